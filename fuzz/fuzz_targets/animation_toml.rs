//! TOML text as `lrr relight --animation`: read, checked, sampled and (when short) relit: Ok
//! or Err, never a panic (`cli::animation_toml`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use lrr_fuzz::{cli, scratch_dir};

fuzz_target!(|data: &[u8]| {
    cli::animation_toml(data, scratch_dir("animation"));
});
