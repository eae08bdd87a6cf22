//! The exact reference (DESIGN.md §5): the full fine-mesh form-factor matrix `F` (n×n, the same
//! kernel and visibility as the bake) and a dense LU solve of `(I - R F) B = E` per channel.
//! Used by `lrr solve --exact` and by tests; practical up to n ≈ 10⁴ (memory 8n² bytes per
//! matrix, checked before allocating).

use crate::error::Result;
use crate::formfactor::FormFactors;
use crate::geometry::Polygon;
use crate::geometry::Region;
use crate::memory;
use crate::mesh::Element;
use crate::patches::Mesh;
use crate::radiosity::{ElementData, solve_dense};

/// The exact solution, per element in original id order.
pub struct ExactSolution {
    /// RGB radiosity `B` per element (original ids), same units as the emission.
    pub radiosity: Vec<[f64; 3]>,
    /// The n×n form-factor matrix (row-major, original ids), kept for checks.
    pub form_factors: Vec<f64>,
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
    let targets: Vec<Region> = mesh.elements.iter().map(Element::lit_region).collect();
    ff.matrix(&polygons, &ids, &targets, &mut f, progress);
    let radiosity = solve_dense(&f, data)?;
    Ok(ExactSolution {
        radiosity,
        form_factors: f,
    })
}
