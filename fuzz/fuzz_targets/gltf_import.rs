//! glTF JSON or GLB bytes through `lrr_precompute::scene::gltf::import`: Ok or Err, never a
//! panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lrr_fuzz::{harness, scratch_dir};

fuzz_target!(|data: &[u8]| {
    harness::gltf_import(data, scratch_dir("gltf"));
});
