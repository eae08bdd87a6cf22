//! JSON text as `lrr probe --points`: Ok or Err, never a panic (`cli::probe_points`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use lrr_fuzz::{cli, scratch_dir};

fuzz_target!(|data: &[u8]| {
    cli::probe_points(data, scratch_dir("points"));
});
