//! TOML text through `SceneDescription::parse` and `build`: Ok or Err, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lrr_fuzz::{harness, scratch_dir};

fuzz_target!(|data: &[u8]| {
    harness::scene_description(data, scratch_dir("scene"));
});
