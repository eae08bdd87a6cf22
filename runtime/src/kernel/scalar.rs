//! The kernels in safe Rust: the reference for [`avx2`](super::avx2) and the fallback on every
//! other CPU. Same arithmetic: 8 f32 lanes per block of [`BLOCK`] columns, block sums in f64.

use super::shared::{BLOCK, Gather, LANES, Rows};

/// The f32 value of the binary16 bits `h`, for finite values only (stored matrices are validated
/// finite): branch-free so that it vectorises. Normals move the exponent bias from 15 to 127;
/// subnormals `m · 2⁻²⁴` are built as `(2⁻¹⁴ + m · 2⁻²⁴) - 2⁻¹⁴`, exact, and never touch f32
/// subnormals (slow on some CPUs). A 65536-entry table was the alternative: a dependent load per
/// value that does not vectorise.
#[inline(always)]
pub(crate) fn f16_finite_to_f32(h: u16) -> f32 {
    let h = u32::from(h);
    let magnitude = (h & 0x7FFF) << 13;
    let normal = f32::from_bits(magnitude + (112 << 23));
    let subnormal = f32::from_bits(magnitude + (113 << 23)) - f32::from_bits(113 << 23);
    let value = if h & 0x7C00 == 0 { subnormal } else { normal };
    f32::from_bits(value.to_bits() | (h & 0x8000) << 16)
}

/// See [`super::sums_interleaved`]: every product in f64, four elements per step in four sets
/// of sums to cut the chain of dependent additions (measured for n = 221184: 2.6 ms element by
/// element, 0.9 ms per run with two sets, 0.72 ms with four).
pub(crate) fn sums_interleaved(w: &[f32], e: &[f32]) -> ([f64; 3], bool) {
    const STEP: usize = 4;
    let mut sums = [[0.0f64; 3]; STEP];
    let mut ok = true;
    let (groups, weights) = (e.chunks_exact(3 * STEP), w.chunks_exact(STEP));
    let (tail, tail_w) = (groups.remainder(), weights.remainder());
    for (v, w) in groups.zip(weights) {
        for (j, sum) in sums.iter_mut().enumerate() {
            for c in 0..3 {
                let x = v[3 * j + c];
                ok &= super::shared::emission_ok(x);
                sum[c] += f64::from(w[j]) * f64::from(x);
            }
        }
    }
    for (v, &w) in tail.chunks_exact(3).zip(tail_w) {
        for c in 0..3 {
            ok &= super::shared::emission_ok(v[c]);
            sums[0][c] += f64::from(w) * f64::from(v[c]);
        }
    }
    let total = std::array::from_fn(|c| (sums[0][c] + sums[1][c]) + (sums[2][c] + sums[3][c]));
    (total, ok)
}

/// See [`super::sums_planar`]: [`sums_interleaved`] for three planes.
pub(crate) fn sums_planar(w: &[f32], e: [&[f32]; 3]) -> ([f64; 3], bool) {
    let mut sums = [0.0f64; 3];
    let mut ok = true;
    for (c, plane) in e.into_iter().enumerate() {
        let mut pair = [0.0f64; 2];
        for (j, (&x, &w)) in plane.iter().zip(w).enumerate() {
            ok &= super::shared::emission_ok(x);
            pair[j % 2] += f64::from(w) * f64::from(x);
        }
        sums[c] = pair[0] + pair[1];
    }
    (sums, ok)
}

/// See [`super::gather`].
pub(crate) fn gather<const C: usize>(g: &Gather<'_>, w: &mut [f32]) {
    let k = g.k;
    let mut buf = [0.0f32; BLOCK];
    for (r, out) in w.chunks_exact_mut(3).take(g.rows()).enumerate() {
        let mut total = [0.0f64; C];
        for q0 in (0..k).step_by(BLOCK) {
            let len = BLOCK.min(k - q0);
            let padded = len.next_multiple_of(LANES);
            let values = &mut buf[..padded];
            let at = r * k + q0;
            match g.m {
                Rows::F32(m) => values[..len].copy_from_slice(&m[at..at + len]),
                Rows::F16(m) => {
                    for (v, &h) in values.iter_mut().zip(&m[at..at + len]) {
                        *v = f16_finite_to_f32(h);
                    }
                }
            }
            values[len..].fill(0.0);
            for (c, t) in total.iter_mut().enumerate() {
                let z = &g.z[c * g.kp + q0..c * g.kp + q0 + padded];
                *t += f64::from(dot(values, z));
            }
        }
        for (c, t) in total.iter().enumerate() {
            out[g.offset + c] = *t as f32;
        }
    }
}

#[cfg(any(test, feature = "testkit"))]
/// See [`super::transposed`]: one row at a time, [`BLOCK`] columns at a time, each channel an
/// f32 axpy over the block.
pub(crate) fn transposed(m: Rows<'_>, k: usize, e: &[f32], acc: &mut [f32], kp: usize) {
    let mut buf = [0.0f32; BLOCK];
    for (r, er) in e.chunks_exact(3).take(m.len() / k).enumerate() {
        for q0 in (0..k).step_by(BLOCK) {
            let len = BLOCK.min(k - q0);
            let values = &mut buf[..len];
            let at = r * k + q0;
            match m {
                Rows::F32(m) => values.copy_from_slice(&m[at..at + len]),
                Rows::F16(m) => {
                    for (v, &h) in values.iter_mut().zip(&m[at..at + len]) {
                        *v = f16_finite_to_f32(h);
                    }
                }
            }
            for (c, &ec) in er.iter().enumerate() {
                let plane = &mut acc[c * kp + q0..c * kp + q0 + len];
                for (a, &v) in plane.iter_mut().zip(values.iter()) {
                    *a += v * ec;
                }
            }
        }
    }
}

/// `Σ a b` in [`LANES`] f32 lanes; the lengths are equal multiples of [`LANES`].
fn dot(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0.0f32; LANES];
    for (x, y) in a.chunks_exact(LANES).zip(b.chunks_exact(LANES)) {
        for j in 0..LANES {
            acc[j] += x[j] * y[j];
        }
    }
    reduce(acc)
}

/// Pairwise sum of the lanes, in the order of the AVX2 horizontal sum.
pub(crate) fn reduce(acc: [f32; LANES]) -> f32 {
    let half: [f32; 4] = std::array::from_fn(|j| acc[j] + acc[j + 4]);
    (half[0] + half[2]) + (half[1] + half[3])
}

/// See [`super::read_sum`]: independent integer lanes as wide as the stored words (16 × u32, or
/// 32 × u16 for binary16), which vectorise into plain loads and adds on any CPU. (Widening the
/// u16 words to u32 lanes made the f16 read pass compute-bound at about 3.5 GB/s, slower than
/// the f16 gather.) The sum is exact modulo 2³² (f32) or 2¹⁶ (f16) whatever the split.
pub(crate) fn read_sum(m: Rows<'_>) -> u64 {
    match m {
        Rows::F32(v) => {
            let mut acc = [0u32; 16];
            let chunks = v.chunks_exact(16);
            let tail = chunks
                .remainder()
                .iter()
                .fold(0u32, |a, x| a.wrapping_add(x.to_bits()));
            for c in chunks {
                for j in 0..16 {
                    acc[j] = acc[j].wrapping_add(c[j].to_bits());
                }
            }
            u64::from(acc.iter().fold(tail, |a, &x| a.wrapping_add(x)))
        }
        Rows::F16(v) => {
            let mut acc = [0u16; 32];
            let chunks = v.chunks_exact(32);
            let tail = chunks
                .remainder()
                .iter()
                .fold(0u16, |a, &x| a.wrapping_add(x));
            for c in chunks {
                for j in 0..32 {
                    acc[j] = acc[j].wrapping_add(c[j]);
                }
            }
            u64::from(acc.iter().fold(tail, |a, &x| a.wrapping_add(x)))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f16_conversion_is_exact_for_every_finite_value() {
        for h in 0..=u16::MAX {
            let exact = lrr_formats::f16_to_f32(h);
            if exact.is_finite() {
                assert_eq!(f16_finite_to_f32(h).to_bits(), exact.to_bits(), "{h:#06x}");
            }
        }
    }

    #[test]
    fn transposed_adds_the_product_of_the_transpose() {
        let (rows, k, kp) = (5, 11, 16);
        let m = super::super::tests::values(rows * k, 3);
        let e = super::super::tests::values(3 * rows, 8);
        let mut acc = vec![1.0f32; 3 * kp];
        transposed(Rows::F32(&m), k, &e, &mut acc, kp);
        for c in 0..3 {
            for q in 0..kp {
                let want = 1.0
                    + if q < k {
                        (0..rows)
                            .map(|r| f64::from(m[r * k + q]) * f64::from(e[3 * r + c]))
                            .sum()
                    } else {
                        0.0
                    };
                let got = f64::from(acc[c * kp + q]);
                assert!(
                    (got - want).abs() <= 1e-6 * want,
                    "c {c} q {q}: {got} vs {want}"
                );
            }
        }
    }

    #[test]
    fn read_sum_sees_every_word() {
        let v: Vec<f32> = (0..37).map(|i| i as f32).collect();
        let base = read_sum(Rows::F32(&v));
        for i in 0..v.len() {
            let mut w = v.clone();
            w[i] = f32::from_bits(w[i].to_bits() + 1);
            assert_eq!(read_sum(Rows::F32(&w)), base + 1, "word {i}");
        }
        let h: Vec<u16> = (0..37).collect();
        assert_eq!(read_sum(Rows::F16(&h)), 666);
        let wide: Vec<u16> = vec![0xFFFF; 70];
        assert_eq!(read_sum(Rows::F16(&wide)), u64::from(0u16.wrapping_sub(70)));
    }
}
