//! Hostile geometry (scales 1e-6 to 1e6, needles, slivers, fans, duplicates) through the whole
//! bake: meshing, grouping, smooth weights, form factors, the file's checks. Ok or Err, never a
//! panic (`harness::bake_geometry`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use lrr_fuzz::{harness, scratch_dir};

fuzz_target!(|data: &[u8]| {
    harness::bake_geometry(data, scratch_dir("bake"));
});
