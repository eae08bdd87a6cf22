//! What an import may hold, planned before a file is read (`--max-memory`).

use crate::error::Result;

/// Bytes an import holds at its peak per byte of the files it reads, at most: the parser's
/// tree (a TOML description's values, an OBJ's lines, a glTF's buffers), then the scene's faces
/// (about 300 bytes each) and the duplicate index. Measured peaks (the import stage of `lrr
/// bake --report`, over what was resident before it): 25.6× and 27.7× for 4.4 and 1.04 MB
/// descriptions of a tessellated sphere, 24× for a 0.95 MB OBJ of it, 19× for the 3.5 MB glb
/// of Godot's zdm2, 27–30× for the 0.18 MB glb of the living room. A glTF's images are decoded within
/// their own bound (`texture::decode`, 2²⁶ texels each), not this one.
pub const IMPORT_BYTES_PER_FILE_BYTE: u128 = 32;

/// Plans reading `path` beside `before` bytes already planned for the import: refuses when
/// the two do not fit `max_memory`; answers their sum. A file that cannot be read is left to
/// the reader's own error.
pub(crate) fn check_import(
    path: &std::path::Path,
    before: u128,
    max_memory: Option<u64>,
) -> Result<u128> {
    let Ok(meta) = std::fs::metadata(path) else {
        return Ok(before);
    };
    let bytes = before + u128::from(meta.len()) * IMPORT_BYTES_PER_FILE_BYTE;
    crate::memory::check_then(
        bytes,
        max_memory,
        || {
            format!(
                "importing {} ({:.1} MB)",
                path.display(),
                meta.len() as f64 / 1e6
            )
        },
        |_| "simplify the model (fewer triangles), or raise --max-memory".to_string(),
    )?;
    Ok(bytes)
}
