//! JSON text as `lrr accuracy --reference`: read, checked against the scene and used to
//! measure a bake's error: Ok or Err, never a panic (`cli::reference_json`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use lrr_fuzz::{cli, scratch_dir};

fuzz_target!(|data: &[u8]| {
    cli::reference_json(data, scratch_dir("reference"));
});
