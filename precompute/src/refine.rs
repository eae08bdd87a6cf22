//! Refinement where light changes (issue #14, `lrr bake --refine B`, on by default with
//! [`DEFAULT_BUDGET`]): the fine mesh split once more where a first solve on it shows the
//! radiosity jumping between neighbours (shadow boundaries, contact lines, the bright spots
//! near emitters), under a budget of `B · n0` new elements. It is part of the mesh stage: the
//! bake then integrates `F_k` over the refined mesh like any other.
//!
//! 1. *First pass.* `F_k` of the default mesh (`n0` elements) at [`FIRST_PASS_SAMPLES`] per
//!    pair (or the bake's `--samples` when fewer), one ray each, the rows of enclosed elements
//!    rescaled to sum to one as the bake's are (`formfactor::enclosure`), solved once with the scene's own emission through the low-rank
//!    operator: `B_P = M_c Vᵀ E_c`, then `B_e = E_e + ρ_e Σ_p F_ep B_p` per channel, averaged
//!    over the channels. Its cost is about a tenth of the bake's form factors; every shard of
//!    a sharded bake (or `lrr plan`, once) repeats it and gets the same mesh.
//! 2. *Indicator.* The smooth reconstruction's vertices ([`crate::mesh::smooth`]) say which
//!    elements have a corner at a point of one smooth surface (not across creases or contact
//!    lines); an element that groups small faces (`mesh::dense`) has the corners of the faces
//!    it shows, as its proxy shares none with its neighbours. At
//!    each vertex the relative jump `(max B − min B) / (max B + B_floor)` of its elements is
//!    taken, `B_floor` = [`FLOOR`] × the area-weighted mean radiosity (so the noise of dark
//!    corners does not count); an element's indicator is the largest jump at its corners.
//! 3. *Split.* Elements are taken by decreasing indicator (ties by id) while the indicator is
//!    at least [`MIN_JUMP`] and the elements added stay within the budget; each is split once
//!    in the subdivision hierarchy (quads 2×2 or 1×2, triangles 4-way: `subdivide::split`), so
//!    `--element-size` stays the upper bound and every child stays inside its patch. An
//!    element that groups small faces shares them among up to four children
//!    (`mesh::split_group`: its faces bisected twice by their centroids, each child a proxy of
//!    its own faces or a lone face, lit on its faces when the parent was). A child's proxy
//!    does not lie inside the parent's, so the patch's shape (a cluster's or a merged
//!    patch's: the union of its elements' polygons) takes the children's polygons in place of
//!    the parent's proxy, of the same area; a group whose proxy is not one of its patch's
//!    polygons is not split. What is drawn does not change. Before this (refinement revision 3) such elements were never split,
//!    so a tessellated sphere's shading kept its proxies' steps: the dense sphere's points on
//!    the sphere, p90 16.9 % → 4.2 % against the path tracer (docs/ACCURACY.md).
//! 4. *Ids and samples.* The patches are the same (`k` and their areas; only a split
//!    group's patch's shape is redrawn, as above); a split element's first child takes the
//!    parent's id and the other children are appended after `n0` (ids seed the sampling of a
//!    row). A child's row takes half the bake's samples per pair (`Mesh::siblings`,
//!    `formfactor::MAX_SAMPLE_SHARE`: 8 of 16), so the four children of a 2×2 split cost
//!    about twice what their parent did instead of four times (Cornell box: smooth p90 4.65%
//!    against 4.53% with 16 samples per child; bake time in docs/ACCURACY.md).
//!
//! Everything runs in file order with sorts keyed by id: the result does not depend on the
//! thread count.
//!
//! Tried and replaced: a first pass of the bake's own 16 samples, whose rows the bake then
//! kept for the elements not split (only the children's rows integrated afterwards). It made
//! the same mesh quality (Cornell box p90 4.7% against 4.5% now) at about the same total cost,
//! but the first pass needed every row of `F_k`, which a shard of a sharded bake does not have.

use std::collections::BTreeMap;

use rayon::prelude::*;

use crate::checkpoint::{self, Checkpoint, CheckpointSettings};
use crate::cores::{OperatorInputs, build_cores};
use crate::error::{Error, Result};
use crate::formfactor::FormFactors;
use crate::geometry::{Polygon, Region};
use crate::memory;
use crate::mesh::{Element, MAX_ELEMENTS, smooth, split_group, subdivide};
use crate::patches::Mesh;
use crate::progress::Progress;
use crate::scene::Scene;
use crate::visibility::Occluder;

/// Jumps below this relative size do not refine (a uniformly lit wall stays as it is).
pub const MIN_JUMP: f64 = 0.1;
/// `B_floor` as a share of the mean radiosity: below it differences count as noise.
pub const FLOOR: f64 = 0.05;

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
    // What is drawn: the elements, or the faces an element of a dense mesh groups (its
    // proxy shares no corner with its neighbours), each with the element it shows.
    let grouped = elements.iter().any(|e| !e.parts.is_empty());
    let (faces, of, _) = if grouped {
        crate::mesh::shown_faces(elements.iter().copied())
    } else {
        (Vec::new(), (0..elements.len() as u32).collect(), false)
    };
    let shown: Vec<&Element> = if grouped {
        faces.iter().collect()
    } else {
        elements.clone()
    };
    let s = smooth::weights(scene, &shown, mesh.contacts.as_deref());
    let area: Vec<f64> = elements.iter().map(|e| e.polygon.area()).collect();
    let total: f64 = area.iter().sum();
    let mean = values.iter().zip(&area).map(|(v, a)| v * a).sum::<f64>() / total.max(1e-300);
    let floor = FLOOR * mean.max(0.0) + f64::MIN_POSITIVE;
    // The elements with a corner of a face they show at each vertex. Not the vertex's
    // weights: a boundary vertex extrapolates from a ring two elements wide, which marked
    // elements far from the jump (tried: splits in a penumbra's umbra along the floor's
    // edges).
    let mut at: Vec<Vec<usize>> = vec![Vec::new(); s.offsets.len() - 1];
    for (f, face) in shown.iter().enumerate() {
        let e = of[f] as usize;
        for &v in &s.corners[4 * f..4 * f + face.polygon.count] {
            if v != lrr_formats::Smooth::NONE && at[v as usize].last() != Some(&e) {
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
        let Some(kids) = children(mesh, &mesh.elements[id]) else {
            continue; // a sliver whose halves have no area, or a group not in its patch
        };
        let extra = kids - 1;
        if added + extra > allowed {
            continue; // a 1×2 split may still fit
        }
        added += extra;
        marked[id] = true;
    }
    marked
}

/// Children of one split of `e` ([`split`]), `None` when it cannot be split: a sliver, or a
/// group whose proxy is not one of its patch's parts (see [`split_marked`]).
fn children(mesh: &Mesh, e: &Element) -> Option<usize> {
    if !e.parts.is_empty() && !e.on_parts && !proxy_in_patch(mesh, e) {
        return None;
    }
    split(e).map(|kids| kids.len())
}

/// Whether grouped element `e`'s proxy is one of the parts of its patch's shape (a cluster's
/// or a merged patch's shape is the union of its elements' polygons).
fn proxy_in_patch(mesh: &Mesh, e: &Element) -> bool {
    (mesh.patches.get(e.patch as usize)).is_some_and(|p| p.shape.parts().contains(&e.polygon))
}

/// One split of `e`: its polygon's in the subdivision hierarchy (`subdivide::split`), or, for
/// an element grouping small faces, its parts shared among up to four groups
/// (`mesh::split_group`). `None` when it cannot be split.
fn split(e: &Element) -> Option<Vec<Element>> {
    if e.parts.is_empty() {
        let kids = subdivide::try_split(&e.polygon)?;
        Some(
            kids.into_iter()
                .map(|polygon| Element {
                    polygon,
                    ..e.clone()
                })
                .collect(),
        )
    } else {
        split_group(e)
    }
}

/// The mesh with the `marked` elements (by id) split once: a split element's first child
/// keeps its id, the others are appended in id order; patches are unchanged. Also the id of
/// every element's parent in `mesh` (its own id when kept).
pub(crate) fn split_marked(mesh: &Mesh, marked: &[bool]) -> (Mesh, Vec<u32>) {
    let mut elements = mesh.elements.clone();
    let mut parents: Vec<u32> = (0..mesh.n() as u32).collect();
    let mut siblings = vec![1u8; mesh.n()];
    // Per patch, the proxies of its split groups lit on them, with what their children are
    // lit on.
    let mut reshaped: BTreeMap<u32, Vec<(Polygon, Vec<Polygon>)>> = BTreeMap::new();
    for (id, _) in marked.iter().enumerate().filter(|(_, m)| **m) {
        let parent = &mesh.elements[id];
        let kids = split(parent).expect("select checked the split");
        if !parent.parts.is_empty() && !parent.on_parts {
            let lit = kids.iter().flat_map(|k| k.lit().copied()).collect();
            reshaped
                .entry(parent.patch)
                .or_default()
                .push((parent.polygon, lit));
        }
        let count = u8::try_from(kids.len()).unwrap_or(u8::MAX);
        let mut kids = kids.into_iter();
        elements[id] = kids.next().expect("a split has children");
        siblings[id] = count;
        for kid in kids {
            elements.push(kid);
            parents.push(id as u32);
            siblings.push(count);
        }
    }
    // A split group's proxy is a part of its patch's shape (`proxy_in_patch`): what its
    // children are lit on takes its place, so that the patch is still the union of what its
    // elements are lit on (of the same area). A group lit on its parts has them in the shape
    // already, as its children do.
    let mut patches = mesh.patches.clone();
    for (p, groups) in reshaped {
        let patch = &mut patches[p as usize];
        let mut parts = Vec::with_capacity(patch.shape.parts().len() + 3 * groups.len());
        // Each split group's proxy replaced once: two groups of one patch with the same
        // proxy (bit for bit) take one part each.
        let mut done = vec![false; groups.len()];
        for q in patch.shape.parts() {
            let found =
                (groups.iter().zip(&mut done)).find(|((proxy, _), done)| !**done && proxy == q);
            match found {
                Some(((_, lit), done)) => {
                    *done = true;
                    parts.extend_from_slice(lit);
                }
                None => parts.push(*q),
            }
        }
        patch.shape = Region::new(parts);
    }
    let refined = Mesh {
        meshing: mesh.meshing.clone(),
        siblings,
        contacts: mesh.contacts.clone(),
        ..Mesh::from_parts(elements, patches)
    };
    (refined, parents)
}

/// `lrr bake`'s default budget: at most `0.2 · n0` new elements (issue #14: with 2MSC at its
/// default threshold it meets the Cornell box's accuracy goal within 2× the former default
/// bake's time; docs/ACCURACY.md).
pub const DEFAULT_BUDGET: f64 = 0.2;

/// Samples per element-patch pair of the first pass, a point pair each, without the adaptive
/// rays of partly visible pairs: the first pass only ranks elements by how their radiosity
/// jumps. Measured on the Cornell box (docs/ACCURACY.md, "Refinement where light changes"):
/// 1 sample ranks worse (p90 5.0%), 2 as well as the bake's 16 (p90 4.5% against 4.7%) at an
/// eighth of the kernel evaluations and a sixteenth or less of the rays.
pub const FIRST_PASS_SAMPLES: u32 = 2;

/// Revision of the refinement rules, part of the checkpoint key (`checkpoint::key`) and of a
/// sharded bake's settings: 4 also splits the elements that group small faces, ranked by the
/// jumps at the corners of the faces drawn (3: the first pass at [`FIRST_PASS_SAMPLES`]
/// inside the mesh stage with enclosed rows summing to one, children sampled at their share
/// of the samples; 2: without either; 1 reused the full first pass's rows, unsharded only).
pub const REVISION: u32 = 4;

/// What the first pass integrates with.
pub(crate) struct FirstPass<'a> {
    /// `None` when nothing can occlude.
    pub occluder: Option<&'a dyn Occluder>,
    /// Per element id of the unrefined mesh: whether its row sums to one (the bake's
    /// enclosure test, `formfactor::enclosure`).
    pub closed: Option<&'a [bool]>,
    /// The bake's samples per pair: the first pass takes at most these.
    pub samples: u32,
    /// A whole bake's storage: its file's writing is checked with the first pass's own
    /// memory (`storage::check_memory_unrefined`). None for a shard or a plan, which write no
    /// operator file.
    pub storage: Option<crate::storage::Storage>,
}

impl FirstPass<'_> {
    /// Samples per pair of the first pass: [`FIRST_PASS_SAMPLES`], or the bake's when fewer.
    pub(crate) fn first_pass_samples(&self) -> u32 {
        FIRST_PASS_SAMPLES.min(self.samples)
    }
}

/// The mesh refined where light changes, with a budget of `budget · n0` new elements: a
/// first pass of [`FIRST_PASS_SAMPLES`] per pair (one ray each; the bake's `samples` when
/// fewer) over the mesh's own patches, solved through
/// the low-rank operator ([`first_pass`]), ranks the elements ([`indicator`], [`select`]).
/// Deterministic and cheap enough that every shard of a sharded bake (or `lrr plan`, once)
/// makes the same mesh; the bake then integrates every row of the refined mesh. A budget of
/// 0 returns the mesh unchanged. `meshing.refined` counts the elements split.
///
/// With `checkpoint` (its settings and [`checkpoint::first_pass_key`]) the first pass's rows
/// are saved block by block as a bake's are, and taken from there when resuming; the open
/// checkpoint is returned for the caller to remove once the bake's output is written.
pub(crate) fn refine_mesh(
    scene: &Scene,
    mesh: Mesh,
    first: &FirstPass,
    budget: f64,
    progress: &Progress,
    max_memory: Option<u64>,
    checkpoint: Option<(&CheckpointSettings, u64)>,
) -> Result<(Mesh, Option<Checkpoint>)> {
    check_budget(budget)?;
    if budget == 0.0 {
        return Ok((mesh, None));
    }
    let (n0, k) = (mesh.n(), mesh.k());
    memory::check_with(
        (n0 as u128) * (k as u128) * 8,
        max_memory,
        &format!("the first pass of --refine (n = {n0} elements × k = {k} patches)"),
        &format!("use --refine 0, or: {}", memory::size_advice()),
    )?;
    // Its cores, the bake's own after it (the same k): refused before the hours of work.
    let channels = if scene.is_grey() { 1 } else { 3 };
    let cores = crate::cores::check_memory(k, channels, n0, max_memory)?;
    // And the file's writing, which the refined mesh can only make larger.
    if let Some(storage) = first.storage {
        crate::storage::check_memory_unrefined((n0, k, channels), storage, max_memory)?;
    }
    let mut ff =
        FormFactors::new(first.first_pass_samples(), first.occluder).with_enclosure(first.closed);
    ff.adaptive = 1;
    ff.elements = Some(&mesh.elements);
    let run = |resume: bool| {
        let settings = checkpoint.map(|(c, key)| {
            let c = CheckpointSettings {
                resume,
                ..c.clone()
            };
            (c, key)
        });
        checkpoint::element_patch_matrix(
            &mesh,
            &ff,
            progress,
            max_memory,
            settings.as_ref().map(|(c, key)| (c, *key)),
            0..n0,
            "first pass",
        )
    };
    // A first-pass checkpoint of other settings (a bake resumed after the scene was edited,
    // a shard run again with other flags) is stale, not an error: started over, with a note.
    let (fk, saved) = match checkpoint {
        Some((c, _)) if c.resume => checkpoint::resume_or_replace(&c.path, "the first pass", run)?,
        _ => run(false)?,
    };
    // The solve's cores come on top of the rows, which it reads.
    progress.estimate("first pass solve", cores);
    let stage = progress.stage("first pass solve", 0);
    let (reflectance, mut emission) = mesh.file_order_materials(scene);
    // The lights that are not surfaces light the first pass as the runtime will: their
    // reflected direct light at each element's centroid (an element lit on its parts: its
    // largest part's, `Element::on_surface`) is emission.
    let owned = crate::lights::LightsOwned::of(scene);
    if !owned.is_empty() {
        let lights = crate::lights::SceneLights::new(&owned, first.occluder);
        let direct: Vec<[f64; 3]> = (0..mesh.n())
            .into_par_iter()
            .map(|s| {
                let p = mesh.element_at(s).on_surface();
                lights.irradiance(p.centroid(), p.normal)
            })
            .collect();
        for ((e, r), h) in emission.iter_mut().zip(&reflectance).zip(direct) {
            for c in 0..3 {
                e[c] += r[c] * h[c];
            }
        }
    }
    let values = first_pass(&mesh, &fk, &reflectance, &emission, channels)?;
    drop(fk);
    stage.finish();
    // The smooth weights of the whole mesh, the indicator and the split: minutes on a mesh of
    // 10⁵ elements, so a stage of its own that says it still runs.
    let bytes = refine_bytes(&mesh, budget);
    memory::check_with(
        bytes,
        max_memory,
        &format!(
            "refining the mesh where light changes ({} elements)",
            mesh.n()
        ),
        "use a smaller --refine (0 refines nothing) or a larger --element-size, or raise \
         --max-memory",
    )?;
    progress.estimate("refine", bytes);
    let stage = progress.stage("refine", 0);
    let (mut refined, split) = refine_by(scene, &mesh, &values, budget)?;
    stage.finish();
    refined.meshing.refined = split;
    Ok((refined, saved))
}

/// Bytes [`indicator`] holds per face drawn (an element, or each face an element of a dense
/// mesh groups) besides the smooth weights and the faces' copies: the element or face
/// references, areas and indicator values (24), and the elements at each smooth vertex (a
/// list of 24 bytes at each of up to four vertices a face and 8 bytes a member, twice
/// over for the lists' growth: 160).
const INDICATOR_BYTES_PER_ELEMENT: u128 = 184;

/// Bytes the refine stage ([`refine_by`]) may hold at once beside `mesh`, planned before it
/// starts: the larger of the indicator's (smooth weights over the faces drawn,
/// `smooth::build_bytes`, [`INDICATOR_BYTES_PER_ELEMENT`] and, where elements group faces,
/// a copy of each face) and the split's (the refined
/// mesh, a copy of this one with up to `budget · n` more elements, and the ranking, marks and
/// parents: 17 bytes an element).
pub(crate) fn refine_bytes(mesh: &Mesh, budget: f64) -> u128 {
    let shown: usize = (mesh.elements.iter()).map(|e| e.parts.len().max(1)).sum();
    let faces = if shown > mesh.n() {
        // The faces drawn, each a copy (an element without parts), and whom each shows.
        shown as u128 * (size_of::<Element>() + size_of::<u32>() + size_of::<usize>()) as u128
    } else {
        0
    };
    let indicator =
        smooth::build_bytes(shown) + INDICATOR_BYTES_PER_ELEMENT * shown as u128 + faces;
    indicator.max(split_bytes(mesh, budget))
}

/// The split's share of [`refine_bytes`].
fn split_bytes(mesh: &Mesh, budget: f64) -> u128 {
    let added = (budget.max(0.0) * mesh.n() as f64).floor() as u128;
    // Per element added: the element, its parent and split count, its weight and mark; and,
    // where a group is split, a polygon and a cumulative area more in its patch's shape,
    // held twice while the shape is redrawn.
    let reshaped = 2 * (size_of::<Polygon>() + size_of::<f64>());
    let per_added =
        (size_of::<Element>() + size_of::<u32>() * 2 + size_of::<f64>() + 1 + reshaped) as u128;
    mesh.heap_bytes() + added * per_added + 17 * mesh.n() as u128
}

/// The mesh with the elements that the first pass's radiosity `values` (per file position)
/// ranks highest split once, within `budget · n0` new elements; and the elements split.
pub(crate) fn refine_by(
    scene: &Scene,
    mesh: &Mesh,
    values: &[f64],
    budget: f64,
) -> Result<(Mesh, usize)> {
    let ind = indicator(scene, mesh, values);
    let marked = select(mesh, &ind, budget);
    let (refined, _) = split_marked(mesh, &marked);
    if refined.n() > MAX_ELEMENTS {
        return Err(Error::Limits(format!(
            "--refine {budget} would make {} elements, more than the limit of {MAX_ELEMENTS}; \
             use a smaller --refine or a larger --element-size",
            refined.n()
        )));
    }
    Ok((refined, marked.iter().filter(|&&m| m).count()))
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
    use glam::DVec3;
    use std::path::Path;

    /// A step of the radiosity across the middle of a box splits the elements at the step
    /// only, within the budget, inside their patches.
    #[test]
    fn a_step_splits_the_elements_beside_it() {
        let scene = procedural::furnace(0.5, 1.0)
            .build("f", Path::new("."))
            .unwrap();
        let sizes = MeshSizes {
            element_size: 0.25,
            patch_size: 0.5,
        };
        let mesh = Mesh::two_fixed(&scene, sizes).unwrap();
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
        let refined = refined_within(&scene, &mesh, &values, budget);
        for e in &refined.elements[mesh.n()..] {
            let x = e.polygon.centroid().x;
            assert!(
                (x - mid).abs() <= sizes.element_size,
                "a child at x = {x}, step at {mid}"
            );
        }
    }
    /// `mesh` refined by `values` within `budget`: something split, no more added than the
    /// budget allows, the patches kept, every check of a plan's mesh passed.
    fn refined_within(scene: &Scene, mesh: &Mesh, values: &[f64], budget: f64) -> Mesh {
        let (refined, split) = refine_by(scene, mesh, values, budget).unwrap();
        assert!(split > 0);
        assert!(refined.n() - mesh.n() <= (budget * mesh.n() as f64) as usize);
        assert_eq!(refined.k(), mesh.k());
        refined.validate().unwrap();
        refined
    }

    /// The dense sphere's scene (1 280 sphere faces, grouped) at its own sizes, meshed by 2MF.
    fn dense_sphere_mesh() -> (Scene, MeshSizes, Mesh) {
        let scene = procedural::dense_sphere(3)
            .build("s", Path::new("."))
            .unwrap();
        let sizes = MeshSizes::resolve(&scene, None, None).unwrap();
        let mesh = Mesh::two_fixed(&scene, sizes).unwrap();
        (scene, sizes, mesh)
    }

    /// Elements that group small faces (the tessellated sphere's) are split too where the
    /// light steps: only those beside the step, their parts shared among their children, so
    /// every face is drawn once as before, by the element that now holds it.
    #[test]
    fn a_step_across_grouped_faces_splits_the_groups_beside_it() {
        let (scene, sizes, mesh) = dense_sphere_mesh();
        let sphere = scene.surfaces.iter().position(|s| s == "sphere").unwrap() as u32;
        let on_sphere = |e: &Element| e.surface == sphere;
        assert!((mesh.elements.iter()).all(|e| !on_sphere(e) || !e.parts.is_empty()));
        let centre = {
            let faces = scene.faces.iter().filter(|f| f.surface == sphere as usize);
            let (sum, count) = faces.fold((glam::DVec3::ZERO, 0.0), |(s, c), f| {
                (s + f.polygon.centroid(), c + 1.0)
            });
            sum / count
        };
        // Bright on the sphere's +x half, dark on its -x half, the room uniform.
        let values: Vec<f64> = (0..mesh.n())
            .map(|s| {
                let e = mesh.element_at(s);
                match (on_sphere(e), e.polygon.centroid().x > centre.x) {
                    (false, _) => 0.5,
                    (true, true) => 1.0,
                    (true, false) => 0.1,
                }
            })
            .collect();
        let budget = 1.0;
        let refined = refined_within(&scene, &mesh, &values, budget);
        // A split group has a face at a jump, and a group's vertex box has sides of at most
        // 2h: its faces lie within 2h of the vertex, which lies within 2h of the step (in the
        // box of the group across it, whose centroid is on the other side).
        let h = sizes.element_size;
        for e in &refined.elements[mesh.n()..] {
            assert!(on_sphere(e));
            for (_, p) in e.shown() {
                let x = p.centroid().x;
                assert!((x - centre.x).abs() <= 4.0 * h, "a child's face at x = {x}");
            }
        }
        let shown = |m: &Mesh| {
            let mut faces: Vec<(u32, [u64; 3])> = (m.elements.iter())
                .flat_map(|e| e.shown().map(|(f, p)| (f, p.centroid().to_array())))
                .map(|(f, c)| (f, c.map(f64::to_bits)))
                .collect();
            faces.sort_unstable();
            faces
        };
        assert_eq!(shown(&refined), shown(&mesh), "the faces drawn changed");
    }

    /// The refine stage's plan for its split covers the mesh it makes: a dense sphere's
    /// grouped elements (their parts copied) beside its room's walls, split as far as the
    /// budget lets.
    #[test]
    fn the_plan_covers_the_refined_mesh() {
        let (scene, _, mesh) = dense_sphere_mesh();
        assert!(mesh.elements.iter().any(|e| !e.parts.is_empty()));
        // Every other element lit: every element has a jump at a corner.
        let values: Vec<f64> = (0..mesh.n()).map(|s| (s % 2) as f64).collect();
        for budget in [0.2, 1.0, 3.0] {
            let (refined, split) = refine_by(&scene, &mesh, &values, budget).unwrap();
            assert!(split > 0);
            let (made, planned) = (refined.heap_bytes(), split_bytes(&mesh, budget));
            println!("budget {budget}: {split} split, {made} bytes made, {planned} planned");
            assert!(made <= planned, "budget {budget}: {made} > {planned}");
        }
    }

    /// The refined mesh is the same whatever the thread count, and a budget of 0 is the mesh.
    /// Groups lit on their parts (box tops of several heights) and groups of a proxy, in
    /// 2MSC's merged patches, split into a mesh that passes every check a plan file's mesh
    /// must (`Mesh::validate`: each element inside its patch, areas and weights).
    #[test]
    fn groups_split_in_merged_patches_stay_inside_them() {
        // 64 boxes of several heights on a floor (their tops grouped across boxes, lit on
        // their parts) and a tessellated sphere (groups of a proxy), one surface.
        let floor = [(-0.5, -0.5), (6.5, -0.5), (6.5, 6.5), (-0.5, 6.5)]
            .map(|(x, y)| DVec3::new(x, y, 0.0));
        let mut triangles = vec![
            [floor[0], floor[1], floor[2]],
            [floor[0], floor[2], floor[3]],
        ];
        for b in 0..64 {
            let lo = DVec3::new((b % 8) as f64 * 0.8, (b / 8) as f64 * 0.8, 0.0);
            let hi = lo + DVec3::new(0.3, 0.3, 0.2 + 0.05 * (b % 5) as f64);
            triangles.extend(crate::mesh::tests::cuboid(lo, hi));
        }
        for t in procedural::icosphere(4, [3.0, 3.0, 3.0], 1.0) {
            triangles.push([0, 1, 2].map(|i| DVec3::from_array(t[i])));
        }
        let scene = crate::mesh::tests::one_surface("boxes and a sphere", &triangles);
        let sizes = MeshSizes {
            element_size: 1.0,
            patch_size: 2.0,
        };
        let rule = crate::patches::refinement(
            sizes,
            crate::patches::coherence::merge::DEFAULT_THRESHOLD,
            None,
            crate::patches::CoherenceRule::Merge,
        )
        .unwrap();
        let mesh = Mesh::two_msc(&scene, sizes, rule, None, None).unwrap();
        // Per kind of group (lit on its parts or not), its faces, and how many elements of
        // a mesh show them.
        let faces = |lit: bool| -> std::collections::BTreeSet<u32> {
            (mesh.elements.iter())
                .filter(|e| e.parts.len() >= 2 && e.on_parts == lit)
                .flat_map(|e| e.parts.iter().map(|(f, _)| *f))
                .collect()
        };
        let showing = |m: &Mesh, lit: bool| {
            let faces = faces(lit);
            (m.elements.iter())
                .filter(|e| e.shown().any(|(f, _)| faces.contains(&f)))
                .count()
        };
        assert!(showing(&mesh, true) > 0 && showing(&mesh, false) > 0);
        // Every group split (the box tops' groups have no neighbour on their smooth surface,
        // so no indicator would mark them).
        let marked: Vec<bool> = (mesh.elements.iter())
            .map(|e| e.parts.len() >= 2 && children(&mesh, e).is_some())
            .collect();
        let (refined, _) = split_marked(&mesh, &marked);
        assert_eq!(refined.k(), mesh.k());
        refined.validate().unwrap();
        for lit in [true, false] {
            assert!(
                showing(&refined, lit) > showing(&mesh, lit),
                "no group lit on its parts = {lit} was split"
            );
        }
    }

    #[test]
    fn refinement_is_deterministic() {
        let scene = procedural::dense_sphere(1)
            .build("s", Path::new("."))
            .unwrap();
        let sizes = MeshSizes::resolve(&scene, None, None).unwrap();
        let occ = crate::visibility::obvhs::ObvhsOccluder::build(&scene);
        let run = |threads: usize, budget: f64| {
            crate::pool::with_threads(Some(threads), || {
                let mesh = Mesh::two_fixed(&scene, sizes).unwrap();
                let first = FirstPass {
                    occluder: Some(&occ),
                    closed: None,
                    samples: 16,
                    storage: None,
                };
                refine_mesh(
                    &scene,
                    mesh,
                    &first,
                    budget,
                    &Progress::hidden(),
                    None,
                    None,
                )
                .unwrap()
                .0
            })
            .unwrap()
        };
        let (one, two) = (run(1, 0.3), run(2, 0.3));
        assert!(
            one.meshing.refined > 0,
            "the sphere's shadow splits elements"
        );
        assert_eq!(one.order, two.order);
        assert_eq!(one.meshing.refined, two.meshing.refined);
        let polygons =
            |m: &Mesh| -> Vec<Polygon> { m.elements.iter().map(|e| e.polygon).collect() };
        assert!(polygons(&one) == polygons(&two));
        let unrefined = Mesh::two_fixed(&scene, sizes).unwrap();
        assert_eq!(run(1, 0.0).order, unrefined.order);
    }

    #[test]
    fn bad_budgets_are_errors() {
        for b in [-0.5, f64::NAN, f64::INFINITY] {
            let e = check_budget(b).unwrap_err().to_string();
            assert!(e.contains("--refine must be"), "{e}");
        }
    }
}
