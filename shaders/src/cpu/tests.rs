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
//! - core product: 1 multiply, 3 adds in a `dot`, `⌈KP/4/64⌉` lane adds, 6 tree levels;
//! - gather: 1 multiply, 4 adds in an octet (two `dot`s), `⌈KP/8/ROW_LANES⌉` lane adds,
//!   `log2 ROW_LANES` tree levels, then `ρ·W` and `E + …`: 2 more.
//!
//! A GPU's fused multiply-adds only remove roundings, so the same bound holds for the shaders.
//! The f64 reference's own error is the same bound with `u = 2⁻⁵³`, added in. (No test value
//! comes near the f32 underflow range, where relative bounds would not hold.)

use super::*;
use crate::padded_k;

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
    kp: usize,
    index: Vec<u32>,
    weights: Vec<f32>,
    /// File position -> id: reversed, so the permutation matters.
    order: Vec<u32>,
    /// By original id.
    emission: Vec<[f32; 3]>,
    /// Three cores of k rows of kp (the same core three times for one channel).
    cores: [Vec<f32>; 3],
    /// n rows of kp.
    fk: Vec<f32>,
    /// File order.
    rho: Vec<[f32; 3]>,
}

impl Case {
    fn random(seed: u64, n: usize, k: usize, channels: u32) -> Case {
        let mut rng = Rng(seed);
        let kp = padded_k(k as u32) as usize;
        let padded = |rng: &mut Rng, rows: usize, f: &dyn Fn(&mut Rng, usize) -> f32| {
            let mut m = vec![0.0; rows * kp];
            for r in 0..rows {
                for q in 0..k {
                    m[r * kp + q] = f(rng, r * k + q);
                }
            }
            m
        };
        // Identity plus signed noise: the mirrors must not rely on non-negative cores.
        let core = |rng: &mut Rng| {
            padded(rng, k, &|rng: &mut Rng, i: usize| {
                f32::from(u8::from(i.is_multiple_of(k + 1))) + (rng.unit() - 0.3) / k as f32
            })
        };
        let r = core(&mut rng);
        let cores = if channels == 3 {
            [r, core(&mut rng), core(&mut rng)]
        } else {
            [r.clone(), r.clone(), r]
        };
        Case {
            params: Params {
                n: n as u32,
                k: k as u32,
                row_count: n as u32,
                ..Params::default()
            },
            kp,
            index: random_index(&mut rng, n, k),
            weights: Vec::new(),
            order: (0..n as u32).rev().collect(),
            // Mostly dark, a few bright emitters, as a lit scene.
            emission: (0..n)
                .map(|_| match rng.below(4) {
                    0 => [0.0; 3].map(|_: f32| 10.0 * rng.unit()),
                    _ => [0.0; 3],
                })
                .collect(),
            cores,
            // Rows summing to about 1, as in a closed room.
            fk: padded(&mut rng, n, &|rng: &mut Rng, _| 2.0 * rng.unit() / k as f32),
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

    fn constants(&self, row_lanes: u32) -> GatherConstants {
        GatherConstants {
            row_lanes,
            ..GatherConstants::new(self.kp as u32, true, false)
        }
    }

    /// `Z` from the first two mirrors.
    fn z(&self) -> Vec<f32> {
        let mut x = vec![0.0; 3 * self.kp];
        segment_sums(
            &self.params,
            self.kp,
            &self.index,
            &self.weights,
            &self.order,
            &self.emission,
            &mut x,
        );
        let mut z = vec![0.0; 3 * self.kp];
        let [r, g, b] = &self.cores;
        core_product(&self.params, self.kp, [r, g, b], &x, &mut z);
        z
    }

    /// All mirrors, `F_k` bound whole.
    fn mirrors(&self, rows: &Rows<'_>, row_lanes: u32) -> Vec<[f32; 3]> {
        let mut b = vec![[f32::NAN; 3]; self.params.n as usize];
        let z = self.z();
        let c = self.constants(row_lanes);
        let (e, rho, order) = (&self.emission, &self.rho, &self.order);
        gather(&self.params, &c, rows, &z, e, rho, order, &mut b);
        b
    }

    /// `B = E + ρ ⊙ F_k M (Vᵀ E)` in f64 from the same f32 inputs, through `magnitude` applied
    /// to every input (identity: the reference; `abs`: `B_abs` of the error bound); by id.
    fn reference(&self, magnitude: fn(f64) -> f64) -> Vec<[f64; 3]> {
        let (n, k, kp) = (self.params.n as usize, self.params.k as usize, self.kp);
        let v = |a: f32| magnitude(f64::from(a));
        let mut x = vec![[0.0f64; 3]; k];
        for (p, xp) in x.iter_mut().enumerate() {
            for s in self.index[p] as usize..self.index[p + 1] as usize {
                let e = self.emission[self.order[s] as usize];
                for (xc, e) in xp.iter_mut().zip(e) {
                    *xc += v(self.weights[s]) * v(e);
                }
            }
        }
        let mut z = vec![[0.0f64; 3]; k];
        for (p, zp) in z.iter_mut().enumerate() {
            for c in 0..3 {
                for (q, xq) in x.iter().enumerate() {
                    zp[c] += v(self.cores[c][p * kp + q]) * xq[c];
                }
            }
        }
        let mut out = vec![[0.0; 3]; n];
        for s in 0..n {
            let id = self.order[s] as usize;
            for c in 0..3 {
                let w: f64 = (0..k).map(|q| v(self.fk[s * kp + q]) * z[q][c]).sum();
                out[id][c] = v(self.emission[id][c]) + v(self.rho[s][c]) * w;
            }
        }
        out
    }

    /// Roundings along one term's path through the three passes (see the module docs).
    fn depth(&self, row_lanes: u32) -> usize {
        let lanes = LANES as usize;
        let tree = LANES.ilog2() as usize;
        let longest = self.index.windows(2).map(|p| (p[1] - p[0]) as usize).max();
        let segment = 1 + longest.unwrap_or(0).div_ceil(lanes) + tree;
        let core = 1 + 3 + (self.kp / 4).div_ceil(lanes) + tree;
        let rl = row_lanes as usize;
        let gather = 1 + 4 + (self.kp / 8).div_ceil(rl) + rl.ilog2() as usize + 2;
        segment + core + gather
    }

    /// Asserts `|b − B| ≤ (γ_D(2⁻²⁴) + γ_D(2⁻⁵³)) · B_abs` everywhere; returns the largest
    /// `|b − B| / B_abs`, to show how far below the bound the mirrors land.
    fn assert_within_bound(&self, b: &[[f32; 3]], row_lanes: u32) -> f64 {
        let d = self.depth(row_lanes) as f64;
        let gamma = |u: f64| d * u / (1.0 - d * u);
        let tolerance = gamma(2f64.powi(-24)) + gamma(2f64.powi(-53));
        let (exact, magnitude) = (self.reference(|a| a), self.reference(f64::abs));
        let mut worst = 0.0f64;
        for (i, (bs, (es, ms))) in b.iter().zip(exact.iter().zip(&magnitude)).enumerate() {
            for c in 0..3 {
                let error = (f64::from(bs[c]) - es[c]).abs();
                assert!(
                    error <= tolerance * ms[c],
                    "B[{i}][{c}] = {} vs {}: error {error:e} > {tolerance:e} x {}",
                    bs[c],
                    es[c],
                    ms[c]
                );
                if ms[c] > 0.0 {
                    worst = worst.max(error / ms[c]);
                }
            }
        }
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
            for row_lanes in [1, 8, 32] {
                let case =
                    Case::random(0x5EED + i as u64 * 7 + u64::from(channels), n, k, channels);
                let b = case.mirrors(&Rows::F32(&case.fk), row_lanes);
                let worst = case.assert_within_bound(&b, row_lanes);
                let bound = case.depth(row_lanes) as f64 * 2f64.powi(-24);
                eprintln!(
                    "n {n}, k {k}, {channels} core(s), {row_lanes} lanes/row: worst {worst:.1e}, \
                     bound {bound:.1e}"
                );
            }
        }
    }
}

#[test]
fn empty_segments_sum_to_zero() {
    let case = Case::random(11, 50, 4, 3);
    assert_eq!(case.index[1], case.index[2], "patch 1 is empty");
    let mut x = vec![f32::NAN; 3 * case.kp];
    let (p, kp) = (&case.params, case.kp);
    segment_sums(
        p,
        kp,
        &case.index,
        &case.weights,
        &case.order,
        &case.emission,
        &mut x,
    );
    assert_eq!([x[1], x[kp + 1], x[2 * kp + 1]], [0.0; 3]);
}

#[test]
fn lane_sums_of_small_integers_are_exact() {
    for lanes in [1, 8, 64] {
        for len in [0, 1, 63, 64, 65, 1000] {
            let sum = reduce_lanes(lanes, len, |i| [i as f32, 1.0, -(i as f32)]);
            let n = len as f32;
            assert_eq!(
                sum,
                [n * (n - 1.0) / 2.0, n, -n * (n - 1.0) / 2.0 + 0.0],
                "{len}"
            );
        }
    }
}

/// Binds F_k in chunks of whole rows, each its own buffer, as the runtime does under an
/// adapter's binding limit: every row comes out bit for bit as in one pass.
#[test]
fn gather_in_row_chunks_equals_one_gather() {
    let case = Case::random(31, 1001, 37, 3);
    let (n, kp) = (1001usize, case.kp);
    let z = case.z();
    let whole = case.mirrors(&Rows::F32(&case.fk), 8);
    let c = case.constants(8);
    let mut chunked = vec![[f32::NAN; 3]; n];
    for (start, rows) in [(0, 300), (300, 1), (301, 450), (751, 250)] {
        let params = Params {
            first_row: start as u32,
            row_count: rows as u32,
            ..case.params
        };
        let fk = Rows::F32(&case.fk[start * kp..(start + rows) * kp]);
        let (e, rho, order) = (&case.emission, &case.rho, &case.order);
        gather(&params, &c, &fk, &z, e, rho, order, &mut chunked);
    }
    assert_eq!(chunked, whole);
}

/// The binary16 gather gives exactly the f32 gather on the widened values.
#[test]
fn gather_f16_equals_gather_on_widened_values() {
    let (n, k) = (333usize, 71usize);
    let mut case = Case::random(41, n, k, 1);
    let kp = case.kp;
    let mut rng = Rng(42);
    // Positive binary16 below 2⁻⁸: normals and, now and then, subnormals; zero padding.
    let halves: Vec<u16> = (0..n * kp)
        .map(|i| match (i % kp < k, rng.below(50)) {
            (false, _) => 0,
            (true, 0) => rng.below(0x400) as u16,
            _ => (0x1000 + rng.below(0x1C00 - 0x1000)) as u16,
        })
        .collect();
    case.fk = halves.iter().map(|&h| f16_to_f32(h)).collect();
    let whole = case.mirrors(&Rows::F32(&case.fk), 4);
    case.assert_within_bound(&whole, 4);
    assert_eq!(case.mirrors(&Rows::F16(&halves), 4), whole);
}

/// Plain RGB: three blocks of rows, block c giving channel c, equal the f64 `E - Y_c X_c`.
#[test]
fn plain_blocks_give_one_channel_each() {
    let (n, k) = (120usize, 13usize);
    let case = Case::random(51, n, k, 3);
    let kp = case.kp;
    let mut rng = Rng(52);
    let y: Vec<f32> = (0..3 * n * kp)
        .map(|i| {
            if i % kp < k {
                rng.unit() / k as f32
            } else {
                0.0
            }
        })
        .collect();
    let x: Vec<f32> = (0..3 * kp)
        .map(|i| if i % kp < k { rng.unit() } else { 0.0 })
        .collect();
    let params = Params {
        row_count: 3 * n as u32,
        ..case.params
    };
    let c = GatherConstants::new(kp as u32, false, true);
    let mut b = vec![[f32::NAN; 3]; n];
    let (e, rho, order) = (&case.emission, &case.rho, &case.order);
    gather(&params, &c, &Rows::F32(&y), &x, e, rho, order, &mut b);
    for s in 0..n {
        let id = order[s] as usize;
        for ch in 0..3 {
            let w: f64 = (0..k)
                .map(|q| f64::from(y[(ch * n + s) * kp + q]) * f64::from(x[ch * kp + q]))
                .sum();
            let want = f64::from(e[id][ch]) - w;
            assert!((f64::from(b[id][ch]) - want).abs() <= 1e-6 * (1.0 + want.abs()));
        }
    }
}

/// `X = Σ a_g x_g` and the groups' emission, against f64.
#[test]
fn light_groups_sum_intensities() {
    let (n, kp) = (10usize, 8usize);
    let params = Params {
        n: n as u32,
        groups: 2,
        positions: 3,
        ..Params::default()
    };
    let a = [2.0, 0.5];
    let group_x: Vec<f32> = (0..2 * 3 * kp).map(|i| i as f32).collect();
    let mut x = vec![0.0; 3 * kp];
    group_sums(&params, kp, &a, &group_x, &mut x);
    for (t, &xt) in x.iter().enumerate() {
        assert_eq!(xt, 2.0 * t as f32 + 0.5 * (3 * kp + t) as f32);
    }
    // Position 4 lit by both groups, 6 by group 0, 9 by group 1.
    let (position, starts, members) = ([4, 6, 9], [0, 2, 3, 4], [0, 1, 0, 1]);
    let member_emission = [[1.0, 2.0, 3.0], [4.0, 0.0, 0.0], [1.0; 3], [0.0, 0.0, 8.0]];
    let order: Vec<u32> = (0..n as u32).rev().collect();
    let mut e = vec![[0.0; 3]; n];
    group_emission(
        &params,
        &a,
        &position,
        &starts,
        &members,
        &member_emission,
        &order,
        &mut e,
    );
    assert_eq!(e[5], [4.0, 4.0, 6.0]);
    assert_eq!(e[3], [2.0; 3]);
    assert_eq!(e[0], [0.0, 0.0, 4.0]);
    assert_eq!(e.iter().filter(|v| **v != [0.0; 3]).count(), 3);
}

/// Random smooth weights over `n` elements (1 to 12 per vertex, some negative as on a surface's
/// boundary) and radiosity: the mirror within the rounding bound of a running f32 sum, `γ_m
/// Σ|w||B|` for `m` weights (one multiply and `m − 1` adds per term), against f64; clamped at
/// zero like the f64 reconstruction (clamping does not grow the error).
#[test]
fn smooth_vertices_match_f64_within_the_rounding_bound() {
    let mut rng = Rng(0xB0B);
    let (n, vertices) = (500usize, 2000usize);
    let radiosity: Vec<[f32; 3]> = (0..n)
        .map(|_| [rng.unit() * 4.0, rng.unit(), rng.unit() * 1e-3])
        .collect();
    let (mut offsets, mut elements, mut weights) = (vec![0u32], Vec::new(), Vec::new());
    for _ in 0..vertices {
        let m = 1 + rng.below(12);
        for _ in 0..m {
            elements.push(rng.below(n) as u32);
            // Within the format's ±8; a third negative.
            let w = 8.0 * rng.unit();
            weights.push(if rng.below(3) == 0 { -w } else { w });
        }
        offsets.push(elements.len() as u32);
    }
    let params = SmoothParams {
        vertex_count: vertices as u32,
        ..SmoothParams::default()
    };
    let mut out = vec![[f32::NAN; 3]; vertices];
    smooth_vertices(&params, &offsets, &elements, &weights, &radiosity, &mut out);
    let (mut clamped, mut worst) = (0, 0.0f64);
    for v in 0..vertices {
        let range = offsets[v] as usize..offsets[v + 1] as usize;
        let m = range.len() as f64;
        let gamma = |u: f64| m * u / (1.0 - m * u);
        for c in 0..3 {
            let (mut exact, mut abs) = (0.0f64, 0.0f64);
            for j in range.clone() {
                let b = f64::from(radiosity[elements[j] as usize][c]);
                exact += f64::from(weights[j]) * b;
                abs += (f64::from(weights[j]) * b).abs();
            }
            let bound = (gamma(2f64.powi(-24)) + gamma(2f64.powi(-53))) * abs;
            let got = f64::from(out[v][c]);
            assert!(got >= 0.0, "vertex {v}: {got}");
            let error = (got - exact.max(0.0)).abs();
            assert!(
                error <= bound,
                "vertex {v} channel {c}: {got} vs {exact}, bound {bound:e}"
            );
            clamped += usize::from(exact < 0.0);
            if abs > 0.0 {
                worst = worst.max(error / abs);
            }
        }
    }
    assert!(clamped > 100, "negative sums are exercised: {clamped}");
    eprintln!("smooth vertices: worst error {worst:.1e} of sum |w B|, {clamped} clamped");
}

/// Mean value coordinates by their definition in f64, independently of the mirror's formula:
/// `t_i = tan(α_i / 2)` from the angle `α_i` at `x` between corners `i` and `i + 1`
/// (`atan2`); `None` on or outside the boundary.
fn mean_value_reference(v: &[[f32; 3]], n: [f32; 3], x: [f32; 3]) -> Option<[f64; 4]> {
    let m = v.len();
    let n = n.map(f64::from);
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let d: Vec<[f64; 3]> = v
        .iter()
        .map(|p| {
            let e: [f64; 3] = std::array::from_fn(|c| f64::from(p[c]) - f64::from(x[c]));
            let h = dot(e, n);
            std::array::from_fn(|c| e[c] - h * n[c])
        })
        .collect();
    let mut t = [0.0f64; 4];
    for i in 0..m {
        let (a, b) = (d[i], d[(i + 1) % m]);
        let cross = [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ];
        let sin = dot(cross, n);
        if sin <= 0.0 {
            return None;
        }
        t[i] = (0.5 * sin.atan2(dot(a, b))).tan();
    }
    let mut w = [0.0f64; 4];
    for i in 0..m {
        w[i] = (t[(i + m - 1) % m] + t[i]) / dot(d[i], d[i]).sqrt();
    }
    let total: f64 = w.iter().sum();
    Some(w.map(|x| x / total))
}

/// The f32 mean value coordinates against the f64 definition on a quad and a triangle (not at
/// the origin, off their plane by rounding): inside, near a corner, near an edge (down to 1e-6
/// of the edge length, where t_i grows to 1e6), and on or just outside an edge (the nearest
/// boundary point's linear interpolation). Bound: 8 ε = 9.5e-7 per weight (f32's ε = 2⁻²³;
/// measured worst: printed), what `trace.wgsl`'s smooth shading adds to the CPU tracer's f64
/// per unit of the corner values.
#[test]
fn mean_value_weights_in_f32_match_the_f64_definition() {
    let n = [0.0, 0.6, 0.8];
    // Corners in the plane 0.6 y + 0.8 z = 0.6 · 7 (within f32 rounding), away from the origin.
    let plane = |u: f32, v: f32| [10.0 + u, 7.0 - 0.8 * v, 0.6 * v];
    let quad = [
        plane(0.0, 0.0),
        plane(2.0, 0.0),
        plane(2.5, 1.0),
        plane(-0.5, 1.5),
    ];
    let tri = [plane(0.0, 0.0), plane(1.0, 0.0), plane(0.2, 1.2)];
    let mut rng = Rng(77);
    let mut worst = [0.0f64; 4]; // inside, near a corner, near an edge, on / outside
    for poly in [&quad[..], &tri[..]] {
        let m = poly.len();
        let lerp = |a: [f32; 3], b: [f32; 3], s: f32| -> [f32; 3] {
            std::array::from_fn(|c| a[c] + s * (b[c] - a[c]))
        };
        let centre: [f32; 3] =
            std::array::from_fn(|c| poly.iter().map(|p| p[c]).sum::<f32>() / m as f32);
        let unit = f64::from(f32::EPSILON);
        for _ in 0..4000 {
            let i = rng.below(m);
            let (a, b) = (poly[i], poly[(i + 1) % m]);
            let kind = rng.below(4);
            let x = match kind {
                // inside: towards the centre from a random boundary point
                0 => lerp(lerp(a, b, rng.unit()), centre, 0.05 + 0.9 * rng.unit()),
                // near corner i: 1e-6 .. 1e-2 of the way to the centre
                1 => lerp(a, centre, 10f32.powf(-6.0 + 4.0 * rng.unit())),
                // near edge i: 1e-6 .. 1e-2 of the way from a point on it to the centre
                2 => lerp(
                    lerp(a, b, 0.05 + 0.9 * rng.unit()),
                    centre,
                    10f32.powf(-6.0 + 4.0 * rng.unit()),
                ),
                // on edge i, or just outside it
                _ => lerp(
                    lerp(a, b, rng.unit()),
                    centre,
                    -1e-4 * rng.unit() * f32::from(rng.below(2) as u8),
                ),
            };
            let got = mean_value_weights(poly, n, x);
            let want = match mean_value_reference(poly, n, x) {
                Some(w) if kind < 3 => w,
                _ => {
                    // Linear interpolation at the nearest point of the boundary, in f64.
                    let mut best = (f64::INFINITY, [0.0f64; 4]);
                    for e in 0..m {
                        let (p, q) = (poly[e].map(f64::from), poly[(e + 1) % m].map(f64::from));
                        let ab: [f64; 3] = std::array::from_fn(|c| q[c] - p[c]);
                        let ax: [f64; 3] = std::array::from_fn(|c| f64::from(x[c]) - p[c]);
                        let len2: f64 = ab.iter().map(|c| c * c).sum();
                        let s = ((0..3).map(|c| ax[c] * ab[c]).sum::<f64>() / len2).clamp(0.0, 1.0);
                        let dist: f64 = (0..3).map(|c| (ax[c] - s * ab[c]).powi(2)).sum();
                        if dist < best.0 {
                            let mut w = [0.0; 4];
                            w[e] = 1.0 - s;
                            w[(e + 1) % m] += s;
                            best = (dist, w);
                        }
                    }
                    best.1
                }
            };
            let error = (0..4)
                .map(|k| (f64::from(got[k]) - want[k]).abs())
                .fold(0.0, f64::max);
            assert!(got[m..].iter().all(|&w| w == 0.0));
            let units = error / unit;
            worst[kind] = worst[kind].max(units);
            assert!(
                units <= 8.0,
                "kind {kind}, x {x:?}: {got:?} vs {want:?}, {units:.1} units"
            );
        }
    }
    eprintln!(
        "mean value weights, worst error in units of f32 eps: inside {:.2}, near a corner {:.2}, \
         near an edge {:.2}, on or outside an edge {:.2}",
        worst[0], worst[1], worst[2], worst[3]
    );
}
