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

/// Vector steps (of [`LANES`] products per lane) summed in f32 before a segment sum adds them
/// in f64.
pub(crate) const SUM_STEPS: usize = 32;

/// `kp`: `k` rounded up to whole lanes (the padded length of a `z` plane).
pub(crate) fn padded(k: usize) -> usize {
    k.next_multiple_of(LANES)
}
