//! What an import may hold, planned before a file is read (`--max-memory`).

use crate::error::Result;

/// Bytes an import of an OBJ or glTF file holds at its peak per byte of the files it reads:
/// the parser's lines or buffers, then the scene's faces and the duplicate index. Measured (the
/// import stage of `lrr bake --report`, over what was resident before it): 24× for a 0.95 MB
/// OBJ of a tessellated sphere, 19× for the 3.5 MB glb of Godot's zdm2, 27× for the 0.18 MB
/// glb of the living room. A glTF's images are decoded within their own bound
/// (`texture::decode`, 2²⁶ texels each), not this one.
pub const IMPORT_BYTES_PER_FILE_BYTE: u128 = 32;

/// Bytes a scene description's parse holds per byte of its text (the TOML tree, then the
/// description's values); its faces come on top ([`IMPORT_BYTES_PER_FACE`]).
pub const DESCRIPTION_BYTES_PER_BYTE: u128 = 16;

/// Bytes an import holds per face a description writes out (its polygons, its indexed faces,
/// six a box): the scene's face (296 bytes), its duplicate key and index entry, the
/// description's record of it. With [`DESCRIPTION_BYTES_PER_BYTE`], fitted to three
/// descriptions and held above each (measured against planned): a tessellated sphere of
/// 20 480 and 81 920 faces (1.04 and 4.37 MB) 28.8 against 29.7 MB and 112.5 against 122.4 MB,
/// 10 000 boxes (0.87 MB, 60 006 faces) 46.8 against 52.3 MB.
pub const IMPORT_BYTES_PER_FACE: u128 = 640;

/// Plans reading `path`, `per_byte` bytes a byte, beside `before` bytes already planned for
/// the import: refuses when the two do not fit `max_memory`; answers their sum. The file's bytes are its own, and for a
/// `.gltf` those of the local files its buffers and images name (read with it). A file that
/// cannot be read is left to the reader's own error.
pub(crate) fn check_import(
    path: &std::path::Path,
    before: u128,
    per_byte: u128,
    max_memory: Option<u64>,
) -> Result<u128> {
    let Ok(meta) = std::fs::metadata(path) else {
        return Ok(before);
    };
    let read = u128::from(meta.len()) + gltf_uri_bytes(path);
    let bytes = before + read * per_byte;
    check_planned(path, read, bytes, max_memory)?;
    Ok(bytes)
}

/// Refuses an import of `path` (`read` bytes of files) planned at `bytes` in all when they do
/// not fit `max_memory`.
pub(crate) fn check_planned(
    path: &std::path::Path,
    read: u128,
    bytes: u128,
    max_memory: Option<u64>,
) -> Result<()> {
    crate::memory::check_then(
        bytes,
        max_memory,
        || {
            format!(
                "importing {} ({} of files)",
                path.display(),
                crate::memory::size(read)
            )
        },
        |_| "simplify the model (fewer triangles), or raise --max-memory".to_string(),
    )
}

/// The bytes of the local files a `.gltf`'s buffers and images name by URI (0 for any other
/// file, and for a JSON that does not parse: the reader reports it).
fn gltf_uri_bytes(path: &std::path::Path) -> u128 {
    let is_gltf = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf"));
    if !is_gltf {
        return 0;
    }
    let Some(json) = std::fs::read(path)
        .ok()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
    else {
        return 0;
    };
    let base = path.parent().unwrap_or(std::path::Path::new("."));
    ["buffers", "images"]
        .iter()
        .filter_map(|key| json.get(key)?.as_array())
        .flatten()
        .filter_map(|item| item.get("uri")?.as_str())
        .filter(|uri| !uri.starts_with("data:"))
        .filter_map(|uri| std::fs::metadata(base.join(uri)).ok())
        .map(|m| u128::from(m.len()))
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `.gltf` is planned with the local files its buffers and images name (not `data:`
    /// URIs, not missing files); any other file alone.
    #[test]
    fn a_gltf_is_planned_with_its_buffer_and_image_files() {
        let dir = std::env::temp_dir().join(format!("lrr-import-plan-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("mesh.bin"), vec![0u8; 1000]).unwrap();
        std::fs::write(dir.join("wall.png"), vec![0u8; 300]).unwrap();
        let json = r#"{"buffers": [{"uri": "mesh.bin"}, {"uri": "data:application/octet-stream;base64,AAAA"}],
                       "images": [{"uri": "wall.png"}, {"uri": "missing.png"}]}"#;
        let gltf = dir.join("scene.gltf");
        std::fs::write(&gltf, json).unwrap();
        let read = json.len() as u128 + 1300;
        assert_eq!(check_import(&gltf, 7, 32, None).unwrap(), 7 + 32 * read);
        let glb = dir.join("scene.glb");
        std::fs::write(&glb, json).unwrap();
        assert_eq!(
            check_import(&glb, 0, 32, None).unwrap(),
            32 * json.len() as u128
        );
        // Over the limit: one line naming the file, its bytes and the advice.
        let err = check_import(&gltf, 0, 32, Some(1000))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("importing ")
                && err.contains("scene.gltf")
                && err.contains("simplify the model"),
            "{err}"
        );
        // A file that cannot be read is left to the reader.
        assert_eq!(
            check_import(&dir.join("none.obj"), 5, 32, Some(1)).unwrap(),
            5
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
