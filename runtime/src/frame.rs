//! The steps of a frame, shared by [`Operator::evaluate`](crate::Operator::evaluate) (one
//! thread) and the [`Evaluator`](crate::Evaluator) (a pool):
//!
//! 1. `X = Vᵀ E`: weighted segment sums over the index vector, f64 (a patch may hold thousands
//!    of elements), or `X = Σ_g a_g x_g` from the light groups: O(n) or O(k G), caller thread;
//! 2. `z_c = M_c X_c` (factored, O(k²) per channel) or `z = X` (plain), rounded to f32;
//! 3. the gather `W = M z` over the stored matrix: the O(nk) pass, rows split over threads
//!    (`pass.rs`, run per chunk by the pool);
//! 4. `B_c = E_c + ρ_c ⊙ W_c` (factored) or `B_c = E_c - W_c` (plain), per original id.
//!
//! Steps 1 and 4 walk the caller's buffers in original id order: see [`Runs`].

use std::sync::Arc;

use lrr_formats::{OperatorData, OperatorFile};

use crate::albedo::Albedo;
use crate::error::{RuntimeError, input};
use crate::kernel::SimdLevel;
use crate::pool::Chunk;
use crate::rgb::{Rgb, RgbMut};
use crate::runs::Runs;

/// What the caller-thread steps read: the file's structure and the current albedo (which an
/// evaluator may have edited without touching the shared file).
#[derive(Debug)]
pub(crate) struct Frame {
    pub file: Arc<OperatorFile>,
    pub runs: Runs,
    /// Factored: `core_channels * k * k` cores. Plain: empty.
    pub cores: Vec<f64>,
    pub core_channels: usize,
    /// Factored: `n * 3` in original id order. Plain: empty.
    pub reflectance_by_id: Vec<f32>,
}

impl Frame {
    /// The frame of `file` with its own albedo, for chunks of rows between `bounds`.
    pub(crate) fn new(file: Arc<OperatorFile>, bounds: &[usize]) -> Self {
        let runs = Runs::new(&file, bounds);
        let (cores, reflectance_by_id) = match &file.operator {
            OperatorData::Factored { cores, .. } => {
                (cores.clone(), runs.rgb_by_id(&file.reflectance))
            }
            OperatorData::PlainYk { .. } => (Vec::new(), Vec::new()),
        };
        Frame {
            core_channels: file.channels as usize,
            file,
            runs,
            cores,
            reflectance_by_id,
        }
    }

    /// Replaces the albedo after an edit; `rho` is the new reflectance by original id.
    pub(crate) fn set_albedo(&mut self, edit: Albedo, rho: &[[f32; 3]]) {
        self.cores = edit.cores;
        self.core_channels = edit.channels;
        self.reflectance_by_id = rho.as_flattened().to_vec();
    }

    /// Bytes held besides the shared file.
    pub(crate) fn bytes(&self) -> usize {
        self.runs.bytes() + 8 * self.cores.len() + 4 * self.reflectance_by_id.len()
    }

    fn factored(&self) -> bool {
        matches!(self.file.operator, OperatorData::Factored { .. })
    }

    /// `X = Vᵀ E` in f64, refusing non-finite or negative emission before anything is written.
    pub(crate) fn segment_sums(
        &self,
        e: &Rgb<'_>,
        x: &mut [[f64; 3]],
        simd: SimdLevel,
    ) -> Result<(), RuntimeError> {
        self.runs.segment_sums(&self.file.weights, e, x, simd)
    }

    /// `X = Σ_g a_g x_g`, refusing a wrong count or a non-finite or negative intensity.
    pub(crate) fn group_sums(&self, a: &[f32], x: &mut [[f64; 3]]) -> Result<(), RuntimeError> {
        check_intensities(&self.file, a)?;
        x.fill([0.0; 3]);
        for (g, &a) in self.file.lights.iter().zip(a) {
            if a == 0.0 {
                continue;
            }
            for (xp, gp) in x.iter_mut().zip(g.x.chunks_exact(3)) {
                for c in 0..3 {
                    xp[c] += f64::from(a) * gp[c];
                }
            }
        }
        Ok(())
    }

    /// `z[c kp + p]`: `(M_c X_c)(p)` (factored) or `X_c(p)` (plain), as f32; `z` past `k` stays
    /// as it is (zero).
    pub(crate) fn core_product(&self, x: &[[f64; 3]], z: &mut [f32], kp: usize) {
        let k = x.len();
        for c in 0..3 {
            let plane = &mut z[c * kp..c * kp + k];
            if !self.factored() {
                for (zp, xp) in plane.iter_mut().zip(x) {
                    *zp = xp[c] as f32;
                }
                continue;
            }
            let core = if self.core_channels == 1 { 0 } else { c };
            let m = &self.cores[core * k * k..(core + 1) * k * k];
            for (zp, row) in plane.iter_mut().zip(m.chunks_exact(k)) {
                *zp = dot_f64(row, x, c) as f32;
            }
        }
    }

    /// Step 4 for the ids of a computed chunk: `E + ρ ⊙ W` (factored) or `E - W` (plain);
    /// `E = 0` when `e` is `None`.
    pub(crate) fn finish(&self, chunk: &Chunk, e: Option<&Rgb<'_>>, out: &mut RgbMut<'_>) {
        let rho = self.factored().then_some(&self.reflectance_by_id[..]);
        let rows = chunk.rows.clone();
        self.runs.finish(chunk.index, rows, &chunk.w, rho, e, out);
    }

    /// Adds `Σ_g a_g E_g` over the groups' positions (after [`finish`](Self::finish) with no
    /// emission); `a` was checked by [`group_sums`](Self::group_sums).
    pub(crate) fn add_group_emission(&self, a: &[f32], out: &mut RgbMut<'_>) {
        for (g, &a) in self.file.lights.iter().zip(a) {
            if a == 0.0 {
                continue;
            }
            for (&s, e) in g.positions.iter().zip(g.emission.chunks_exact(3)) {
                let id = self.file.order[s as usize] as usize;
                let b = out.get(id);
                out.set(id, std::array::from_fn(|c| b[c] + a * e[c]));
            }
        }
    }
}

/// `Σ_q row[q] x[q][c]` in four f64 lanes: one serial chain of additions would wait on the add
/// latency (the k×k product then took as long as the pass over `F_k` at n = 2000, k = 216).
fn dot_f64(row: &[f64], x: &[[f64; 3]], c: usize) -> f64 {
    let mut lanes = [0.0f64; 4];
    let (rows, xs) = (row.chunks_exact(4), x.chunks_exact(4));
    let tail: f64 = (rows.remainder().iter().zip(xs.remainder()))
        .map(|(m, xq)| m * xq[c])
        .sum();
    for (m, xq) in rows.zip(xs) {
        for j in 0..4 {
            lanes[j] += m[j] * xq[j][c];
        }
    }
    (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]) + tail
}

/// Refuses intensities that do not fit the file's light groups.
pub(crate) fn check_intensities(f: &OperatorFile, a: &[f32]) -> Result<(), RuntimeError> {
    if a.len() != f.lights.len() {
        let names: Vec<&str> = f.lights.iter().map(|g| g.name.as_str()).collect();
        return Err(input(format!(
            "intensities: one per light group expected, the file has {} ({names:?}), found {}",
            f.lights.len(),
            a.len()
        )));
    }
    if let Some(g) = a.iter().position(|a| !(a.is_finite() && *a >= 0.0)) {
        return Err(input(format!(
            "intensity of light group {g} ({:?}) is {}: intensities must be finite and \
             non-negative",
            f.lights[g].name, a[g]
        )));
    }
    Ok(())
}
