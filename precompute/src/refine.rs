//! Refinement where light changes (issue #14, `lrr bake --refine B`): the fine mesh split
//! once more where a first solve on it shows the radiosity jumping between neighbours (shadow
//! boundaries, contact lines, the bright spots near emitters), under a budget of `B · n0` new
//! elements.
//!
//! 1. *First pass.* The default mesh (`n0` elements) is baked as usual up to `F_k` (the rows a
//!    bake computes anyway, checkpointed as an unrefined bake's), and solved once with the
//!    scene's own emission through the low-rank operator: `B_P = M_c Vᵀ E_c`, then
//!    `B_e = E_e + ρ_e Σ_p F_ep B_p` per channel, averaged over the channels.
//! 2. *Indicator.* The smooth reconstruction's vertices ([`crate::mesh::smooth`]) say which
//!    elements have a corner at a point of one smooth surface (not across creases or contact
//!    lines). At
//!    each vertex the relative jump `(max B − min B) / (max B + B_floor)` of its elements is
//!    taken, `B_floor` = [`FLOOR`] × the area-weighted mean radiosity (so the noise of dark
//!    corners does not count); an element's indicator is the largest jump at its corners.
//! 3. *Split.* Elements are taken by decreasing indicator (ties by id) while the indicator is
//!    at least [`MIN_JUMP`] and the elements added stay within the budget; each is split once
//!    in the subdivision hierarchy (quads 2×2 or 1×2, triangles 4-way: `subdivide::split`), so
//!    `--element-size` stays the upper bound and every child stays inside its patch.
//! 4. *Rows.* The patches are unchanged, so the row of an element that was not split is the
//!    one the first pass computed: it keeps its id (the sampling seed), a split element's
//!    first child takes the parent's id and the other children are appended after `n0`. Only
//!    the children's rows are integrated: `F_k` costs `(n0 + children) · k` rows, and a bake
//!    that recomputed every row of the refined mesh would write the same bytes.
//!
//! Everything runs in file order with sorts keyed by id: the result does not depend on the
//! thread count.

use crate::cores::{OperatorInputs, build_cores};
use crate::error::{Error, Result};
use crate::formfactor::FormFactors;
use crate::geometry::{Polygon, Region};
use crate::memory;
use crate::mesh::{Element, MAX_ELEMENTS, smooth, subdivide};
use crate::patches::Mesh;
use crate::progress::Progress;
use crate::scene::Scene;

/// Jumps below this relative size do not refine (a uniformly lit wall stays as it is).
pub const MIN_JUMP: f64 = 0.1;
/// `B_floor` as a share of the mean radiosity: below it differences count as noise.
pub const FLOOR: f64 = 0.05;

/// The refined mesh and its `F_k` (n×k, file order).
pub(crate) struct Refined {
    pub mesh: Mesh,
    pub fk: Vec<f64>,
    /// Elements split.
    pub split: usize,
}

/// The first pass's radiosity per file position (channels averaged): the low-rank solve of
/// the scene's emission through `F_k`.
pub(crate) fn first_pass(
    mesh: &Mesh,
    fk: &[f64],
    reflectance: &[[f64; 3]],
    emission: &[[f64; 3]],
    channels: usize,
) -> Result<Vec<f64>> {
    let (n, k) = (mesh.n(), mesh.k());
    let cores = build_cores(&OperatorInputs {
        fk,
        weights: &mesh.weights,
        index: &mesh.index,
        reflectance,
        channels,
    })?;
    let mut out = vec![0.0; n];
    for c in 0..channels {
        let mut ve = vec![0.0; k];
        for (p, v) in ve.iter_mut().enumerate() {
            let (a, b) = (mesh.index[p] as usize, mesh.index[p + 1] as usize);
            *v = (a..b).map(|s| mesh.weights[s] * emission[s][c]).sum();
        }
        let m = &cores.m[c * k * k..(c + 1) * k * k];
        let bp: Vec<f64> = (0..k)
            .map(|i| (0..k).map(|j| m[i * k + j] * ve[j]).sum())
            .collect();
        for (s, o) in out.iter_mut().enumerate() {
            let row = &fk[s * k..(s + 1) * k];
            let gathered: f64 = row.iter().zip(&bp).map(|(f, b)| f * b).sum();
            *o += (emission[s][c] + reflectance[s][c] * gathered) / channels as f64;
        }
    }
    Ok(out)
}

/// Per file position: the largest relative jump of the first pass's radiosity `values` at the
/// element's smooth vertices (see the module docs).
pub(crate) fn indicator(scene: &Scene, mesh: &Mesh, values: &[f64]) -> Vec<f64> {
    let elements: Vec<&Element> = (0..mesh.n()).map(|s| mesh.element_at(s)).collect();
    let s = smooth::weights(scene, &elements);
    let area: Vec<f64> = elements.iter().map(|e| e.polygon.area()).collect();
    let total: f64 = area.iter().sum();
    let mean = values.iter().zip(&area).map(|(v, a)| v * a).sum::<f64>() / total.max(1e-300);
    let floor = FLOOR * mean.max(0.0) + f64::MIN_POSITIVE;
    // The elements with a corner at each vertex. Not the vertex's weights: a boundary
    // vertex extrapolates from a ring two elements wide, which marked elements far from the
    // jump (tried: splits in a penumbra's umbra along the floor's edges).
    let mut at: Vec<Vec<usize>> = vec![Vec::new(); s.offsets.len() - 1];
    for (e, element) in elements.iter().enumerate() {
        for &v in &s.corners[4 * e..4 * e + element.polygon.count] {
            if v != lrr_formats::Smooth::NONE {
                at[v as usize].push(e);
            }
        }
    }
    let mut out = vec![0.0f64; values.len()];
    for members in &at {
        let (lo, hi) = members
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), &e| {
                let b = values[e].max(0.0);
                (lo.min(b), hi.max(b))
            });
        let jump = (hi - lo) / (hi + floor);
        for &e in members {
            out[e] = out[e].max(jump);
        }
    }
    out
}

/// Which elements (by original id) to split: by decreasing indicator while it is at least
/// [`MIN_JUMP`] and the elements added (children − 1 each) stay within `budget · n0`.
pub(crate) fn select(mesh: &Mesh, indicator: &[f64], budget: f64) -> Vec<bool> {
    let n0 = mesh.n();
    let allowed = (budget * n0 as f64).floor() as usize;
    let mut ranked: Vec<usize> = (0..n0).filter(|&s| indicator[s] >= MIN_JUMP).collect();
    ranked.sort_by(|&a, &b| {
        indicator[b]
            .total_cmp(&indicator[a])
            .then(mesh.order[a].cmp(&mesh.order[b]))
    });
    let mut marked = vec![false; n0];
    let mut added = 0;
    for s in ranked {
        let id = mesh.order[s] as usize;
        let extra = children(&mesh.elements[id].polygon) - 1;
        if added + extra > allowed {
            continue; // a 1×2 split may still fit
        }
        added += extra;
        marked[id] = true;
    }
    marked
}

/// Children of one split of `p` (`subdivide::split`).
fn children(p: &Polygon) -> usize {
    subdivide::split(p).len()
}

/// The mesh with the `marked` elements (by id) split once: a split element's first child
/// keeps its id, the others are appended in id order; patches are unchanged. Also the id of
/// every element's parent in `mesh` (its own id when kept).
pub(crate) fn split_marked(mesh: &Mesh, marked: &[bool]) -> (Mesh, Vec<u32>) {
    let mut elements = mesh.elements.clone();
    let mut parents: Vec<u32> = (0..mesh.n() as u32).collect();
    for (id, _) in marked.iter().enumerate().filter(|(_, m)| **m) {
        let parent = mesh.elements[id].clone();
        let mut kids = subdivide::split(&parent.polygon).into_iter();
        elements[id].polygon = kids.next().expect("a split has children");
        for polygon in kids {
            elements.push(Element {
                polygon,
                ..parent.clone()
            });
            parents.push(id as u32);
        }
    }
    let refined = Mesh {
        meshing: mesh.meshing.clone(),
        ..Mesh::from_parts(elements, mesh.patches.clone())
    };
    (refined, parents)
}

/// Refines the mesh of a first pass (`fk`, its n0×k rows, and the radiosity `values` per
/// file position) with a budget of `budget · n0` new elements, integrating only the rows of
/// the new elements.
#[allow(clippy::too_many_arguments)] // the first pass (mesh, rows, values) and the bake's settings
pub(crate) fn refine(
    scene: &Scene,
    mesh: &Mesh,
    fk: &[f64],
    values: &[f64],
    budget: f64,
    ff: &FormFactors,
    progress: &Progress,
    max_memory: Option<u64>,
) -> Result<Refined> {
    check_budget(budget)?;
    let ind = indicator(scene, mesh, values);
    let marked = select(mesh, &ind, budget);
    let (refined, parents) = split_marked(mesh, &marked);
    let (n0, k) = (mesh.n(), mesh.k());
    if refined.n() > MAX_ELEMENTS {
        return Err(Error::Limits(format!(
            "--refine {budget} would make {} elements, more than the limit of {MAX_ELEMENTS}; \
             use a smaller --refine or a larger --element-size",
            refined.n()
        )));
    }
    memory::check_with(
        (refined.n() as u128) * (k as u128) * 12,
        max_memory,
        "the refined element-to-patch matrix",
        "use a smaller --refine, or a larger --element-size or --patch-size",
    )?;
    let mut position_of = vec![0usize; n0];
    for (s, &id) in mesh.order.iter().enumerate() {
        position_of[id as usize] = s;
    }
    let fresh: Vec<usize> = (0..refined.n())
        .filter(|&s| {
            let id = refined.order[s] as usize;
            id >= n0 || marked[id]
        })
        .collect();
    let polygons: Vec<Polygon> = fresh
        .iter()
        .map(|&s| refined.element_at(s).polygon)
        .collect();
    let ids: Vec<u32> = fresh.iter().map(|&s| refined.order[s]).collect();
    let targets: Vec<Region> = refined.patches.iter().map(|p| p.shape.clone()).collect();
    let mut rows = vec![0.0; fresh.len() * k];
    let stage = progress.stage("refined rows", fresh.len() as u64);
    // A child is enclosed when its parent is (its rows sum to one likewise; the parent's probe
    // rays were spread over the child's area and its siblings').
    let closed: Option<Vec<bool>> = ff.closed.map(|c| {
        parents
            .iter()
            .map(|&p| c.get(p as usize).copied().unwrap_or(false))
            .collect()
    });
    let children = FormFactors::new(ff.samples, ff.occluder).with_enclosure(closed.as_deref());
    children.matrix(&polygons, &ids, &targets, &mut rows, &|i| stage.inc(i));
    ff.absorb(&children);
    stage.finish();
    let mut out = vec![0.0; refined.n() * k];
    let mut next = fresh.iter().zip(rows.chunks(k.max(1))).peekable();
    for s in 0..refined.n() {
        let dst = &mut out[s * k..(s + 1) * k];
        match next.peek() {
            Some((f, row)) if **f == s => {
                dst.copy_from_slice(row);
                next.next();
            }
            _ => {
                let p = position_of[refined.order[s] as usize];
                dst.copy_from_slice(&fk[p * k..(p + 1) * k]);
            }
        }
    }
    Ok(Refined {
        split: marked.iter().filter(|&&m| m).count(),
        mesh: refined,
        fk: out,
    })
}

/// `--refine` must be a share of n: a finite number ≥ 0.
pub(crate) fn check_budget(budget: f64) -> Result<()> {
    if budget.is_finite() && budget >= 0.0 {
        Ok(())
    } else {
        Err(Error::Settings(format!(
            "--refine must be a share of the element count of zero or more (e.g. 0.5 adds at \
             most n/2 elements), got {budget}"
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::MeshSizes;
    use crate::scene::procedural;
    use std::path::Path;

    /// The rows kept from the first pass and the children's rows are what integrating every
    /// row of the refined mesh afresh gives, bit for bit (the ids, hence the seeds, are kept).
    #[test]
    fn reused_rows_equal_rows_integrated_afresh() {
        let scene = procedural::furnace(0.5, 1.0)
            .build("f", Path::new("."))
            .unwrap();
        let sizes = MeshSizes {
            element_size: 0.25,
            patch_size: 0.5,
        };
        let mesh = Mesh::two_fixed(&scene, sizes).unwrap();
        let ff = FormFactors::new(4, None);
        let targets: Vec<Region> = mesh.patches.iter().map(|p| p.shape.clone()).collect();
        let rows = |m: &Mesh| {
            let polygons: Vec<Polygon> = (0..m.n()).map(|s| m.element_at(s).polygon).collect();
            let mut out = vec![0.0; m.n() * m.k()];
            ff.matrix(&polygons, &m.order, &targets, &mut out, &|_| {});
            out
        };
        let fk = rows(&mesh);
        // A step in x across the middle of the box: the elements either side of it jump.
        let xs: Vec<f64> = (0..mesh.n())
            .map(|s| mesh.element_at(s).polygon.centroid().x)
            .collect();
        let mid = 0.5
            * (xs.iter().cloned().fold(f64::MAX, f64::min)
                + xs.iter().cloned().fold(f64::MIN, f64::max));
        let values: Vec<f64> = xs
            .iter()
            .map(|&x| if x > mid { 1.0 } else { 0.1 })
            .collect();
        let budget = 0.25;
        let refined = refine(
            &scene,
            &mesh,
            &fk,
            &values,
            budget,
            &ff,
            &Progress::hidden(),
            None,
        )
        .unwrap();
        assert!(refined.split > 0);
        assert!(refined.mesh.n() - mesh.n() <= (budget * mesh.n() as f64) as usize);
        assert_eq!(refined.mesh.k(), mesh.k());
        refined.mesh.validate().unwrap();
        assert!(
            refined.fk == rows(&refined.mesh),
            "reused rows differ from fresh ones"
        );
        // Only elements at the step were split: every child's centroid is within one element
        // of the middle.
        for e in &refined.mesh.elements[mesh.n()..] {
            let x = e.polygon.centroid().x;
            assert!(
                (x - mid).abs() <= sizes.element_size,
                "a child at x = {x}, step at {mid}"
            );
        }
    }

    #[test]
    fn bad_budgets_are_errors() {
        for b in [-0.5, f64::NAN, f64::INFINITY] {
            let e = check_budget(b).unwrap_err().to_string();
            assert!(e.contains("--refine must be"), "{e}");
        }
    }
}
