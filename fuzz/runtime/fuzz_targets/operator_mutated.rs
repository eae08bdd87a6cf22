//! A valid operator file edited as the input says (sections re-packed with valid checksums, or
//! raw edits resealed), then loaded: reaches the decoder and the validator past the checksums.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lrr_fuzz_runtime::{alloc, operators};

fuzz_target!(|data: &[u8]| {
    let bytes = operators::mutate(data);
    alloc::check(bytes.len(), || operators::operator_bytes(&bytes));
});
