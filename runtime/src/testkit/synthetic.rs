//! Synthetic operators for tests and benchmarks: valid, well-conditioned, deterministic.
//!
//! n elements in k patches of about n/k elements, random weights; every row
//! of `F_k` has random non-negative entries (about a third zero) summing to less than 0.9, and
//! reflectance lies in [0.1, 0.9), so every row of `Vᵀ diag(ρ) F_k` sums to less than 0.81: the
//! systems are far from singular, and their inverses (the cores, computed here by the runtime's
//! own LU) are non-negative, like those of a real scene. Original ids come in one run per patch,
//! the runs shuffled: a bake numbers elements depth-first through the subdivision, so a patch's
//! elements have consecutive ids, but the id order of the patches need not be the file's. About 1% of the elements emit, and
//! three light groups (when n ≥ 3) cover a few more. The display geometry is a grid of unit
//! squares. A hand-written generator (xorshift64*): no dependency, same seed, same operator.

use lrr_formats::{Geometry, Layout, OperatorData, OperatorFile, Precision};

use crate::albedo;
use crate::error::{RuntimeError, input};
use crate::operator::Operator;

/// A valid operator of `n` elements, `k` patches, `channels` (1: grey reflectance, 3: RGB),
/// stored in `precision` and `layout`. The plain layout is converted from the factored one
/// (`O(channels · n · k²)`, on every available core). Errors on impossible sizes.
pub fn operator(
    n: usize,
    k: usize,
    channels: usize,
    precision: Precision,
    layout: Layout,
    seed: u64,
) -> Result<Operator, RuntimeError> {
    Operator::from_file(file(n, k, channels, precision, layout, seed)?)
}

/// The [`OperatorFile`] of [`operator`].
pub fn file(
    n: usize,
    k: usize,
    channels: usize,
    precision: Precision,
    layout: Layout,
    seed: u64,
) -> Result<OperatorFile, RuntimeError> {
    if k == 0 || k > n || u32::try_from(n).is_err() || !(channels == 1 || channels == 3) {
        return Err(input(format!(
            "synthetic operator: need 1 <= k <= n < 2^32 and channels 1 or 3, got n = {n}, \
             k = {k}, channels = {channels}"
        )));
    }
    let mut rng = Rng::new(seed);
    let index: Vec<u32> = (0..=k).map(|p| (p * n / k) as u32).collect();
    let mut file = OperatorFile {
        metadata_json: format!(
            r#"{{"generator":"lrr_runtime::synthetic","seed":{seed},"n":{n},"k":{k}}}"#
        ),
        n: n as u32,
        k: k as u32,
        channels: channels as u32,
        precision,
        order: runs(&index, &mut rng),
        weights: weights(&index, &mut rng),
        index,
        operator: OperatorData::Factored {
            fk: form_factors(n, k, precision, &mut rng),
            cores: Vec::new(),
        },
        reflectance: Vec::new(),
        emission: vec![0.0; 3 * n],
        geometry: grid(n),
        lights: Vec::new(),
        display: Default::default(),
    };
    let rho: Vec<[f32; 3]> = (0..n)
        .map(|_| {
            let r = [
                0.1 + 0.8 * rng.unit(),
                0.1 + 0.8 * rng.unit(),
                0.1 + 0.8 * rng.unit(),
            ];
            if channels == 1 { [r[0]; 3] } else { r }
        })
        .collect();
    let edit = albedo::rebuild(&file, &rho)?;
    file.channels = edit.channels as u32;
    file.reflectance = edit.reflectance;
    if let OperatorData::Factored { cores, .. } = &mut file.operator {
        *cores = edit.cores;
    }
    emit(&mut file, &mut rng)?;
    Ok(match layout {
        Layout::Factored => file,
        Layout::PlainYk => file.to_plain_yk(0)?,
    })
}

/// Rows of random non-negative values, about a third zero, each summing to [0.3, 0.9).
fn form_factors(
    n: usize,
    k: usize,
    precision: Precision,
    rng: &mut Rng,
) -> lrr_formats::StoredMatrix {
    let mut row = vec![0.0f32; k];
    let mut all = Vec::with_capacity(n * k);
    for _ in 0..n {
        let mut sum = 0.0f64;
        for v in row.iter_mut() {
            let u = rng.unit();
            *v = if u < 0.33 { 0.0 } else { u };
            sum += f64::from(*v);
        }
        let scale = if sum > 0.0 {
            (0.3 + 0.6 * f64::from(rng.unit())) / sum
        } else {
            0.0
        };
        all.extend(row.iter().map(|&v| (f64::from(v) * scale) as f32));
    }
    lrr_formats::StoredMatrix::from_f32(&all, precision)
}

/// Random areas in [0.5, 1.5) normalised per patch: `w = A_e / A_p` in (0, 1].
fn weights(index: &[u32], rng: &mut Rng) -> Vec<f32> {
    let mut w = Vec::with_capacity(index.last().map_or(0, |&n| n as usize));
    for p in index.windows(2) {
        let areas: Vec<f64> = (p[0]..p[1]).map(|_| 0.5 + f64::from(rng.unit())).collect();
        let total: f64 = areas.iter().sum();
        w.extend(
            areas
                .iter()
                .map(|a| ((a / total) as f32).clamp(f32::MIN_POSITIVE, 1.0)),
        );
    }
    w
}

/// File position -> id: each patch's elements get a run of consecutive ids, the runs in a random
/// order (Fisher–Yates over the patches).
fn runs(index: &[u32], rng: &mut Rng) -> Vec<u32> {
    let k = index.len() - 1;
    let mut patches: Vec<usize> = (0..k).collect();
    for i in (1..k).rev() {
        patches.swap(i, rng.below(i + 1));
    }
    let mut order = vec![0u32; index[k] as usize];
    let mut next = 0u32;
    for p in patches {
        for s in index[p]..index[p + 1] {
            order[s as usize] = next;
            next += 1;
        }
    }
    order
}

/// About 1% of the elements emit; three light groups of about 0.5% each.
fn emit(file: &mut OperatorFile, rng: &mut Rng) -> Result<(), RuntimeError> {
    let n = file.n as usize;
    for s in 0..n {
        if rng.below(100) == 0 || s == 0 {
            let e: [f32; 3] = std::array::from_fn(|_| 10.0 * rng.unit());
            file.emission[3 * s..3 * s + 3].copy_from_slice(&e);
        }
    }
    if n < 3 {
        return Ok(());
    }
    for g in 0..3 {
        let positions: Vec<u32> = (0..n as u32)
            .filter(|&s| rng.below(200) == 0 || s as usize == g)
            .collect();
        let emission: Vec<f32> = (0..3 * positions.len()).map(|_| 5.0 * rng.unit()).collect();
        let group = file.light_group(format!("group {g}"), positions, emission)?;
        file.lights.push(group);
    }
    Ok(())
}

/// Unit squares on a grid, facing +z.
fn grid(n: usize) -> Geometry {
    let width = (n as f64).sqrt().ceil() as usize;
    let mut vertices = Vec::with_capacity(12 * n);
    for e in 0..n {
        let (x, y) = ((e % width) as f32, (e / width) as f32);
        vertices.extend([
            x,
            y,
            0.0,
            x + 1.0,
            y,
            0.0,
            x + 1.0,
            y + 1.0,
            0.0,
            x,
            y + 1.0,
            0.0,
        ]);
    }
    Geometry {
        vertex_count: vec![4; n],
        vertices,
        normals: [0.0, 0.0, 1.0].repeat(n),
    }
}

/// xorshift64* (Vigna): small, fast, good enough for test data.
struct Rng(u64);

impl Rng {
    fn new(seed: u64) -> Self {
        // Any seed, even 0, gives a non-zero state.
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }

    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in [0, 1), 24 bits.
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in `0..n` (n > 0; the modulo bias is irrelevant here).
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn operators_are_valid_and_deterministic() {
        for (layout, precision, channels) in [
            (Layout::Factored, Precision::F32, 3),
            (Layout::Factored, Precision::F16, 1),
            (Layout::PlainYk, Precision::F16, 3),
            (Layout::PlainYk, Precision::F32, 1),
        ] {
            let a = file(50, 7, channels, precision, layout, 9).unwrap();
            a.validate().unwrap();
            assert_eq!(a, file(50, 7, channels, precision, layout, 9).unwrap());
            assert_ne!(a, file(50, 7, channels, precision, layout, 10).unwrap());
            assert_eq!(a.layout(), layout);
            assert_eq!(a.channels as usize, channels);
            assert_eq!(a.lights.len(), 3);
        }
        assert!(file(5, 6, 3, Precision::F32, Layout::Factored, 0).is_err());
        assert!(file(5, 2, 2, Precision::F32, Layout::Factored, 0).is_err());
    }
}
