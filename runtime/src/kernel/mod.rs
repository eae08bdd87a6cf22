//! The hot loop of a frame: `W(s, c) = Σ_q M(s, q) z_c(q)` for a block of rows of the stored
//! matrix `M` (`F_k`, or a channel of `Y_k`), all channels in one pass over the row, and the
//! plain read pass the benchmark compares it with.
//!
//! Two implementations of the same arithmetic:
//! - [`scalar`]: safe Rust, the reference and the fallback on every CPU;
//! - [`avx2`] (x86-64 with AVX2, FMA and F16C, detected at run time): the only `unsafe` code of
//!   the crate. Measured on the development machine (one thread, 1000 rows × k = 216 in cache,
//!   three channels): the safe loop reaches 4.8 GB/s of f32 and 1.8 GB/s of f16 (LLVM vectorises
//!   the lanes to SSE2 at best, without FMA, and has no hardware f16 conversion), the intrinsics
//!   25 GB/s and 10–13 GB/s; memory gives one thread 5–10 GB/s, so only the intrinsics keep up
//!   with it. Tests compare the two on every shape.
//!
//! An AVX-512 version of the gather and the read pass (16 lanes, 4 or 8 rows per block, same
//! prefetch per cache line) was written and measured against this one, alternating in one run
//! (`examples/roofline`, 221184 × 216 f32, 2 threads): median read/frame ratio 0.61–0.64 against
//! 0.82–0.84 for AVX2, with the 512-bit read pass no faster than the 256-bit one. It was not
//! kept.
//!
//! Accuracy: products are summed in 8 f32 lanes over blocks of [`BLOCK`](shared::BLOCK) columns, each block's
//! sum is added in f64. With non-negative terms (form factors, cores of a physical operator,
//! non-negative emission) the relative error of a row is at most about
//! `(BLOCK / 8 + 4) · 2⁻²⁴ ≈ 2.2e-6`, whatever k is.

pub(crate) mod scalar;
pub(crate) mod shared;

#[cfg(feature = "gpu")]
pub(crate) use shared::first_bad_emission;
pub(crate) use shared::{Gather, LANES, Rows, emission_ok, padded};

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2;

/// The instruction set the kernels run on: the safe scalar loops or the AVX2 intrinsics.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SimdLevel {
    /// Safe Rust on any CPU.
    Scalar,
    /// x86-64 AVX2 + FMA + F16C intrinsics.
    Avx2,
}

impl SimdLevel {
    /// The fastest implementation this CPU supports.
    pub fn detect() -> Self {
        if SimdLevel::Avx2.supported() {
            SimdLevel::Avx2
        } else {
            SimdLevel::Scalar
        }
    }

    /// Whether this CPU runs this implementation (an unsupported one falls back to the scalar
    /// kernels).
    pub fn supported(self) -> bool {
        match self {
            SimdLevel::Scalar => true,
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx2 => avx2::supported(),
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// A short name for reports: `"avx2+fma+f16c"` or `"scalar"`.
    pub fn name(self) -> &'static str {
        match self {
            SimdLevel::Scalar => "scalar",
            SimdLevel::Avx2 => "avx2+fma+f16c",
        }
    }
}

/// `w[3 r + offset + c] = Σ_q m(r, q) z[c kp + q]` for `c < C` (1 or 3).
pub(crate) fn gather<const C: usize>(simd: SimdLevel, g: &Gather<'_>, w: &mut [f32]) {
    debug_assert!(g.z.len() >= C * g.kp && g.kp >= g.k && w.len() >= 3 * g.rows());
    match simd {
        #[cfg(target_arch = "x86_64")]
        SimdLevel::Avx2 => avx2::gather::<C>(g, w),
        _ => scalar::gather::<C>(g, w),
    }
}

#[cfg(any(test, feature = "testkit"))]
/// `acc[c kp + q] += Σ_r m(r, q) e[3 r + c]` for every row `r` of `m` (`k` columns) and `c < 3`:
/// the transposed product `Mᵀ E` of the dense-`V` baseline (`testkit`), in f32 (the caller adds
/// `acc` to f64 every few hundred rows). `e` holds 3 interleaved values per row; `acc` is 3
/// planes of `kp >= k` values, left as they are past `k`.
pub(crate) fn transposed(
    simd: SimdLevel,
    m: Rows<'_>,
    k: usize,
    e: &[f32],
    acc: &mut [f32],
    kp: usize,
) {
    debug_assert!(kp >= k && acc.len() >= 3 * kp && e.len() >= 3 * (m.len() / k));
    match simd {
        #[cfg(target_arch = "x86_64")]
        SimdLevel::Avx2 => avx2::transposed(m, k, e, acc, kp),
        _ => scalar::transposed(m, k, e, acc, kp),
    }
}

/// A wrapping sum of every stored word of `m` (f32 bits modulo 2³², or binary16 bits modulo
/// 2¹⁶), so that nothing can be skipped: the memory-read roofline of a gather over the same rows.
pub(crate) fn read_sum(simd: SimdLevel, m: Rows<'_>) -> u64 {
    match simd {
        #[cfg(target_arch = "x86_64")]
        SimdLevel::Avx2 => avx2::read_sum(m),
        _ => scalar::read_sum(m),
    }
}

/// `Σ_j w_j e_j` per channel over one run of interleaved emission (`e.len() == 3 * w.len()`),
/// and whether every value of `e` was allowed ([`emission_ok`]): a segment sum of `X = Vᵀ E`.
/// Accuracy: the AVX2 version sums [`SUM_STEPS`](shared::SUM_STEPS) products per f32 lane before adding in f64,
/// so with non-negative weights and emission a sum's relative error is at most about
/// `(SUM_STEPS + 1) · 2⁻²⁴ ≈ 2e-6`; the scalar twin sums in f64.
pub(crate) fn sums_interleaved(simd: SimdLevel, w: &[f32], e: &[f32]) -> ([f64; 3], bool) {
    debug_assert_eq!(e.len(), 3 * w.len());
    match simd {
        #[cfg(target_arch = "x86_64")]
        SimdLevel::Avx2 => avx2::sums_interleaved(w, e),
        _ => scalar::sums_interleaved(w, e),
    }
}

/// [`sums_interleaved`] over three planes, each as long as `w`.
pub(crate) fn sums_planar(simd: SimdLevel, w: &[f32], e: [&[f32]; 3]) -> ([f64; 3], bool) {
    debug_assert!(e.iter().all(|p| p.len() == w.len()));
    match simd {
        #[cfg(target_arch = "x86_64")]
        SimdLevel::Avx2 => avx2::sums_planar(w, e),
        _ => scalar::sums_planar(w, e),
    }
}

#[cfg(test)]
pub(crate) mod tests {
    /// A deterministic sequence of positive values spread over several binades.
    pub(crate) fn values(len: usize, seed: u64) -> Vec<f32> {
        let mut s = seed;
        (0..len)
            .map(|_| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((s >> 40) as f32 / (1u64 << 24) as f32) * 2f32.powi((s >> 20) as i32 % 8 - 4)
            })
            .collect()
    }
}
