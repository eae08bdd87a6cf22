//! Parts of a sharded bake (a valid part edited, checksums resealed, or any bytes) merged
//! by `shard::merge`: Ok or Err, never a panic; a merged file loads (`shards::shard_part`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use lrr_fuzz::{scratch_dir, shards};

fuzz_target!(|data: &[u8]| {
    shards::shard_part(data, scratch_dir("part"));
});
