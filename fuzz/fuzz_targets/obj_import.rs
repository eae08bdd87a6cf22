//! OBJ (+ MTL) text through `lrr_precompute::scene::obj::load`: Ok or Err, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lrr_fuzz::{harness, scratch_dir};

fuzz_target!(|data: &[u8]| {
    harness::obj_import(data, scratch_dir("obj"));
});
