//! A bake resumed from a checkpoint the input spells (records of any index, length,
//! values and checksum): Ok or Err, never a panic; a finished bake's file passes its checks
//! (`shards::checkpoint_resume`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use lrr_fuzz::{scratch_dir, shards};

fuzz_target!(|data: &[u8]| {
    shards::checkpoint_resume(data, scratch_dir("ckpt"));
});
