//! What the scalar and AVX2 kernels share: block sizes, the view of a block of stored rows, the
//! shape of one gather, and the emission check both apply.

/// Columns summed in f32 before the partial sum is added in f64.
pub(crate) const BLOCK: usize = 256;

/// f32 lanes of the accumulators (one AVX2 register).
pub(crate) const LANES: usize = 8;

/// A block of whole rows of the stored matrix, `rows × k` values, row-major.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Rows<'a> {
    F32(&'a [f32]),
    F16(&'a [u16]),
}

impl Rows<'_> {
    /// Number of values.
    pub(crate) fn len(&self) -> usize {
        match self {
            Rows::F32(v) => v.len(),
            Rows::F16(v) => v.len(),
        }
    }
}

/// The shape of one gather: `C` channels from `z` (`C` planes of `kp >= k` values, zero past
/// `k`) into `w[3 r + offset + c]` for every row `r` of `m`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Gather<'a> {
    pub m: Rows<'a>,
    pub k: usize,
    pub z: &'a [f32],
    pub kp: usize,
    pub offset: usize,
}

impl Gather<'_> {
    /// Rows of `m`.
    pub(crate) fn rows(&self) -> usize {
        self.m.len() / self.k
    }
}

/// Whether an emission value is allowed: finite and >= 0 (false for NaN).
#[inline(always)]
pub(crate) fn emission_ok(v: f32) -> bool {
    (0.0..=f32::MAX).contains(&v)
}

/// The first value of `values` that [`emission_ok`] refuses, if any. Checks 256 values at a
/// time with a fold that does not stop early (which the compiler vectorises: two compares and
/// an and per value, no branch), and looks for the position only in a block that failed. A
/// scalar `position` (a compare and a branch per value) cost the GPU path 0.4 ms of host time a
/// frame at n = 221184; this takes 0.09 ms (docs/PERFORMANCE.md, GPU). (The CPU frame checks
/// the values as its segment sums add them.)
#[cfg(any(feature = "gpu", test))]
pub(crate) fn first_bad_emission(values: &[f32]) -> Option<usize> {
    const BLOCK: usize = 256;
    for (b, block) in values.chunks(BLOCK).enumerate() {
        let ok = block.iter().fold(true, |ok, &v| ok & emission_ok(v));
        if !ok {
            let i = block.iter().position(|&v| !emission_ok(v))?;
            return Some(b * BLOCK + i);
        }
    }
    None
}

/// Vector steps (of [`LANES`] products per lane) summed in f32 before a segment sum adds them
/// in f64.
pub(crate) const SUM_STEPS: usize = 32;

/// `kp`: `k` rounded up to whole lanes (the padded length of a `z` plane).
pub(crate) fn padded(k: usize) -> usize {
    k.next_multiple_of(LANES)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_bad_emission_finds_the_first_refused_value() {
        let mut v = vec![0.5f32; 1000];
        assert_eq!(first_bad_emission(&v), None);
        assert_eq!(first_bad_emission(&[]), None);
        for (at, bad) in [
            (0, -1.0),
            (255, f32::NAN),
            (256, f32::INFINITY),
            (999, -0.0001),
            (700, f32::NEG_INFINITY),
        ] {
            let keep = v[at];
            v[at] = bad;
            assert_eq!(first_bad_emission(&v), Some(at), "{bad} at {at}");
            v[at] = keep;
        }
        v[300] = f32::NAN;
        v[900] = -1.0;
        assert_eq!(first_bad_emission(&v), Some(300));
        // -0.0, 0, the largest finite value are allowed, as by emission_ok.
        assert_eq!(first_bad_emission(&[-0.0, 0.0, f32::MAX, 1e-45]), None);
    }
}
