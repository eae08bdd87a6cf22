//! A plan file (a valid plan edited, resealed, or any bytes) read by a shard
//! (`shard::bake_shard` with a plan): Ok or Err, never a panic (`shards::shard_plan`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use lrr_fuzz::{scratch_dir, shards};

fuzz_target!(|data: &[u8]| {
    shards::shard_plan(data, scratch_dir("plan"));
});
