//! The exact reference (DESIGN.md §5): the full fine-mesh form-factor matrix `F` (n×n, the same
//! kernel and visibility as the bake) and a dense LU solve of `(I - R F) B = E` per channel.
//! Used by `lrr solve --exact` and by tests; practical up to n ≈ 10⁴ (memory 8n² bytes per
//! matrix, checked before allocating).

use faer::Mat;
use faer::linalg::solvers::Solve;

use crate::error::{Error, Result};
use crate::formfactor::kernel::Polygon;
use crate::formfactor::{FormFactors, Target};
use crate::memory;
use crate::mesh::Mesh;

/// The exact solution, per element in original id order.
pub struct ExactSolution {
    pub radiosity: Vec<[f64; 3]>,
    /// The n×n form-factor matrix (row-major, original ids), kept for checks.
    pub form_factors: Vec<f64>,
}

/// Per-element reflectance and emission in original id order.
pub struct ElementData<'a> {
    pub reflectance: &'a [[f64; 3]],
    pub emission: &'a [[f64; 3]],
}

/// Computes the full matrix and solves for every channel.
pub fn solve_exact(
    mesh: &Mesh,
    data: &ElementData,
    ff: &FormFactors,
    max_memory: Option<u64>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<ExactSolution> {
    let n = mesh.n();
    let bytes = (n as u128) * (n as u128) * 8 * 2;
    memory::check_with(
        bytes,
        max_memory,
        "the exact solve (two n×n f64 matrices)",
        "use a larger --element-size",
    )?;
    let polygons: Vec<Polygon> = mesh.elements.iter().map(|e| e.polygon).collect();
    let ids: Vec<u32> = (0..n as u32).collect();
    let mut f = vec![0.0; n * n];
    let targets: Vec<Target> = polygons.iter().map(|&p| Target::single(p)).collect();
    ff.matrix(&polygons, &ids, &targets, &mut f, progress);
    let radiosity = solve_dense(&f, data)?;
    Ok(ExactSolution {
        radiosity,
        form_factors: f,
    })
}

/// Solves `(I - diag(ρ_c) F) B_c = E_c` for c = r, g, b with dense LU.
pub fn solve_dense(f: &[f64], data: &ElementData) -> Result<Vec<[f64; 3]>> {
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
