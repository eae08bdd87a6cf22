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
