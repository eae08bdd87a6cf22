//! A valid file with display sections (BVH, materials, lights, camera) edited as the input
//! says, then loaded, made into a ray tracer and rendered: refused or rendered, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lrr_fuzz_runtime::trace;

fuzz_target!(|data: &[u8]| {
    trace::trace_mutated(data);
});
