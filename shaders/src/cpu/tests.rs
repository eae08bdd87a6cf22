//! The mirrors against a straightforward f64 evaluation of `B = E + ρ ⊙ F_k M (Vᵀ E)`.
//!
//! Tolerance: a rigorous rounding-error bound, not a guess. Every f32 operation rounds with
//! relative error at most `u = 2⁻²⁴`, so a result that passes each input term through at most
//! `D` roundings is the exact sum of terms each perturbed by a factor within `1 ± γ_D`,
//! `γ_D = D·u / (1 − D·u)` (Higham, *Accuracy and Stability of Numerical Algorithms*, §3.1).
//! Hence `|B̂ − B| ≤ γ_D · B_abs`, with `B_abs` the same evaluation on absolute values. Along
//! one term's path:
//!
//! - segment sum: 1 multiply, at most `⌈len/64⌉` adds in its lane, 6 tree levels;
//! - core product: 1 multiply, `⌈k/64⌉` lane adds, 6 tree levels;
//! - gather: 1 multiply, `⌈k/64⌉` lane adds, 6 tree levels, then `ρ·W` and `E + …`: 2 more.
//!
//! A GPU's fused multiply-adds only remove roundings, so the same bound holds for the shaders.
//! The f64 reference's own error is the same bound with `u = 2⁻⁵³`, added in. (No test value
//! comes near the f32 underflow range, where relative bounds would not hold.)

use super::*;
use crate::pack_f16;

/// xorshift64* (Vigna): enough randomness for test operators, no dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in [0, 1), 24 random bits: exact in f32.
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u32 << 24) as f32
    }

    fn below(&mut self, bound: usize) -> usize {
        (self.next() % bound as u64) as usize
    }
}

/// A random factored operator and emission, buffers as the shaders see them.
struct Case {
    params: Params,
    index: Vec<u32>,
    weights: Vec<f32>,
    emission: Vec<[f32; 3]>,
    cores: Vec<f32>,
    fk: Vec<f32>,
    rho: Vec<[f32; 3]>,
}

impl Case {
    fn random(seed: u64, n: usize, k: usize, channels: u32) -> Case {
        let mut rng = Rng(seed);
        Case {
            params: Params::new(n as u32, k as u32, channels),
            index: random_index(&mut rng, n, k),
            weights: Vec::new(),
            // Mostly dark, a few bright emitters, as a lit scene.
            emission: (0..n)
                .map(|_| match rng.below(4) {
                    0 => [0.0; 3].map(|_: f32| 10.0 * rng.unit()),
                    _ => [0.0; 3],
                })
                .collect(),
            // Identity plus signed noise: the mirrors must not rely on non-negative cores.
            cores: (0..channels as usize * k * k)
                .map(|i| f32::from(u8::from(i % (k + 1) == 0)) + (rng.unit() - 0.3) / k as f32)
                .collect(),
            // Rows summing to about 1, as in a closed room.
            fk: (0..n * k).map(|_| 2.0 * rng.unit() / k as f32).collect(),
            rho: (0..n)
                .map(|_| [0.0; 3].map(|_: f32| 0.95 * rng.unit()))
                .collect(),
        }
        .with_weights(&mut rng)
    }

    /// Weights `A_s / A_p` from random element areas.
    fn with_weights(mut self, rng: &mut Rng) -> Case {
        let areas: Vec<f32> = (0..self.params.n).map(|_| 0.5 + rng.unit()).collect();
        self.weights = vec![0.0; areas.len()];
        for p in self.index.windows(2) {
            let segment = p[0] as usize..p[1] as usize;
            let total: f32 = areas[segment.clone()].iter().sum();
            for s in segment {
                self.weights[s] = areas[s] / total;
            }
        }
        self
    }

    /// All three mirrors, f32 `F_k` bound whole.
    fn mirrors(&self) -> Vec<[f32; 3]> {
        let (n, k) = (self.params.n as usize, self.params.k as usize);
        let mut x = vec![[0.0; 3]; k];
        segment_sums(
            &self.params,
            &self.index,
            &self.weights,
            &self.emission,
            &mut x,
        );
        let mut z = vec![[0.0; 3]; k];
        core_product(&self.params, &self.cores, &x, &mut z);
        let mut b = vec![[f32::NAN; 3]; n];
        gather(
            &self.params,
            &self.fk,
            &z,
            &self.emission,
            &self.rho,
            &mut b,
        );
        b
    }

    /// `Z` from the first two mirrors, for the gather tests.
    fn z(&self) -> Vec<[f32; 3]> {
        let k = self.params.k as usize;
        let mut x = vec![[0.0; 3]; k];
        segment_sums(
            &self.params,
            &self.index,
            &self.weights,
            &self.emission,
            &mut x,
        );
        let mut z = vec![[0.0; 3]; k];
        core_product(&self.params, &self.cores, &x, &mut z);
        z
    }

    /// `B = E + ρ ⊙ F_k M (Vᵀ E)` in f64 from the same f32 inputs, through `magnitude` applied
    /// to every input (identity: the reference; `abs`: `B_abs` of the error bound).
    fn reference(&self, magnitude: fn(f64) -> f64) -> Vec<[f64; 3]> {
        let (n, k) = (self.params.n as usize, self.params.k as usize);
        let v = |a: f32| magnitude(f64::from(a));
        let mut x = vec![[0.0f64; 3]; k];
        for (p, xp) in x.iter_mut().enumerate() {
            for s in self.index[p] as usize..self.index[p + 1] as usize {
                for (xc, e) in xp.iter_mut().zip(self.emission[s]) {
                    *xc += v(self.weights[s]) * v(e);
                }
            }
        }
        let mut z = vec![[0.0f64; 3]; k];
        for (p, zp) in z.iter_mut().enumerate() {
            for c in 0..3 {
                let core = if self.params.channels == 3 { c } else { 0 };
                for (q, xq) in x.iter().enumerate() {
                    zp[c] += v(self.cores[core * k * k + p * k + q]) * xq[c];
                }
            }
        }
        (0..n)
            .map(|s| {
                let mut b = [0.0; 3];
                for c in 0..3 {
                    let w: f64 = (0..k).map(|q| v(self.fk[s * k + q]) * z[q][c]).sum();
                    b[c] = v(self.emission[s][c]) + v(self.rho[s][c]) * w;
                }
                b
            })
            .collect()
    }

    /// Roundings along one term's path through the three passes (see the module docs).
    fn depth(&self) -> usize {
        let lanes = LANES as usize;
        let tree = LANES.ilog2() as usize;
        let longest = self.index.windows(2).map(|p| (p[1] - p[0]) as usize).max();
        let k = self.params.k as usize;
        let segment = 1 + longest.unwrap_or(0).div_ceil(lanes) + tree;
        let core = 1 + k.div_ceil(lanes) + tree;
        let gather = 1 + k.div_ceil(lanes) + tree + 2;
        segment + core + gather
    }

    /// Asserts `|b − B| ≤ (γ_D(2⁻²⁴) + γ_D(2⁻⁵³)) · B_abs` everywhere; returns the largest
    /// `|b − B| / B_abs`, to show how far below the bound the mirrors land.
    fn assert_within_bound(&self, b: &[[f32; 3]]) -> f64 {
        let gamma = |u: f64| {
            let d = self.depth() as f64;
            d * u / (1.0 - d * u)
        };
        let tolerance = gamma(2f64.powi(-24)) + gamma(2f64.powi(-53));
        let (exact, magnitude) = (self.reference(|a| a), self.reference(f64::abs));
        let mut worst = 0.0f64;
        for (s, (bs, (es, ms))) in b.iter().zip(exact.iter().zip(&magnitude)).enumerate() {
            for c in 0..3 {
                let error = (f64::from(bs[c]) - es[c]).abs();
                assert!(
                    error <= tolerance * ms[c],
                    "B[{s}][{c}] = {} vs {}: error {error:e} > {tolerance:e} x {}",
                    bs[c],
                    es[c],
                    ms[c]
                );
                if ms[c] > 0.0 {
                    worst = worst.max(error / ms[c]);
                }
            }
        }
        assert!(worst <= tolerance);
        worst
    }
}

/// `k + 1` sorted offsets with `I[0] = 0`, `I[k] = n`; patch 1 empty when `k ≥ 3`, and the
/// rest random, so segments range from empty to several times `LANES`.
fn random_index(rng: &mut Rng, n: usize, k: usize) -> Vec<u32> {
    let mut index: Vec<u32> = (0..k - 1).map(|_| rng.below(n + 1) as u32).collect();
    index.push(0);
    index.push(n as u32);
    index.sort_unstable();
    if k >= 3 {
        index[2] = index[1];
    }
    index
}

#[test]
fn mirrors_match_f64_within_the_rounding_bound() {
    // (n, k): one patch, k below / at / above LANES, k a multiple of LANES, long segments.
    let shapes = [
        (1, 1),
        (40, 3),
        (700, 5),
        (500, 63),
        (640, 64),
        (900, 130),
        (300, 256),
    ];
    for (i, &(n, k)) in shapes.iter().enumerate() {
        for channels in [1, 3] {
            let case = Case::random(0x5EED + i as u64 * 7 + u64::from(channels), n, k, channels);
            let worst = case.assert_within_bound(&case.mirrors());
            let bound = case.depth() as f64 * 2f64.powi(-24);
            eprintln!("n {n}, k {k}, {channels} core(s): worst {worst:.1e}, bound {bound:.1e}");
        }
    }
}

#[test]
fn empty_segments_sum_to_zero() {
    let case = Case::random(11, 50, 4, 3);
    assert_eq!(case.index[1], case.index[2], "patch 1 is empty");
    let mut x = vec![[f32::NAN; 3]; 4];
    segment_sums(
        &case.params,
        &case.index,
        &case.weights,
        &case.emission,
        &mut x,
    );
    assert_eq!(x[1], [0.0; 3]);
}

#[test]
fn one_core_serves_all_three_channels() {
    let mut case = Case::random(21, 200, 9, 3);
    let k = 9;
    case.cores.truncate(k * k);
    case.params.channels = 1;
    let z1 = case.z();
    case.cores = case.cores.repeat(3);
    case.params.channels = 3;
    assert_eq!(z1, case.z());
}

#[test]
fn lane_sums_of_small_integers_are_exact() {
    for len in [0, 1, 63, 64, 65, 1000] {
        let sum = reduce_lanes(len, |i| [i as f32, 1.0, -(i as f32)]);
        let n = len as f32;
        assert_eq!(
            sum,
            [n * (n - 1.0) / 2.0, n, -n * (n - 1.0) / 2.0 + 0.0],
            "{len}"
        );
    }
}

/// Binds F_k in row chunks, each view starting at an aligned entry before its first row, as the
/// runtime does under lavapipe's 128 MiB limit: every row comes out bit for bit as in one pass.
#[test]
fn gather_in_row_chunks_equals_one_gather() {
    let case = Case::random(31, 1001, 37, 3);
    let (n, k) = (1001usize, 37usize);
    let z = case.z();
    let whole = case.mirrors();
    let align = 64; // entries: 256 bytes of f32, a typical binding offset alignment
    let mut chunked = vec![[f32::NAN; 3]; n];
    for (start, rows) in [(0, 300), (300, 1), (301, 450), (751, 250)] {
        let first = start * k;
        let view = first / align * align;
        let params = case
            .params
            .rows(start as u32, rows as u32, (first - view) as u32);
        let fk = &case.fk[view..(start + rows) * k];
        gather(&params, fk, &z, &case.emission, &case.rho, &mut chunked);
    }
    assert_eq!(chunked, whole);
}

/// The binary16 gather on packed words gives exactly the f32 gather on the widened values, for
/// an odd `k` (rows starting in either half of a word), bound whole or in word-aligned chunks.
#[test]
fn gather_f16_equals_gather_on_widened_values() {
    let (n, k) = (333usize, 71usize);
    let mut case = Case::random(41, n, k, 1);
    let mut rng = Rng(42);
    // Positive binary16 below 2⁻⁸: normals and, now and then, subnormals.
    let halves: Vec<u16> = (0..n * k)
        .map(|_| match rng.below(50) {
            0 => rng.below(0x400) as u16,
            _ => (0x1000 + rng.below(0x1C00 - 0x1000)) as u16,
        })
        .collect();
    case.fk = halves.iter().map(|&h| f16_to_f32(h)).collect();
    let words = pack_f16(&halves);
    let z = case.z();
    let whole = case.mirrors();
    case.assert_within_bound(&whole);

    let mut b = vec![[f32::NAN; 3]; n];
    gather_f16(&case.params, &words, &z, &case.emission, &case.rho, &mut b);
    assert_eq!(b, whole);

    let align = 64; // words
    let mut chunked = vec![[f32::NAN; 3]; n];
    for (start, rows) in [(0, 100), (100, 133), (233, 100)] {
        let first = start * k;
        let view = first / 2 / align * align;
        let params = case
            .params
            .rows(start as u32, rows as u32, (first - 2 * view) as u32);
        gather_f16(
            &params,
            &words[view..],
            &z,
            &case.emission,
            &case.rho,
            &mut chunked,
        );
    }
    assert_eq!(chunked, whole);
}
