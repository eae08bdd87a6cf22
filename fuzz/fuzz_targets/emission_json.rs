//! JSON text as `lrr probe --emission`: Ok or Err, never a panic (`cli::emission_json`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use lrr_fuzz::{cli, scratch_dir};

fuzz_target!(|data: &[u8]| {
    cli::emission_json(data, scratch_dir("emission"));
});
