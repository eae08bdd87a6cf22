//! Albedo edits: new reflectance, new k×k cores, no re-bake.
//!
//! `A_c = I - Vᵀ diag(ρ'_c) F_k`, i.e. `A_c(p, q) = δ_pq - Σ_{s ∈ p} w_s ρ'_c(s) F(s, q)`: one
//! pass over `F_k` and the index vector, O(nk); then `M_c = A_c⁻¹` by LU with partial pivoting in
//! f64, O(k³) per channel. A system whose 1-norm condition number `‖A‖₁ ‖A⁻¹‖₁` exceeds
//! [`MAX_CONDITION`] is refused, as the bake refuses it.

use lrr_formats::{MAX_CONDITION, OperatorData, OperatorFile, StoredMatrix, f16_to_f32};

use crate::error::{RuntimeError, input};
use crate::lu::{Lu, norm1};

/// The result of an edit: what a frame reads besides the shared matrix.
#[derive(Debug, Clone)]
pub(crate) struct Albedo {
    /// `channels * k * k` row-major.
    pub cores: Vec<f64>,
    /// 1 when the new reflectance is grey, else 3.
    pub channels: usize,
    /// `n * 3` in file order.
    pub reflectance: Vec<f32>,
}

/// New cores for `rho` (one RGB reflectance per element, original ids, each in [0, 1)).
pub(crate) fn rebuild(file: &OperatorFile, rho: &[[f32; 3]]) -> Result<Albedo, RuntimeError> {
    let OperatorData::Factored { fk, .. } = &file.operator else {
        return Err(RuntimeError::Input(
            "albedo edits need the factored layout (F_k and cores); this operator stores the \
             plain Y_k = -diag(ρ) F_k M, which has the reflectance baked in: re-bake with the \
             factored layout"
                .into(),
        ));
    };
    let (n, k) = (file.n as usize, file.k as usize);
    let reflectance = to_file_order(file, rho)?;
    let grey = reflectance
        .chunks_exact(3)
        .all(|r| r[0] == r[1] && r[1] == r[2]);
    let channels = if grey { 1 } else { 3 };
    let systems = system_matrices(file, fk, &reflectance, channels);
    let mut cores = Vec::with_capacity(channels * k * k);
    for (c, a) in systems.into_iter().enumerate() {
        cores.extend(invert(a, k, c, channels)?);
    }
    debug_assert_eq!(reflectance.len(), 3 * n);
    Ok(Albedo {
        cores,
        channels,
        reflectance,
    })
}

/// Checks `rho` and permutes it to file order.
fn to_file_order(file: &OperatorFile, rho: &[[f32; 3]]) -> Result<Vec<f32>, RuntimeError> {
    let n = file.n as usize;
    if rho.len() != n {
        return Err(input(format!(
            "reflectance: one RGB value per element expected (n = {n}), found {}",
            rho.len()
        )));
    }
    if let Some(id) = rho
        .iter()
        .position(|r| !r.iter().all(|v| v.is_finite() && (0.0..1.0).contains(v)))
    {
        return Err(input(format!(
            "reflectance of element {id} is {:?}: each channel must be in [0, 1) (a reflectance \
             of 1 or more reflects at least all light it receives and the system is singular)",
            rho[id]
        )));
    }
    let mut out = vec![0.0; 3 * n];
    for (s, &id) in file.order.iter().enumerate() {
        out[3 * s..3 * s + 3].copy_from_slice(&rho[id as usize]);
    }
    Ok(out)
}

/// `A_c` for each channel, row-major; one pass over `F_k`.
fn system_matrices(
    file: &OperatorFile,
    fk: &StoredMatrix,
    reflectance: &[f32],
    channels: usize,
) -> Vec<Vec<f64>> {
    let k = file.k as usize;
    let mut a: Vec<Vec<f64>> = (0..channels)
        .map(|_| {
            let mut m = vec![0.0; k * k];
            m.iter_mut().step_by(k + 1).for_each(|d| *d = 1.0);
            m
        })
        .collect();
    let mut row = vec![0.0f64; k];
    for p in 0..k {
        for s in file.index[p] as usize..file.index[p + 1] as usize {
            match fk {
                StoredMatrix::F32(v) => row
                    .iter_mut()
                    .zip(&v[s * k..(s + 1) * k])
                    .for_each(|(r, f)| *r = f64::from(*f)),
                StoredMatrix::F16(v) => row
                    .iter_mut()
                    .zip(&v[s * k..(s + 1) * k])
                    .for_each(|(r, &h)| *r = f64::from(f16_to_f32(h))),
            }
            let w = f64::from(file.weights[s]);
            for (c, a) in a.iter_mut().enumerate() {
                let scale = w * f64::from(reflectance[3 * s + c]);
                if scale != 0.0 {
                    let a_row = &mut a[p * k..(p + 1) * k];
                    a_row
                        .iter_mut()
                        .zip(&row)
                        .for_each(|(a, f)| *a -= scale * f);
                }
            }
        }
    }
    a
}

/// `A⁻¹`, refusing a numerically singular system.
fn invert(a: Vec<f64>, k: usize, c: usize, channels: usize) -> Result<Vec<f64>, RuntimeError> {
    let channel = if channels == 1 {
        "grey".to_string()
    } else {
        format!("channel {}", ["r", "g", "b"][c])
    };
    let norm = norm1(&a, k);
    let lu = Lu::factor(a, k).map_err(|col| {
        RuntimeError::Input(format!(
            "the reflectance edit makes the {channel} system I - Vᵀ diag(ρ) F_k exactly singular \
             (zero pivot in column {col}): lower the reflectance"
        ))
    })?;
    let inverse = lu.inverse();
    let condition = norm * norm1(&inverse, k);
    if condition.is_nan() || condition > MAX_CONDITION {
        return Err(RuntimeError::Input(format!(
            "the reflectance edit makes the {channel} system I - Vᵀ diag(ρ) F_k numerically \
             singular: 1-norm condition number {condition:.3e} > {MAX_CONDITION:e}: lower the \
             reflectance (closed scenes with reflectance near 1 reflect light forever)"
        )));
    }
    Ok(inverse)
}
