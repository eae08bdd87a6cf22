//! Arbitrary bytes through `lrr_runtime::Operator::from_bytes`: Ok or Err, never a panic, and no
//! allocation beyond what the input justifies.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lrr_fuzz_runtime::{alloc, operators};

fuzz_target!(|data: &[u8]| {
    alloc::check(data.len(), || operators::operator_bytes(data));
});
