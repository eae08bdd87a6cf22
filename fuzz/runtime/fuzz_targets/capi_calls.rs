//! The C interface driven by a sequence of calls (load, evaluate, baked emission, locate,
//! direct pass, lightmap, free, last error) in any order with any lengths: every call returns
//! a status of lrr.h, never a caught panic (`capi::capi_calls`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use lrr_fuzz_runtime::capi;

fuzz_target!(|data: &[u8]| {
    capi::capi_calls(data);
});
