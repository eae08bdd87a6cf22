//! The dense radiosity system `(I − diag(ρ_c) F) B_c = E_c` (DESIGN.md §1), solved by LU per
//! channel, and the relative error measure every comparison uses. Any square form-factor
//! matrix will do: the exact n×n one ([`crate::exact`]) or 2MSC's coarse probe system
//! ([`crate::patches::coherence`]).

use faer::Mat;
use faer::linalg::solvers::Solve;

use crate::error::{Error, Result};

/// Per-element reflectance and emission in original id order.
pub struct ElementData<'a> {
    /// RGB reflectance ρ per element, each in [0, 1).
    pub reflectance: &'a [[f64; 3]],
    /// RGB emitted exitance `E = π·Ke` per element (W/m² style).
    pub emission: &'a [[f64; 3]],
}

/// Solves `(I - diag(ρ_c) F) B_c = E_c` for c = r, g, b with dense LU.
pub(crate) fn solve_dense(f: &[f64], data: &ElementData) -> Result<Vec<[f64; 3]>> {
    let n = data.reflectance.len();
    let mut out = vec![[0.0; 3]; n];
    for c in 0..3 {
        let a = Mat::<f64>::from_fn(n, n, |i, j| {
            let d = if i == j { 1.0 } else { 0.0 };
            d - data.reflectance[i][c] * f[i * n + j]
        });
        let e = Mat::<f64>::from_fn(n, 1, |i, _| data.emission[i][c]);
        let b = a.partial_piv_lu().solve(&e);
        for i in 0..n {
            let v = b[(i, 0)];
            if !v.is_finite() {
                return Err(Error::Numerical(format!(
                    "the exact radiosity system of channel {c} is singular (element {i} got {v}); \
                     reflectance 1 in a closed scene never lets light decay"
                )));
            }
            out[i][c] = v;
        }
    }
    Ok(out)
}

/// Relative L2 error `‖a - b‖ / ‖b‖` over all channels.
pub fn relative_l2(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let mut num = 0.0;
    let mut den = 0.0;
    for (x, y) in a.iter().zip(b) {
        for c in 0..3 {
            num += (x[c] - y[c]).powi(2);
            den += y[c].powi(2);
        }
    }
    if den == 0.0 {
        num.sqrt()
    } else {
        (num / den).sqrt()
    }
}
