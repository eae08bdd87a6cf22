//! The bodies of the scene import targets (`obj_import`, `scene_description`, `gltf_import`),
//! shared with the replay test: `fuzz_targets/*.rs` call them through this crate, and
//! `tests/tests/e2e/fuzz_replay.rs` includes this file with `#[path]` and runs every seed and
//! every committed crash input through the same functions, so CI replays them on the stable
//! toolchain without cargo-fuzz. (The operator file and kernel targets live in `runtime/`, a
//! cargo-fuzz project that builds without the bake's dependencies.)
//!
//! Each function takes the fuzzer's bytes and returns whether the input was accepted; refusing
//! it (an `Err`) is fine, panicking is the bug the fuzzer looks for. The functions use only the
//! public API of lrr-precompute.

use std::path::Path;

use lrr_precompute::bake::{BakeSettings, bake};
use lrr_precompute::patches::{CoherenceRule, PatchMethod};
use lrr_precompute::progress::Progress;
use lrr_precompute::scene::{description::SceneDescription, gltf, obj};

/// The MTL written next to the OBJ when the input carries none.
const DEFAULT_MTL: &[u8] =
    b"newmtl white\nKd 0.7 0.7 0.7\nnewmtl light\nKd 0.5 0.5 0.5\nKe 10 10 10\n";
/// A line that splits an `obj_import` input into the OBJ text and the MTL text.
pub const MTL_SEPARATOR: &[u8] = b"\n#--mtl--\n";

/// `obj_import`: the input is an OBJ, optionally followed by [`MTL_SEPARATOR`] and the MTL; they
/// are written to `dir/scene.obj` and `dir/scene.mtl` (an OBJ names it with `mtllib scene.mtl`)
/// and imported.
pub fn obj_import(data: &[u8], dir: &Path) -> bool {
    let (obj_text, mtl_text) = match data
        .windows(MTL_SEPARATOR.len())
        .position(|w| w == MTL_SEPARATOR)
    {
        Some(at) => (&data[..at], &data[at + MTL_SEPARATOR.len()..]),
        None => (data, DEFAULT_MTL),
    };
    let path = dir.join("scene.obj");
    std::fs::write(&path, obj_text).expect("cannot write the fuzz OBJ");
    std::fs::write(dir.join("scene.mtl"), mtl_text).expect("cannot write the fuzz MTL");
    obj::load(&path).is_ok()
}

/// Writes the files a scene description may include: `prop.obj` with its `prop.mtl`.
pub fn prepare_scene_dir(dir: &Path) {
    let obj =
        "mtllib prop.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\ng prop\nusemtl white\nf 1 2 3 4\n";
    std::fs::write(dir.join("prop.obj"), obj).expect("cannot write prop.obj");
    std::fs::write(dir.join("prop.mtl"), DEFAULT_MTL).expect("cannot write prop.mtl");
}

/// `scene_description`: UTF-8 text parsed and built against `dir` (see [`prepare_scene_dir`]).
/// Includes are followed only when they name a plain file in `dir`: a path out of it could be
/// any file of the machine (`/dev/zero` never ends), which tests the machine, not the parser.
pub fn scene_description(data: &[u8], dir: &Path) -> bool {
    let Ok(text) = std::str::from_utf8(data) else {
        return false;
    };
    let Ok(desc) = SceneDescription::parse(text, "fuzz.toml") else {
        return false;
    };
    let plain = |name: &str| {
        !name.is_empty()
            && name != "."
            && name != ".."
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "._-".contains(c))
    };
    if !desc.includes.iter().all(|i| i.path().is_some_and(plain)) {
        return false;
    }
    desc.build("fuzz.toml", dir).is_ok()
}

/// `gltf_import`: the bytes as a `.gltf` (JSON) or `.glb` file imported from `dir` (relative
/// URIs resolve there and may not leave it; see [`prepare_scene_dir`] for what it holds).
pub fn gltf_import(data: &[u8], dir: &Path) -> bool {
    gltf::import(data, dir, "fuzz", "fuzz.gltf").is_ok()
}

/// Most triangles a `bake_geometry` input makes (each 18 bytes after the 2-byte head).
pub const MAX_BAKE_TRIANGLES: usize = 48;

/// `bake_geometry`: hostile geometry through the whole bake (issue #31: import, meshing, the
/// grouping of small faces, smooth weights, 2MSC, form factors, the file's own checks). The
/// input is a head (the scale, `10^(head[0] % 13 - 6)`: 1e-6 to 1e6; `head[1]`: the element
/// size as a fraction of the scene, and bit 7 for `--method 2mf`), then up to
/// [`MAX_BAKE_TRIANGLES`] triangles of nine little-endian i16 coordinates, each times the
/// scale / 256 (needles, slivers, fans, duplicates and coincident vertices come from repeated
/// or nearly equal values). An emitting square is added above them so the bake has light. They
/// are written as an OBJ in `dir` and baked with the default settings at most a 64 MiB
/// `--max-memory`, one thread, 4 samples; the result must be an error, or a file that passes
/// its own checks with finite radiosity.
pub fn bake_geometry(data: &[u8], dir: &Path) -> bool {
    let Some((head, body)) = data.split_first_chunk::<2>() else {
        return false;
    };
    let scale = 10f64.powi(i32::from(head[0] % 13) - 6);
    let at = |c: &[u8]| f64::from(i16::from_le_bytes([c[0], c[1]])) * scale / 256.0;
    let mut obj = String::from("mtllib scene.mtl\n");
    let mut count = 0;
    for t in body.chunks_exact(18).take(MAX_BAKE_TRIANGLES) {
        for v in t.chunks_exact(6) {
            obj.push_str(&format!(
                "v {:e} {:e} {:e}\n",
                at(&v[0..2]),
                at(&v[2..4]),
                at(&v[4..6])
            ));
        }
        count += 1;
    }
    if count == 0 {
        return false;
    }
    // The light: a square of side 256 scale units above the geometry's box (the i16 range).
    let (lo, hi, top) = (-128.0 * scale, 128.0 * scale, 130.0 * scale);
    for (x, z) in [(lo, lo), (hi, lo), (hi, hi), (lo, hi)] {
        obj.push_str(&format!("v {x:e} {top:e} {z:e}\n"));
    }
    obj.push_str("g geometry\nusemtl white\n");
    for i in 0..count {
        let v = 3 * i + 1;
        obj.push_str(&format!("f {} {} {}\n", v, v + 1, v + 2));
    }
    let l = 3 * count + 1;
    obj.push_str(&format!(
        "g light\nusemtl light\nf {} {} {} {}\n",
        l + 3,
        l + 2,
        l + 1,
        l
    ));
    let path = dir.join("bake.obj");
    std::fs::write(&path, obj).expect("cannot write the fuzz OBJ");
    std::fs::write(dir.join("scene.mtl"), DEFAULT_MTL).expect("cannot write the fuzz MTL");
    let Ok(scene) = obj::load(&path) else {
        return false;
    };
    let method = if head[1] & 0x80 != 0 {
        PatchMethod::TwoFixed
    } else {
        PatchMethod::SpatialCoherence {
            threshold: lrr_precompute::patches::coherence::merge::DEFAULT_THRESHOLD,
            min_patch_area: None,
            rule: CoherenceRule::Merge,
        }
    };
    let fraction = f64::from(head[1] & 0x7f).max(2.0);
    let settings = BakeSettings {
        element_size: Some(scene.extent() / fraction),
        method,
        samples: 4,
        threads: Some(1),
        max_memory: Some(64 << 20),
        refine: Some(lrr_precompute::refine::DEFAULT_BUDGET),
        ..BakeSettings::default()
    };
    let Ok(baked) = bake(&scene, &settings, &Progress::hidden()) else {
        return false;
    };
    let file = lrr_precompute::write::operator_file(&baked)
        .expect("a finished bake makes a file that passes its checks");
    file.to_bytes()
        .expect("a finished bake's file passes the checks its encoding runs");
    assert!(
        baked.fk.iter().all(|f| f.is_finite()),
        "non-finite form factors"
    );
    true
}
