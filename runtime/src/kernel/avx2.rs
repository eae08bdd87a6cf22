//! The kernels with x86-64 AVX2, FMA and F16C intrinsics: the crate's only `unsafe` code.
//!
//! Every `unsafe` block is a load of 8 values from a Rust array of exactly that size, or a call
//! into a `#[target_feature]` function after [`supported`] said yes. The arithmetic mirrors
//! [`scalar`](super::scalar) (8 lanes, [`BLOCK`]-column blocks, f64 block sums); results differ
//! only by rounding (fused multiply-add), which the tests bound.
//!
//! Rows are processed `R` at a time so that one load of `z` serves `R` rows and `R · C`
//! independent FMA chains hide the FMA latency: for three channels `R = 4` in f32 (12
//! accumulators + 3 `z` + 1 row register = 16 ymm) and `R = 3` in binary16 (the conversion
//! needs a second temporary: with `R = 4` LLVM kept one accumulator on the stack), `R = 8` for
//! one channel. The column loop of a block is its own function ([`lane_sums`]): inlined into the
//! row loop, the `R · C` f64 block totals held vector registers across it and LLVM spilled two
//! accumulators of the three-channel loop to the stack (a store and a reload in their chains).
//! Taking it out (2026-11-23, one thread, 960 rows × 216 in L2, best of 30 alternated runs):
//! binary16 three channels 15.2 → 16.5 GB/s (17.1 with `R = 4` and its spill), one channel
//! 28.6 → 35.4; f32 34.5 → 36.1 and 47.1 → 49.6. Three-channel binary16 now computes about as
//! many values per second as f32 (8.3 against 9.0 G/s), so half the bytes per value need
//! twice the compute per byte: with 3 FMAs per 8 values and row, the conversion's µop on the
//! same ports is what AVX2 cannot hide (AVX-512's second FMA port could; see PERFORMANCE.md). Measured on the development machine, one
//! thread, 1000 rows × k = 216 in cache, three channels: f32 8, 22 and 25–27 GB/s with
//! `R = 1, 2, 4`, f16 5.5, 11 and 10–13.6 GB/s (the scalar twin: 4.8 and 1.8 GB/s); one channel
//! with `R = 4, 8`: f32 41 and 50 GB/s, f16 24 and 27 GB/s. Two things mattered as much as `R`:
//! slicing each row once per column block (indices inside the loop then need no bounds checks:
//! 17 → 25 GB/s), and no closures in the loop (a closure does not inherit the target features,
//! so its intrinsics would become calls).
//!
//! From memory the loop waited on loads: the hardware prefetcher did not run far enough ahead of
//! a loop that also computes (one thread, 191 MB: 5.2 GB/s against 8.4 for a plain read). A
//! software prefetch of the same columns one block of `R` rows ahead brought it to 9.8 GB/s.
//! Without it the frame falls to 0.47 of the read (221184 × 216 f32, 2 threads, from L3). A
//! second prefetch into L2 only (`T1`), four blocks ahead, then raised the frame's share of the
//! read from a median of 0.78 (0.76–0.80) to 0.84 (0.80–0.87) over 9 alternated runs of
//! `examples/roofline` (same build otherwise); eight blocks ahead was no better, and the same
//! extra prefetch in the read pass did not make the read faster, so the roofline does without.
//! Prefetching binary16 as far ahead in bytes as f32 (twice the rows) was measured against
//! this (`examples/roofline 221184 216 2 f16 20`, 5 alternated runs on the loaded machine):
//! medians of pairs 0.67–0.80 against 0.65–0.78, no difference; not kept.

#![allow(unsafe_code)]

use std::arch::x86_64::{
    __m128i, __m256, __m256i, _CMP_NGE_UQ, _CMP_NLE_UQ, _MM_HINT_T0, _MM_HINT_T1, _mm_add_ps,
    _mm_add_ss, _mm_cvtss_f32, _mm_loadu_si128, _mm_movehdup_ps, _mm_movehl_ps, _mm_prefetch,
    _mm256_add_epi16, _mm256_add_epi32, _mm256_castps_si256, _mm256_castps256_ps128, _mm256_cmp_ps,
    _mm256_cvtph_ps, _mm256_extract_epi32, _mm256_extractf128_ps, _mm256_fmadd_ps, _mm256_loadu_ps,
    _mm256_loadu_si256, _mm256_movemask_ps, _mm256_or_ps, _mm256_permutevar8x32_ps, _mm256_set1_ps,
    _mm256_setr_epi32, _mm256_setzero_ps, _mm256_setzero_si256,
};

use super::shared::{BLOCK, Gather, LANES, Rows, SUM_STEPS};

/// Whether this CPU has AVX2, FMA and F16C (std caches the answer).
pub(crate) fn supported() -> bool {
    is_x86_feature_detected!("avx2")
        && is_x86_feature_detected!("fma")
        && is_x86_feature_detected!("f16c")
}

/// See [`super::gather`]; falls back to [`scalar`](super::scalar) on a CPU without the features.
pub(crate) fn gather<const C: usize>(g: &Gather<'_>, w: &mut [f32]) {
    if !supported() {
        return super::scalar::gather::<C>(g, w);
    }
    // The element type and the row count become constants, so the inner loop has no branch.
    let (f32s, f16s): (&[f32], &[u16]) = match g.m {
        Rows::F32(v) => (v, &[]),
        Rows::F16(v) => (&[], v),
    };
    let f16 = matches!(g.m, Rows::F16(_));
    // SAFETY: `supported()` confirmed AVX2, FMA and F16C on this CPU.
    unsafe {
        match (C == 3, f16) {
            (true, false) => rows::<C, 4, false>(g, f32s, f16s, w),
            (true, true) => rows::<C, 3, true>(g, f32s, f16s, w),
            (false, false) => rows::<C, 8, false>(g, f32s, f16s, w),
            (false, true) => rows::<C, 8, true>(g, f32s, f16s, w),
        }
    }
}

/// Every row of `g`, `R` at a time; the values are `f32s`, or `f16s` when `H`.
#[target_feature(enable = "avx2,fma,f16c")]
fn rows<const C: usize, const R: usize, const H: bool>(
    g: &Gather<'_>,
    f32s: &[f32],
    f16s: &[u16],
    w: &mut [f32],
) {
    let n = g.rows();
    let mut r = 0;
    while r + R <= n {
        block::<C, R, H>(g, f32s, f16s, r, w);
        r += R;
    }
    while r < n {
        block::<C, 1, H>(g, f32s, f16s, r, w);
        r += 1;
    }
}

/// Rows `r0..r0 + R`: the lane sums of each [`BLOCK`] of columns ([`lane_sums`]) added in f64.
#[target_feature(enable = "avx2,fma,f16c")]
#[inline]
fn block<const C: usize, const R: usize, const H: bool>(
    g: &Gather<'_>,
    f32s: &[f32],
    f16s: &[u16],
    r0: usize,
    w: &mut [f32],
) {
    let k = g.k;
    let mut total = [[0.0f64; C]; R];
    let mut q0 = 0;
    while q0 < k {
        let len = BLOCK.min(k - q0);
        let acc = lane_sums::<C, R, H>(g, f32s, f16s, r0, q0, len);
        for r in 0..R {
            for c in 0..C {
                total[r][c] += f64::from(hsum(acc[r][c]));
            }
        }
        q0 += len;
    }
    for r in 0..R {
        for c in 0..C {
            w[3 * (r0 + r) + g.offset + c] = total[r][c] as f32;
        }
    }
}

/// The `R · C` accumulators of rows `r0..r0 + R` over the columns `q0..q0 + len` (`len <=
/// BLOCK`). Its own function, never inlined: the caller's `R · C` f64 totals would otherwise
/// hold vector registers through this loop, which then spilled accumulators to the stack (a
/// store and a reload in every step of their chain).
///
/// The loop goes one cache line of each row at a time (2 vector steps of f32, 4 of binary16):
/// first the prefetches of that line for the rows one block ahead (into L1) and four blocks
/// ahead (into L2), then the steps. Prefetch addresses are the row's own pointer plus a fixed
/// offset, so they need no registers of their own.
#[target_feature(enable = "avx2,fma,f16c")]
#[inline(never)]
fn lane_sums<const C: usize, const R: usize, const H: bool>(
    g: &Gather<'_>,
    f32s: &[f32],
    f16s: &[u16],
    r0: usize,
    q0: usize,
    len: usize,
) -> [[__m256; C]; R] {
    let k = g.k;
    let full = len / LANES;
    let mut acc = [[_mm256_setzero_ps(); C]; R];
    // Slices of exactly `full` vectors, so the loop's indices need no bounds checks.
    let span = full * LANES;
    let mut zs: [&[f32]; C] = [&[]; C];
    for c in 0..C {
        zs[c] = &g.z[c * g.kp + q0..c * g.kp + q0 + span];
    }
    let mut rf: [&[f32]; R] = [&[]; R];
    let mut rh: [&[u16]; R] = [&[]; R];
    for r in 0..R {
        let at = (r0 + r) * k + q0;
        if H {
            rh[r] = &f16s[at..at + span];
        } else {
            rf[r] = &f32s[at..at + span];
        }
    }
    let per_line = if H {
        64 / (2 * LANES)
    } else {
        64 / (4 * LANES)
    };
    let (near, far) = (R * k, 4 * R * k);
    for v in 0..full {
        let q = v * LANES;
        if v % per_line == 0 {
            for r in 0..R {
                if H {
                    prefetch(rh[r], q + near);
                    prefetch_l2(rh[r], q + far);
                } else {
                    prefetch(rf[r], q + near);
                    prefetch_l2(rf[r], q + far);
                }
            }
        }
        step::<C, R, H>(&zs, &rf, &rh, q, &mut acc);
    }
    let tail = len - span;
    if tail != 0 {
        let q = q0 + span;
        let mut zv = [_mm256_setzero_ps(); C];
        for c in 0..C {
            zv[c] = load_f32(&g.z[c * g.kp + q..]);
        }
        for r in 0..R {
            let at = (r0 + r) * k + q;
            let f = if H {
                let mut padded = [0u16; LANES];
                padded[..tail].copy_from_slice(&f16s[at..at + tail]);
                load_f16(&padded)
            } else {
                let mut padded = [0.0f32; LANES];
                padded[..tail].copy_from_slice(&f32s[at..at + tail]);
                load_f32(&padded)
            };
            for c in 0..C {
                acc[r][c] = _mm256_fmadd_ps(f, zv[c], acc[r][c]);
            }
        }
    }
    acc
}

/// One vector step of [`lane_sums`] at column `q` of the slices: `C` loads of `z`, then per row
/// one load (widened by F16C when `H`) and `C` fused multiply-adds.
#[target_feature(enable = "avx2,fma,f16c")]
#[inline]
fn step<const C: usize, const R: usize, const H: bool>(
    zs: &[&[f32]; C],
    rf: &[&[f32]; R],
    rh: &[&[u16]; R],
    q: usize,
    acc: &mut [[__m256; C]; R],
) {
    let mut zv = [_mm256_setzero_ps(); C];
    for c in 0..C {
        zv[c] = load_f32(&zs[c][q..q + LANES]);
    }
    for r in 0..R {
        let f = if H {
            load_f16(&rh[r][q..q + LANES])
        } else {
            load_f32(&rf[r][q..q + LANES])
        };
        for c in 0..C {
            acc[r][c] = _mm256_fmadd_ps(f, zv[c], acc[r][c]);
        }
    }
}

#[cfg(any(test, feature = "testkit"))]
/// See [`super::transposed`]; falls back to [`scalar`](super::scalar) on a CPU without the
/// features.
pub(crate) fn transposed(m: Rows<'_>, k: usize, e: &[f32], acc: &mut [f32], kp: usize) {
    if !supported() {
        return super::scalar::transposed(m, k, e, acc, kp);
    }
    let t = Transposed { k, kp, e };
    // SAFETY: `supported()` confirmed AVX2, FMA and F16C on this CPU.
    unsafe {
        match m {
            Rows::F32(v) => t_rows::<TRANSPOSED_ROWS, false>(&t, v, &[], acc),
            Rows::F16(v) => t_rows::<TRANSPOSED_ROWS, true>(&t, &[], v, acc),
        }
    }
}

#[cfg(any(test, feature = "testkit"))]
/// Rows per block of [`transposed`]: 3 rows × 3 channels of broadcast emission, 3 accumulators
/// and a row register (13 of the 16 ymm registers).
const TRANSPOSED_ROWS: usize = 3;

#[cfg(any(test, feature = "testkit"))]
/// The shape of one [`transposed`] call.
struct Transposed<'a> {
    k: usize,
    kp: usize,
    e: &'a [f32],
}

#[cfg(any(test, feature = "testkit"))]
/// Every row of `f32s` (or `f16s` when `H`), `R` at a time.
#[target_feature(enable = "avx2,fma,f16c")]
fn t_rows<const R: usize, const H: bool>(
    t: &Transposed<'_>,
    f32s: &[f32],
    f16s: &[u16],
    acc: &mut [f32],
) {
    let n = if H { f16s.len() } else { f32s.len() } / t.k;
    let mut r = 0;
    while r + R <= n {
        t_block::<R, H>(t, f32s, f16s, r, acc);
        r += R;
    }
    while r < n {
        t_block::<1, H>(t, f32s, f16s, r, acc);
        r += 1;
    }
}

#[cfg(any(test, feature = "testkit"))]
/// Rows `r0..r0 + R` of [`transposed`]: per vector of columns, the 3 accumulators are loaded
/// once, take `3 R` fused multiply-adds and are stored back. Prefetch as in [`lane_sums`].
#[target_feature(enable = "avx2,fma,f16c")]
#[inline(never)]
fn t_block<const R: usize, const H: bool>(
    t: &Transposed<'_>,
    f32s: &[f32],
    f16s: &[u16],
    r0: usize,
    acc: &mut [f32],
) {
    let (k, kp) = (t.k, t.kp);
    let full = k / LANES;
    let span = full * LANES;
    let mut ev = [[_mm256_setzero_ps(); 3]; R];
    for r in 0..R {
        for c in 0..3 {
            ev[r][c] = _mm256_set1_ps(t.e[3 * (r0 + r) + c]);
        }
    }
    let mut rf: [&[f32]; R] = [&[]; R];
    let mut rh: [&[u16]; R] = [&[]; R];
    for r in 0..R {
        let at = (r0 + r) * k;
        if H {
            rh[r] = &f16s[at..at + span];
        } else {
            rf[r] = &f32s[at..at + span];
        }
    }
    let (a0, rest) = acc.split_at_mut(kp);
    let (a1, a2) = rest.split_at_mut(kp);
    let planes: [&mut [f32]; 3] = [&mut a0[..kp], &mut a1[..kp], &mut a2[..kp]];
    let per_line = if H {
        64 / (2 * LANES)
    } else {
        64 / (4 * LANES)
    };
    let (near, far) = (R * k, 4 * R * k);
    for v in 0..full {
        let q = v * LANES;
        if v % per_line == 0 {
            for r in 0..R {
                if H {
                    prefetch(rh[r], q + near);
                    prefetch_l2(rh[r], q + far);
                } else {
                    prefetch(rf[r], q + near);
                    prefetch_l2(rf[r], q + far);
                }
            }
        }
        let mut a = [_mm256_setzero_ps(); 3];
        for c in 0..3 {
            a[c] = load_f32(&planes[c][q..q + LANES]);
        }
        for r in 0..R {
            let f = if H {
                load_f16(&rh[r][q..q + LANES])
            } else {
                load_f32(&rf[r][q..q + LANES])
            };
            for c in 0..3 {
                a[c] = _mm256_fmadd_ps(f, ev[r][c], a[c]);
            }
        }
        for c in 0..3 {
            store_f32(&mut planes[c][q..q + LANES], a[c]);
        }
    }
    let tail = k - span;
    if tail != 0 {
        // The planes are `kp >= span + LANES` long; the padded columns take products with 0.
        let mut a = [_mm256_setzero_ps(); 3];
        for c in 0..3 {
            a[c] = load_f32(&planes[c][span..span + LANES]);
        }
        for r in 0..R {
            let at = (r0 + r) * k + span;
            let f = if H {
                let mut padded = [0u16; LANES];
                padded[..tail].copy_from_slice(&f16s[at..at + tail]);
                load_f16(&padded)
            } else {
                let mut padded = [0.0f32; LANES];
                padded[..tail].copy_from_slice(&f32s[at..at + tail]);
                load_f32(&padded)
            };
            for c in 0..3 {
                a[c] = _mm256_fmadd_ps(f, ev[r][c], a[c]);
            }
        }
        for c in 0..3 {
            store_f32(&mut planes[c][span..span + LANES], a[c]);
        }
    }
}

/// Asks the CPU to bring the cache line holding `data[index]` into L1. A hint: it never faults
/// and reads nothing into the program (so the intrinsic is safe), and an index past the end (the
/// block after the last) is harmless: the pointer comes from `wrapping_add`, defined for any
/// offset.
#[target_feature(enable = "avx2,fma,f16c")]
#[inline]
fn prefetch<T>(data: &[T], index: usize) {
    _mm_prefetch::<_MM_HINT_T0>(data.as_ptr().wrapping_add(index).cast::<i8>());
}

/// [`prefetch`] into L2 only (hint `T1`): far ahead, so that the near `T0` prefetch finds the
/// line close by.
#[target_feature(enable = "avx2,fma,f16c")]
#[inline]
fn prefetch_l2<T>(data: &[T], index: usize) {
    _mm_prefetch::<_MM_HINT_T1>(data.as_ptr().wrapping_add(index).cast::<i8>());
}

/// See [`super::read_sum`]: the same sums as the scalar version (lanes as wide as the words,
/// wrapping), with 256-bit loads and the same prefetch distance as the gather, so that the
/// roofline is the fastest plain read this code knows.
pub(crate) fn read_sum(m: Rows<'_>) -> u64 {
    if !supported() {
        return super::scalar::read_sum(m);
    }
    // SAFETY: `supported()` confirmed AVX2 on this CPU.
    unsafe {
        match m {
            Rows::F32(v) => read_f32(v),
            Rows::F16(v) => read_f16(v),
        }
    }
}

/// Bytes ahead of the read position that [`read_sum`] prefetches.
const READ_AHEAD: usize = 4096;

#[target_feature(enable = "avx2,fma,f16c")]
fn read_f32(v: &[f32]) -> u64 {
    let mut acc = [_mm256_setzero_si256(); 4];
    let chunks = v.chunks_exact(4 * LANES);
    let tail = chunks
        .remainder()
        .iter()
        .fold(0u32, |a, x| a.wrapping_add(x.to_bits()));
    for (i, c) in chunks.enumerate() {
        prefetch(v, i * 4 * LANES + READ_AHEAD / 4);
        for (j, a) in acc.iter_mut().enumerate() {
            let words = _mm256_castps_si256(load_f32(&c[j * LANES..]));
            *a = _mm256_add_epi32(*a, words);
        }
    }
    let mut lanes = [0u32; LANES];
    for a in acc {
        for (l, x) in lanes.iter_mut().zip(u32_lanes(a)) {
            *l = l.wrapping_add(x);
        }
    }
    u64::from(lanes.iter().fold(tail, |a, &x| a.wrapping_add(x)))
}

#[target_feature(enable = "avx2,fma,f16c")]
fn read_f16(v: &[u16]) -> u64 {
    const WIDE: usize = 16;
    let mut acc = [_mm256_setzero_si256(); 4];
    let chunks = v.chunks_exact(4 * WIDE);
    let tail = chunks
        .remainder()
        .iter()
        .fold(0u16, |a, &x| a.wrapping_add(x));
    for (i, c) in chunks.enumerate() {
        prefetch(v, i * 4 * WIDE + READ_AHEAD / 2);
        for (j, a) in acc.iter_mut().enumerate() {
            let lanes: &[u16; WIDE] = c[j * WIDE..(j + 1) * WIDE].try_into().expect("16 values");
            // SAFETY: `lanes` is 16 readable u16 (32 bytes); the unaligned load has no other
            // requirement.
            let words = unsafe { _mm256_loadu_si256(lanes.as_ptr().cast::<__m256i>()) };
            *a = _mm256_add_epi16(*a, words);
        }
    }
    let mut sum = tail;
    for a in acc {
        for x in u32_lanes(a) {
            sum = sum.wrapping_add(x as u16).wrapping_add((x >> 16) as u16);
        }
    }
    u64::from(sum)
}

/// See [`super::sums_interleaved`]. Eight elements per step: their 8 weights are spread over
/// the 24 interleaved values by three lane permutations, so every value meets its weight in
/// one FMA; lane `l` of accumulator `j` holds channel `(8 j + l) % 3`. Values are checked in
/// the same pass (two unordered compares: NaN fails both ways). Measured on the development
/// machine, n = 221184 in runs of 1024, one thread: 0.195 ms against 0.70 ms for the scalar
/// twin (see `runs`).
pub(crate) fn sums_interleaved(w: &[f32], e: &[f32]) -> ([f64; 3], bool) {
    if !supported() {
        return super::scalar::sums_interleaved(w, e);
    }
    // SAFETY: `supported()` confirmed AVX2 and FMA on this CPU.
    unsafe { interleaved(w, e) }
}

#[target_feature(enable = "avx2,fma,f16c")]
fn interleaved(w: &[f32], e: &[f32]) -> ([f64; 3], bool) {
    let spread = [
        _mm256_setr_epi32(0, 0, 0, 1, 1, 1, 2, 2),
        _mm256_setr_epi32(2, 3, 3, 3, 4, 4, 4, 5),
        _mm256_setr_epi32(5, 5, 6, 6, 6, 7, 7, 7),
    ];
    let mut check = Check::new();
    let mut total = [0.0f64; 3];
    let full = w.len() / LANES * LANES;
    let (wf, ef) = (&w[..full], &e[..3 * full]);
    for (wb, eb) in wf
        .chunks(LANES * SUM_STEPS)
        .zip(ef.chunks(3 * LANES * SUM_STEPS))
    {
        let mut acc = [_mm256_setzero_ps(); 3];
        for (ws, es) in wb.chunks_exact(LANES).zip(eb.chunks_exact(3 * LANES)) {
            let weights = load_f32(ws);
            for j in 0..3 {
                let x = load_f32(&es[j * LANES..]);
                check.add(x);
                let wj = _mm256_permutevar8x32_ps(weights, spread[j]);
                acc[j] = _mm256_fmadd_ps(wj, x, acc[j]);
            }
        }
        for (j, a) in acc.into_iter().enumerate() {
            for (l, bits) in u32_lanes(_mm256_castps_si256(a)).into_iter().enumerate() {
                total[(j * LANES + l) % 3] += f64::from(f32::from_bits(bits));
            }
        }
    }
    let (rest, ok) = super::scalar::sums_interleaved(&w[full..], &e[3 * full..]);
    for c in 0..3 {
        total[c] += rest[c];
    }
    (total, ok && check.ok())
}

/// See [`super::sums_planar`]: per plane, 8 products per step in one f32 accumulator.
pub(crate) fn sums_planar(w: &[f32], e: [&[f32]; 3]) -> ([f64; 3], bool) {
    if !supported() {
        return super::scalar::sums_planar(w, e);
    }
    // SAFETY: `supported()` confirmed AVX2 and FMA on this CPU.
    unsafe { planar(w, e) }
}

#[target_feature(enable = "avx2,fma,f16c")]
fn planar(w: &[f32], e: [&[f32]; 3]) -> ([f64; 3], bool) {
    let mut check = Check::new();
    let mut total = [0.0f64; 3];
    let full = w.len() / LANES * LANES;
    for (c, plane) in e.into_iter().enumerate() {
        let pf = &plane[..full];
        for (wb, pb) in w[..full]
            .chunks(LANES * SUM_STEPS)
            .zip(pf.chunks(LANES * SUM_STEPS))
        {
            let mut acc = _mm256_setzero_ps();
            for (ws, xs) in wb.chunks_exact(LANES).zip(pb.chunks_exact(LANES)) {
                let x = load_f32(xs);
                check.add(x);
                acc = _mm256_fmadd_ps(load_f32(ws), x, acc);
            }
            total[c] += f64::from(hsum(acc));
        }
    }
    let tail = [&e[0][full..], &e[1][full..], &e[2][full..]];
    let (rest, ok) = super::scalar::sums_planar(&w[full..], tail);
    for c in 0..3 {
        total[c] += rest[c];
    }
    (total, ok && check.ok())
}

/// Lanes that failed [`emission_ok`](super::emission_ok), or'ed together.
struct Check {
    bad: __m256,
}

impl Check {
    #[target_feature(enable = "avx2,fma,f16c")]
    #[inline]
    fn new() -> Self {
        Check {
            bad: _mm256_setzero_ps(),
        }
    }

    /// Records the lanes of `x` that are negative, above `f32::MAX` or NaN.
    #[target_feature(enable = "avx2,fma,f16c")]
    #[inline]
    fn add(&mut self, x: __m256) {
        let low = _mm256_cmp_ps::<_CMP_NGE_UQ>(x, _mm256_setzero_ps());
        let high = _mm256_cmp_ps::<_CMP_NLE_UQ>(x, _mm256_set1_ps(f32::MAX));
        self.bad = _mm256_or_ps(self.bad, _mm256_or_ps(low, high));
    }

    #[target_feature(enable = "avx2,fma,f16c")]
    #[inline]
    fn ok(&self) -> bool {
        _mm256_movemask_ps(self.bad) == 0
    }
}

/// The eight 32-bit lanes of `v`.
#[target_feature(enable = "avx2,fma,f16c")]
#[inline]
fn u32_lanes(v: __m256i) -> [u32; LANES] {
    [
        _mm256_extract_epi32::<0>(v) as u32,
        _mm256_extract_epi32::<1>(v) as u32,
        _mm256_extract_epi32::<2>(v) as u32,
        _mm256_extract_epi32::<3>(v) as u32,
        _mm256_extract_epi32::<4>(v) as u32,
        _mm256_extract_epi32::<5>(v) as u32,
        _mm256_extract_epi32::<6>(v) as u32,
        _mm256_extract_epi32::<7>(v) as u32,
    ]
}

/// The first 8 values of `v` (bounds-checked: panics on fewer, which callers rule out).
#[target_feature(enable = "avx2,fma,f16c")]
#[inline]
fn load_f32(v: &[f32]) -> __m256 {
    let lanes: &[f32; LANES] = v[..LANES].try_into().expect("8 values");
    // SAFETY: `lanes` is 8 readable f32 (32 bytes); the unaligned load has no other requirement.
    unsafe { _mm256_loadu_ps(lanes.as_ptr()) }
}

#[cfg(any(test, feature = "testkit"))]
/// Stores `x` into the first 8 values of `v` (bounds-checked like [`load_f32`]).
#[target_feature(enable = "avx2,fma,f16c")]
#[inline]
fn store_f32(v: &mut [f32], x: __m256) {
    let lanes: &mut [f32; LANES] = (&mut v[..LANES]).try_into().expect("8 values");
    // SAFETY: `lanes` is 8 writable f32 (32 bytes); the unaligned store has no other requirement.
    unsafe { std::arch::x86_64::_mm256_storeu_ps(lanes.as_mut_ptr(), x) }
}

/// The first 8 binary16 values of `v`, widened exactly by the F16C instruction.
#[target_feature(enable = "avx2,fma,f16c")]
#[inline]
fn load_f16(v: &[u16]) -> __m256 {
    let lanes: &[u16; LANES] = v[..LANES].try_into().expect("8 values");
    // SAFETY: `lanes` is 8 readable u16 (16 bytes); the unaligned load has no other requirement.
    _mm256_cvtph_ps(unsafe { _mm_loadu_si128(lanes.as_ptr().cast::<__m128i>()) })
}

/// The sum of the 8 lanes, pairwise in the order of [`scalar::reduce`](super::scalar::reduce).
#[target_feature(enable = "avx2,fma,f16c")]
#[inline]
fn hsum(v: __m256) -> f32 {
    let half = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps::<1>(v));
    let pairs = _mm_add_ps(half, _mm_movehl_ps(half, half));
    _mm_cvtss_f32(_mm_add_ss(pairs, _mm_movehdup_ps(pairs)))
}

#[cfg(test)]
mod tests {
    use super::super::{Gather, Rows, padded, scalar, tests::values};
    use super::*;

    /// Whether this CPU runs the AVX2 kernels. Without them a test fails (the kernels would go
    /// untested while the tests pass) unless `LRR_SKIP_AVX2=1` says that is expected; then it
    /// says it skipped.
    fn avx2_or_allowed_skip() -> bool {
        if supported() {
            return true;
        }
        assert!(
            std::env::var_os("LRR_SKIP_AVX2").is_some(),
            "this CPU lacks AVX2/FMA/F16C, so the AVX2 kernels cannot be tested here: run on \
             an x86-64 CPU with them, or set LRR_SKIP_AVX2=1 to skip these tests knowingly"
        );
        eprintln!("skipped: this CPU lacks AVX2/FMA/F16C (LRR_SKIP_AVX2 is set)");
        false
    }

    #[test]
    fn a_row_gives_the_same_bits_in_every_block_shape() {
        // Chunk bounds move with the thread count, so a row may be computed in a block of R
        // rows or alone: the result must be the same bits (deterministic frames).
        if !avx2_or_allowed_skip() {
            return;
        }
        for (rows, k) in [(13, 216), (11, 300), (9, 7)] {
            let kp = padded(k);
            let m = values(rows * k, k as u64);
            let halves: Vec<u16> = m.iter().map(|&v| lrr_formats::f32_to_f16(v)).collect();
            let z = values(3 * kp, 5);
            for m in [Rows::F32(&m), Rows::F16(&halves)] {
                for c3 in [true, false] {
                    let g = Gather {
                        m,
                        k,
                        z: &z,
                        kp,
                        offset: 0,
                    };
                    let mut all = vec![0.0f32; 3 * rows];
                    if c3 {
                        gather::<3>(&g, &mut all);
                    } else {
                        gather::<1>(&g, &mut all);
                    }
                    for r in 0..rows {
                        let one = match m {
                            Rows::F32(v) => Rows::F32(&v[r * k..(r + 1) * k]),
                            Rows::F16(v) => Rows::F16(&v[r * k..(r + 1) * k]),
                        };
                        let g = Gather { m: one, ..g };
                        let mut w = [0.0f32; 3];
                        if c3 {
                            gather::<3>(&g, &mut w);
                        } else {
                            gather::<1>(&g, &mut w);
                        }
                        let used = if c3 { 3 } else { 1 };
                        for c in 0..used {
                            assert_eq!(
                                w[c].to_bits(),
                                all[3 * r + c].to_bits(),
                                "rows {rows} k {k} {m:?} row {r} channel {c}"
                            );
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn transposed_matches_the_scalar_twin_on_every_shape() {
        if !avx2_or_allowed_skip() {
            return;
        }
        // Rows around the 3-row blocks, columns around the 8 lanes and the cache lines.
        for (rows, k) in [
            (1, 1),
            (2, 7),
            (3, 8),
            (4, 13),
            (7, 16),
            (8, 33),
            (10, 216),
            (5, 300),
        ] {
            let kp = padded(k);
            let m = values(rows * k, (rows * 31 + k) as u64);
            let halves: Vec<u16> = m.iter().map(|&v| lrr_formats::f32_to_f16(v)).collect();
            let e = values(3 * rows, 9);
            let mut start = values(3 * kp, 4);
            for c in 0..3 {
                start[c * kp + k..(c + 1) * kp].fill(0.0);
            }
            for m in [Rows::F32(&m), Rows::F16(&halves)] {
                let (mut fast, mut slow) = (start.clone(), start.clone());
                transposed(m, k, &e, &mut fast, kp);
                scalar::transposed(m, k, &e, &mut slow, kp);
                for (i, (a, b)) in fast.iter().zip(&slow).enumerate() {
                    assert!(
                        (a - b).abs() <= 1e-6 * b.abs(),
                        "rows {rows} k {k} {m:?} value {i}: {a} vs {b}"
                    );
                }
                for c in 0..3 {
                    assert!(fast[c * kp + k..(c + 1) * kp].iter().all(|&x| x == 0.0));
                }
            }
        }
    }

    #[test]
    fn matches_the_scalar_twin_on_every_shape() {
        if !avx2_or_allowed_skip() {
            return;
        }
        for (rows, k) in [
            (1, 1),
            (3, 7),
            (5, 8),
            (9, 13),
            (13, 216),
            (4, 256),
            (6, 300),
            (2, 777),
            (7, 40),
            (11, 24),
        ] {
            let kp = padded(k);
            let m = values(rows * k, (rows * 1000 + k) as u64);
            let halves: Vec<u16> = m.iter().map(|&v| lrr_formats::f32_to_f16(v)).collect();
            let mut z = values(3 * kp, 7);
            for c in 0..3 {
                z[c * kp + k..(c + 1) * kp].fill(0.0);
            }
            for m in [Rows::F32(&m), Rows::F16(&halves)] {
                for offset in [0, 2] {
                    let g = Gather {
                        m,
                        k,
                        z: &z,
                        kp,
                        offset,
                    };
                    let (mut fast, mut slow) = (vec![-1.0; 3 * rows], vec![-1.0; 3 * rows]);
                    if offset == 0 {
                        gather::<3>(&g, &mut fast);
                        scalar::gather::<3>(&g, &mut slow);
                    } else {
                        gather::<1>(&g, &mut fast);
                        scalar::gather::<1>(&g, &mut slow);
                    }
                    for (i, (a, b)) in fast.iter().zip(&slow).enumerate() {
                        assert!(
                            (a - b).abs() <= 1e-6 * b.abs(),
                            "rows {rows} k {k} {m:?} offset {offset} value {i}: {a} vs {b}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn segment_sums_match_the_scalar_twin_and_refuse_the_same_values() {
        if !avx2_or_allowed_skip() {
            return;
        }
        for len in [0, 1, 7, 8, 9, 31, 255, 256, 257, 1000, 4099] {
            let w = values(len, len as u64 + 3);
            let e = values(3 * len, len as u64 + 11);
            let planes = [&e[..len], &e[len..2 * len], &e[2 * len..]];
            for (fast, slow) in [
                (sums_interleaved(&w, &e), scalar::sums_interleaved(&w, &e)),
                (sums_planar(&w, planes), scalar::sums_planar(&w, planes)),
            ] {
                assert!(fast.1 && slow.1, "len {len}: valid emission refused");
                for c in 0..3 {
                    let (a, b) = (fast.0[c], slow.0[c]);
                    assert!(
                        (a - b).abs() <= 3e-6 * b.abs(),
                        "len {len} c {c}: {a} vs {b}"
                    );
                }
            }
            // One bad value anywhere (vector part or scalar tail) is refused by both.
            for at in [0, 3 * len / 2, (3 * len).saturating_sub(1)] {
                for bad in [-1e-30, -0.5, f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
                    if len == 0 {
                        continue;
                    }
                    let mut e = e.clone();
                    e[at] = bad;
                    let planes = [&e[..len], &e[len..2 * len], &e[2 * len..]];
                    assert!(
                        !sums_interleaved(&w, &e).1,
                        "len {len} at {at}: {bad} taken"
                    );
                    assert!(!sums_planar(&w, planes).1, "len {len} at {at}: {bad} taken");
                    assert!(!scalar::sums_interleaved(&w, &e).1);
                    assert!(!scalar::sums_planar(&w, planes).1);
                }
            }
            // Negative zero and the largest finite value are allowed.
            if len > 0 {
                let mut e = e.clone();
                e[0] = -0.0;
                e[3 * len - 1] = f32::MAX;
                assert!(sums_interleaved(&w, &e).1 && scalar::sums_interleaved(&w, &e).1);
            }
        }
    }
}
