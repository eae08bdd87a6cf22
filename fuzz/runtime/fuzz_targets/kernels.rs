//! Arbitrary operators and emissions through the frame's kernels (segment sums and gather), the
//! AVX2 ones and their scalar twins: the same answer to every input, each within the stated
//! bound of an f64 evaluation, never a panic. See `kernels::kernels`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    lrr_fuzz_runtime::kernels::kernels(data);
});
