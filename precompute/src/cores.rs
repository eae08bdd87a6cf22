//! The low-rank operator (DESIGN.md §2): per channel `c`, the k×k core
//! `M_c = (I_k - Vᵀ diag(ρ_c) F_k)⁻¹`, so that `B_c = E_c + ρ_c ⊙ F_k M_c (Vᵀ E_c)`.
//!
//! `(Vᵀ diag(ρ_c) F_k)(p, q) = Σ_{e ∈ p} w_e ρ_c(e) F(e, q)` costs O(nk) from the index vector;
//! V is never formed. Each core is LU-factored with partial pivoting (faer) and inverted; its
//! 1-norm condition number `‖A‖₁‖A⁻¹‖₁` is reported, and a system that is numerically singular
//! is refused instead of producing NaNs.

use faer::Mat;
use faer::linalg::solvers::DenseSolveCore;
use lrr_formats::MAX_CONDITION;

use crate::error::{Error, Result};

/// The per-channel cores.
#[derive(Debug, Clone, PartialEq)]
pub struct Cores {
    pub k: usize,
    /// 1 (grey scene) or 3.
    pub channels: usize,
    /// `channels × k × k`, row-major.
    pub m: Vec<f64>,
    /// 1-norm condition number of `I - VᵀU` per channel.
    pub condition: Vec<f64>,
}

/// Inputs in file order: `fk` is n×k row-major, `weights` and `reflectance` per element.
pub(crate) struct OperatorInputs<'a> {
    pub fk: &'a [f64],
    pub weights: &'a [f64],
    pub index: &'a [u32],
    pub reflectance: &'a [[f64; 3]],
    pub channels: usize,
}

/// Bytes [`build_cores`] holds at most for `k` patches and `channels` channels: the systems
/// and the inverses kept (`c k²` f64 each), and while one channel is inverted its LU factors,
/// the inverse and a copy (`3 k²`). The merge of a sharded bake plans with it too.
pub(crate) fn cores_bytes(k: usize, channels: usize) -> u128 {
    let (k, c) = (k as u128, channels as u128);
    (2 * c + 3) * k * k * 8
}

/// Refuses cores over `max_memory` ([`crate::memory::check_with`]) together with the `n`
/// rows of f64 element-to-patch factors they are built from, which are held meanwhile; the
/// cores' own bytes otherwise.
pub(crate) fn check_memory(
    k: usize,
    channels: usize,
    n: usize,
    max_memory: Option<u64>,
) -> Result<u128> {
    let bytes = cores_bytes(k, channels);
    let rows = (n as u128) * (k as u128) * 8;
    crate::memory::check_with(
        rows + bytes,
        max_memory,
        &format!(
            "the radiosity system's cores ({channels} × k² with k = {k} patches) with the \
             n = {n} rows they are built from"
        ),
        "use a larger --patch-size, or raise --max-memory",
    )?;
    Ok(bytes)
}

/// Builds and inverts `I - VᵀU` for every channel.
pub(crate) fn build_cores(inp: &OperatorInputs) -> Result<Cores> {
    let mut systems = Systems::new(inp.weights, inp.index, inp.reflectance, inp.channels);
    systems.add_rows(inp.fk);
    systems.finish()
}

/// The systems `A_c = I_k - Vᵀ diag(ρ_c) F_k` of every channel, summed from the rows of `F_k`
/// as they come (in file order, in pieces of whole rows): the merge of a sharded bake streams
/// its rows through this, a bake passes all of them at once, and both get the same bits (each
/// entry takes the same terms in the same order).
pub(crate) struct Systems<'a> {
    weights: &'a [f64],
    index: &'a [u32],
    reflectance: &'a [[f64; 3]],
    a: Vec<Mat<f64>>,
    /// The next row's file position and its patch.
    row: usize,
    patch: usize,
}

impl<'a> Systems<'a> {
    /// Identity systems for `channels` channels; `weights`, `index`, `reflectance` in file order.
    pub(crate) fn new(
        weights: &'a [f64],
        index: &'a [u32],
        reflectance: &'a [[f64; 3]],
        channels: usize,
    ) -> Self {
        let k = index.len() - 1;
        Self {
            weights,
            index,
            reflectance,
            a: (0..channels).map(|_| Mat::<f64>::identity(k, k)).collect(),
            row: 0,
            patch: 0,
        }
    }

    /// Takes in the next rows of `F_k` (k values each).
    pub(crate) fn add_rows(&mut self, rows: &[f64]) {
        let k = self.index.len() - 1;
        if k == 0 {
            return;
        }
        for row in rows.chunks_exact(k) {
            let s = self.row;
            while self.index[self.patch + 1] as usize <= s {
                self.patch += 1;
            }
            let p = self.patch;
            for (c, a) in self.a.iter_mut().enumerate() {
                let scale = self.weights[s] * self.reflectance[s][c];
                if scale == 0.0 {
                    continue;
                }
                for (q, f) in row.iter().enumerate() {
                    a[(p, q)] -= scale * f;
                }
            }
            self.row += 1;
        }
    }

    /// Inverts every channel's system (all n rows must have been added).
    pub(crate) fn finish(self) -> Result<Cores> {
        let k = self.index.len() - 1;
        assert_eq!(self.row, self.weights.len(), "every row of F_k is needed");
        let channels = self.a.len();
        let mut m = Vec::with_capacity(channels * k * k);
        let mut condition = Vec::with_capacity(channels);
        for (c, a) in self.a.iter().enumerate() {
            let (inverse, kappa) = invert(a, c)?;
            for p in 0..k {
                for q in 0..k {
                    m.push(inverse[(p, q)]);
                }
            }
            condition.push(kappa);
        }
        Ok(Cores {
            k,
            channels,
            m,
            condition,
        })
    }
}

/// `A = I_k - Vᵀ diag(ρ_c) F_k`, patch by patch: what [`Systems`] must agree with.
#[cfg(test)]
fn system_matrix(inp: &OperatorInputs, c: usize) -> Mat<f64> {
    let k = inp.index.len() - 1;
    let mut a = Mat::<f64>::identity(k, k);
    for p in 0..k {
        for s in inp.index[p] as usize..inp.index[p + 1] as usize {
            let scale = inp.weights[s] * inp.reflectance[s][c];
            if scale == 0.0 {
                continue;
            }
            let row = &inp.fk[s * k..(s + 1) * k];
            for (q, f) in row.iter().enumerate() {
                a[(p, q)] -= scale * f;
            }
        }
    }
    a
}

/// Inverts a system matrix, with its 1-norm condition number; refuses singular systems.
pub(crate) fn invert(a: &Mat<f64>, channel: usize) -> Result<(Mat<f64>, f64)> {
    let lu = a.partial_piv_lu();
    let inverse = lu.inverse();
    let kappa = norm_1(a) * norm_1(&inverse);
    let finite =
        (0..inverse.nrows()).all(|i| (0..inverse.ncols()).all(|j| inverse[(i, j)].is_finite()));
    if !finite || !kappa.is_finite() || kappa > MAX_CONDITION {
        return Err(Error::Numerical(format!(
            "the radiosity system of channel {channel} is numerically singular (condition number {kappa:.3e}, \
             limit {MAX_CONDITION:.0e}): light does not decay. This happens when reflectance is 1 (or \
             extremely close to it) in a closed scene; lower the reflectance (e.g. to 0.999) or open the scene"
        )));
    }
    Ok((inverse, kappa))
}

/// Induced 1-norm: the largest absolute column sum (faer's `norm_l1` is the entrywise sum).
pub(crate) fn norm_1(a: &Mat<f64>) -> f64 {
    (0..a.ncols())
        .map(|j| (0..a.nrows()).map(|i| a[(i, j)].abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_patch_system_inverts_exactly() {
        // n = 2, k = 2, each element its own patch, each sees the other with F = 1 (two
        // infinite parallel plates): B = E + ρ B_other.
        let fk = [0.0, 1.0, 1.0, 0.0];
        let inp = OperatorInputs {
            fk: &fk,
            weights: &[1.0, 1.0],
            index: &[0, 1, 2],
            reflectance: &[[0.5; 3], [0.5; 3]],
            channels: 1,
        };
        let cores = build_cores(&inp).unwrap();
        // A = [[1, -0.5], [-0.5, 1]], A⁻¹ = [[4/3, 2/3], [2/3, 4/3]]
        let expected = [4.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0, 4.0 / 3.0];
        for (a, b) in cores.m.iter().zip(expected) {
            assert!((a - b).abs() < 1e-14);
        }
        assert!((cores.condition[0] - 1.5 * 2.0).abs() < 1e-12);
    }

    #[test]
    fn rows_in_pieces_give_the_bits_of_the_whole_system() {
        // n = 7 elements in k = 3 patches (one empty), coloured reflectance, one black element.
        let (n, k) = (7usize, 3usize);
        let fk: Vec<f64> = (0..n * k)
            .map(|i| ((i * 7919) % 97) as f64 / 331.0)
            .collect();
        let index = [0u32, 3, 3, 7];
        let weights = [0.2, 0.5, 0.3, 0.1, 0.4, 0.25, 0.25];
        let reflectance: Vec<[f64; 3]> = (0..n)
            .map(|s| [0.1 * s as f64 % 0.9, 0.3, if s == 4 { 0.0 } else { 0.7 }])
            .collect();
        let inp = OperatorInputs {
            fk: &fk,
            weights: &weights,
            index: &index,
            reflectance: &reflectance,
            channels: 3,
        };
        let whole = build_cores(&inp).unwrap();
        let mut systems = Systems::new(&weights, &index, &reflectance, 3);
        for piece in [0, 2, 3, 7].windows(2) {
            systems.add_rows(&fk[piece[0] * k..piece[1] * k]);
        }
        for c in 0..3 {
            let a = system_matrix(&inp, c);
            for p in 0..k {
                for q in 0..k {
                    assert_eq!(systems.a[c][(p, q)].to_bits(), a[(p, q)].to_bits());
                }
            }
        }
        assert_eq!(systems.finish().unwrap(), whole);
    }

    #[test]
    fn reflectance_one_in_a_closed_pair_is_refused() {
        let fk = [0.0, 1.0, 1.0, 0.0];
        let inp = OperatorInputs {
            fk: &fk,
            weights: &[1.0, 1.0],
            index: &[0, 1, 2],
            reflectance: &[[1.0; 3], [1.0; 3]],
            channels: 1,
        };
        let e = build_cores(&inp).unwrap_err().to_string();
        assert!(e.contains("singular") && e.contains("reflectance"), "{e}");
    }
}
