//! A straightforward f64 evaluation of an operator file: the yardstick for the fast paths.
//!
//! Every product and sum in f64, one element at a time, no blocking, no threads; the only
//! roundings are those of the stored values themselves. O(nk) but slow: for tests and accuracy
//! reports, not for frames.

use lrr_formats::{OperatorData, OperatorFile};

use crate::error::{RuntimeError, input};

/// `B~` for `emission` (one RGB value per element, original ids), in original id order.
///
/// Factored: `B_c = E_c + ρ_c ⊙ F_k M_c (Vᵀ E_c)`; plain: `B_c = E_c - Y_c (Vᵀ E_c)`. Errors
/// only on a wrong length (values are used as they are).
pub fn evaluate(file: &OperatorFile, emission: &[[f32; 3]]) -> Result<Vec<[f64; 3]>, RuntimeError> {
    let (n, k) = (file.n as usize, file.k as usize);
    if emission.len() != n {
        return Err(input(format!(
            "emission: one RGB value per element expected (n = {n}), found {}",
            emission.len()
        )));
    }
    let mut x = vec![[0.0f64; 3]; k];
    for (p, xp) in x.iter_mut().enumerate() {
        for s in file.index[p] as usize..file.index[p + 1] as usize {
            let e = emission[file.order[s] as usize];
            for c in 0..3 {
                xp[c] += f64::from(file.weights[s]) * f64::from(e[c]);
            }
        }
    }
    let channels = file.channels as usize;
    // Z_c = M_c X_c (factored only).
    let mut z = vec![[0.0f64; 3]; k];
    if let OperatorData::Factored { cores, .. } = &file.operator {
        for c in 0..3 {
            let block = if channels == 1 { 0 } else { c };
            let m = &cores[block * k * k..(block + 1) * k * k];
            for (q, zq) in z.iter_mut().enumerate() {
                zq[c] = (0..k).map(|p| m[q * k + p] * x[p][c]).sum();
            }
        }
    }
    let mut out = vec![[0.0f64; 3]; n];
    for (s, &id) in file.order.iter().enumerate() {
        let e = emission[id as usize];
        for c in 0..3 {
            let block = if channels == 1 { 0 } else { c };
            let b = match &file.operator {
                OperatorData::Factored { fk, .. } => {
                    let w: f64 = (0..k)
                        .map(|q| f64::from(fk.get(s * k + q).unwrap_or(f32::NAN)) * z[q][c])
                        .sum();
                    f64::from(e[c]) + f64::from(file.reflectance[3 * s + c]) * w
                }
                OperatorData::PlainYk { yk } => {
                    let row = (block * n + s) * k;
                    let w: f64 = (0..k)
                        .map(|q| f64::from(yk.get(row + q).unwrap_or(f32::NAN)) * x[q][c])
                        .sum();
                    f64::from(e[c]) - w
                }
            };
            out[id as usize][c] = b;
        }
    }
    Ok(out)
}
