//! The coarse mesh (DESIGN.md §3): patches cut from the fine mesh's subdivision hierarchy, and
//! [`Mesh`], the two meshes together in the operator's file order.
//!
//! *2MF* (two fixed meshes) cuts the hierarchy uniformly where a node's size first drops to the
//! patch size: a patch is then a convex polygon that contains its elements exactly (inclusion),
//! and the elements of one patch have equal areas when their face was a parallelogram. *2MSC*
//! ([`coherence`]) cuts the same hierarchy adaptively, probing how the scene looks from inside
//! each candidate patch (point-to-patch form factors with visibility, and a coarse solve).
//! Surfaces made of many faces smaller than the patch size get patches by clustering
//! (`cluster`): a patch is then a union of faces, a [`Region`] of several parts.
//!
//! The operator works in *file order*, elements sorted by patch, described by `order` (file
//! position → original element id) and the index vector `index` (k+1 offsets into file
//! positions), with weights `w = A_e / A_p`.

pub mod coherence;
mod patch;

pub use patch::{CoherenceRule, Patch, PatchMethod};

use crate::error::{Error, Result};
use crate::geometry::cluster;
use crate::geometry::{Polygon, Region};
use crate::mesh::subdivide;
use crate::mesh::{ContactIndex, Element, MeshReport, MeshSizes, fine_mesh_within};
use crate::scene::Scene;
use crate::visibility::Occluder;
use rustc_hash::FxHashMap;
use std::sync::Arc;

/// The fine mesh (elements) and the coarse mesh (patches) of a bake, with the file order.
#[derive(Debug, Clone)]
pub struct Mesh {
    /// Elements by original id.
    pub elements: Vec<Element>,
    /// Patches by index; `k = patches.len()`.
    pub patches: Vec<Patch>,
    /// File position → original element id (elements sorted by patch).
    pub order: Vec<u32>,
    /// k+1 offsets: patch p holds file positions `index[p]..index[p+1]`.
    pub index: Vec<u32>,
    /// Per file position: `w = A_e / A_p`.
    pub(crate) weights: Vec<f64>,
    /// What building the fine mesh found (regions, imprints, angles, stage times).
    pub meshing: MeshReport,
    /// Per element id: into how many pieces its parent was split by the refinement where
    /// light changes (`crate::refine`): its row takes that share of the samples per pair, so
    /// the samples per unit area stay the unrefined mesh's. Empty: nothing split (1 each).
    pub(crate) siblings: Vec<u8>,
    /// The scene's faces indexed for contact searches, with the contacts meshing found
    /// (`mesh::ContactIndex`), for the smooth weights; `None` for a mesh read from a plan
    /// (the weights then index the faces themselves).
    pub(crate) contacts: Option<Arc<ContactIndex>>,
}

/// Checks the 2MSC parameters and fills in the default `A_min` of the split rule: `(2h)²`
/// (about 2×2 elements) at thresholds of 1e-4 and above, shrinking in proportion below,
/// `(2h)² · threshold / FULL_MIN_AREA_THRESHOLD`, so that a smaller threshold keeps splitting down
/// to single elements (and `k → n`, the exact solve) instead of stopping at the cap. The merge
/// rule has no `A_min` (0 is recorded) and refuses one.
pub(crate) fn refinement(
    sizes: MeshSizes,
    threshold: f64,
    min_patch_area: Option<f64>,
    rule: CoherenceRule,
) -> Result<coherence::Refinement> {
    if !(threshold.is_finite() && threshold > 0.0) {
        let what = match rule {
            CoherenceRule::Merge => "the estimated relative error of the patches, e.g. 7e-5",
            CoherenceRule::Split => {
                "the largest share of reflected power a patch may get wrong, e.g. 3e-5"
            }
        };
        return Err(Error::Settings(format!(
            "--threshold must be a positive number ({what}), got {threshold}"
        )));
    }
    if rule == CoherenceRule::Merge {
        if let Some(a) = min_patch_area {
            return Err(Error::Settings(format!(
                "--min-patch-area {a} applies to --method 2msc-split only: 2msc merges \
                 elements while the estimated error stays under --threshold (drop the flag, \
                 or raise --threshold for larger patches)"
            )));
        }
        return Ok(coherence::Refinement {
            threshold,
            min_patch_area: 0.0,
            rule,
        });
    }
    let scale = (threshold / coherence::FULL_MIN_AREA_THRESHOLD).min(1.0);
    let min_patch_area =
        min_patch_area.unwrap_or(4.0 * sizes.element_size * sizes.element_size * scale);
    if !(min_patch_area.is_finite() && min_patch_area >= 0.0) {
        return Err(Error::Settings(format!(
            "--min-patch-area must be an area of zero or more (scene units²), got {min_patch_area}"
        )));
    }
    Ok(coherence::Refinement {
        threshold,
        min_patch_area,
        rule,
    })
}

/// What 2MSC measures against: the probes (the 2MF patches at the patch size, with their
/// coarse solve) and each piece's material (means over the channels); also the probes'
/// planned bytes ([`probe_bytes`]). `(held, max_memory)`: the probes are refused when they
/// need more than `max_memory` (`None`: 80% of what is available) beside the `held` bytes
/// meshing planned.
pub(crate) fn msc_inputs<'a>(
    scene: &Scene,
    sizes: MeshSizes,
    pieces: &[subdivide::Piece],
    elements: &[Element],
    occluder: Option<&'a dyn Occluder>,
    (held, max_memory): (u128, Option<u64>),
) -> Result<(coherence::Probes<'a>, Vec<coherence::Material>, u128)> {
    // Probes at half the patch size were tried: 4× the probing cost for the same k at
    // equal error on the Cornell box.
    let mut probed = elements.to_vec();
    let probe_patches = two_fixed_patches(pieces, sizes, &mut probed);
    let probe_patches = lit_on_parts(&probed, probe_patches);
    let budget = probe_budget(elements.len());
    let q = probe_patches.len().min(budget);
    // The probes are the 2MF patches at the patch size: a larger patch size makes fewer,
    // down to one per surface, and a larger element size fewer elements to view them. When
    // they are grouped down to the budget, `n · q` stays near MAX_PROBE_PAIRS whatever the
    // sizes, until the patches are fewer than the budget. (--method 2mf needs no probes but
    // takes those patches as its k, whose cores are larger still.) On a refusal, the advice
    // names the factor that brings the patch count to the most probes that fit beside these
    // elements (24 q² + 8 n q ≤ the limit; the count goes as the inverse square of the size).
    let n = elements.len();
    let planned = probe_bytes(q, n);
    crate::memory::check_then(
        held + planned,
        max_memory,
        || format!("2MSC's probing (q = {q} probes, n = {n} elements) beside meshing"),
        |usable| {
            let (nf, usable) = (n as f64, usable.saturating_sub(held) as f64);
            let fit = ((64.0 * nf * nf + 96.0 * usable).sqrt() - 8.0 * nf) / 48.0;
            if fit < 1.0 {
                return format!("{}, or raise --max-memory", crate::memory::size_advice());
            }
            let larger = format!(
                "a --patch-size about {:.2} times larger (fewer probes)",
                (probe_patches.len() as f64 / fit.floor()).sqrt().max(1.0) * 1.05
            );
            // Where the elements' views outweigh the probes' solve, fewer elements help
            // most (and the matrices after the probes need them fewer too).
            if 8 * n > 24 * q {
                format!(
                    "use a larger --element-size (fewer elements) or {larger}, or raise \
                     --max-memory"
                )
            } else {
                format!("use {larger}, or raise --max-memory")
            }
        },
    )?;
    let (targets, reflectance, emission) = if probe_patches.len() > budget {
        grouped_probes(scene, probe_patches, &mut probed, budget)
    } else {
        let mut out = (Vec::new(), Vec::new(), Vec::new());
        for p in probe_patches {
            let m = material(scene, p.face);
            out.0.push(p.shape);
            out.1.push(m.reflectance);
            out.2.push(m.emission);
        }
        out
    };
    let (origin, _) = scene.bounds();
    let frame = coherence::SeedFrame {
        origin,
        extent: scene.extent(),
    };
    let lights = crate::lights::LightsOwned::of(scene);
    let mut probes =
        coherence::Probes::new(targets, reflectance, emission, occluder, frame, lights)?;
    for e in &probed {
        probes.elements[e.patch as usize] += 1.0;
    }
    let materials = pieces.iter().map(|p| material(scene, p.face)).collect();
    Ok((probes, materials, planned))
}

/// Bytes 2MSC's probes need with `q` probes over `n` elements: the coarse system's factors,
/// its matrix and that matrix's LU factors (three `q²` f64), and every element's view of the
/// probes that the merge rule keeps (`n · q` f32, and as much again for the groups' sums).
/// At most about 0.8 GB: [`MAX_PROBES`] and [`MAX_PROBE_PAIRS`] bound both terms.
pub(crate) fn probe_bytes(q: usize, n: usize) -> u128 {
    let (q, n) = (q as u128, n as u128);
    3 * q * q * 8 + n * q * 8
}

/// Most probes 2MSC measures against: their coarse solve holds `q²` factors (128 MiB here).
pub(crate) const MAX_PROBES: usize = 4096;
/// Most element-to-probe pairs (`n · q`) 2MSC evaluates: `PROBE_RAYS` rays each, and 8 bytes of
/// the merge rule's working memory each (400 MB here).
pub(crate) const MAX_PROBE_PAIRS: usize = 50_000_000;
/// Fewest probes, whatever the element count.
const MIN_PROBES: usize = 64;

/// How many probes a mesh of `n` elements may have: the 2MF patches at the patch size unless
/// they are more than this (a game level of 60 k faces gives as many probes), then grouped
/// down to it (`grouped_probes`). The scenes of the tests and docs stay under it (the Cornell
/// box has 128 probes, the building about 1 400).
pub(crate) fn probe_budget(n: usize) -> usize {
    (MAX_PROBE_PAIRS / n.max(1)).clamp(MIN_PROBES, MAX_PROBES)
}

/// The 2MF patches grouped into `budget` probes by position and normal (`cluster::to_budget`;
/// emitting and non-emitting patches never share a probe); a probe's reflectance and emission
/// are its patches' area-weighted means, and `probed[..].patch` is renumbered to the probes.
fn grouped_probes(
    scene: &Scene,
    patches: Vec<Patch>,
    probed: &mut [Element],
    budget: usize,
) -> (Vec<Region>, Vec<f64>, Vec<f64>) {
    let units: Vec<cluster::Unit> = patches
        .iter()
        .map(|p| cluster::Unit::of_region(&p.shape))
        .collect();
    let materials: Vec<coherence::Material> =
        patches.iter().map(|p| material(scene, p.face)).collect();
    let (lit, unlit): (Vec<usize>, Vec<usize>) =
        (0..patches.len()).partition(|&i| materials[i].emission > 0.0);
    let sets = cluster::to_budget(&units, vec![lit, unlit], budget);
    let mut probe_of = vec![0u32; patches.len()];
    let mut out = (Vec::new(), Vec::new(), Vec::new());
    for (g, set) in sets.iter().enumerate() {
        let mut parts = Vec::new();
        let (mut area, mut rho, mut emission) = (0.0, 0.0, 0.0);
        for &i in set {
            probe_of[i] = g as u32;
            parts.extend_from_slice(patches[i].shape.parts());
            area += units[i].area;
            rho += units[i].area * materials[i].reflectance;
            emission += units[i].area * materials[i].emission;
        }
        out.0.push(Region::new(parts));
        out.1.push(rho / area);
        out.2.push(emission / area);
    }
    for e in probed {
        e.patch = probe_of[e.patch as usize];
    }
    out
}

/// A face's material, as 2MSC sees it: reflectance and emission averaged over the channels.
fn material(scene: &Scene, face: u32) -> coherence::Material {
    let m = &scene.materials[scene.faces[face as usize].material];
    coherence::Material {
        reflectance: m.reflectance.iter().sum::<f64>() / 3.0,
        emission: m.emission.iter().sum::<f64>() / 3.0,
    }
}

/// The 2MF patches: the uniform cut of each large piece, clusters of the small pieces of each
/// surface (a lone small piece is its own patch). Patches are numbered in piece order (a
/// cluster where its first piece comes), depth-first within a piece; sets `elements[..].patch`.
fn two_fixed_patches(
    pieces: &[subdivide::Piece],
    sizes: MeshSizes,
    elements: &mut [Element],
) -> Vec<Patch> {
    let units: Vec<cluster::Unit> = pieces
        .iter()
        .map(|p| cluster::Unit::of(&p.polygon))
        .collect();
    let mut cluster_of = vec![usize::MAX; pieces.len()];
    let mut clusters = Vec::new();
    for set in subdivide::dense_sets(pieces, sizes) {
        for c in cluster::by_size(&units, set, sizes.patch_size) {
            for &p in &c {
                cluster_of[p] = clusters.len();
            }
            clusters.push(c);
        }
    }
    let mut patch_of_cluster: Vec<Option<u32>> = vec![None; clusters.len()];
    let mut patches = Vec::new();
    for (i, piece) in pieces.iter().enumerate() {
        let mut assign = |id: u32, first: u32, count: u32| {
            for e in &mut elements[first as usize..(first + count) as usize] {
                e.patch = id;
            }
        };
        if cluster_of[i] == usize::MAX {
            subdivide::cut(
                piece.polygon,
                piece.first,
                sizes,
                &mut |polygon, first, count| {
                    patches.push(Patch {
                        shape: Region::single(polygon),
                        face: piece.face,
                        surface: piece.surface,
                    });
                    assign(patches.len() as u32 - 1, first, count);
                },
            );
            continue;
        }
        let c = &clusters[cluster_of[i]];
        let id = *patch_of_cluster[cluster_of[i]].get_or_insert_with(|| {
            patches.push(Patch {
                shape: Region::new(c.iter().map(|&p| pieces[p].polygon).collect()),
                face: piece.face,
                surface: piece.surface,
            });
            patches.len() as u32 - 1
        });
        assign(id, piece.first, piece.count);
    }
    patches
}

impl Mesh {
    /// Builds both meshes with the given patch method. 2MSC probes visibility with `occluder`
    /// (`None`: nothing occludes). (Bakes call [`build_within`](Self::build_within).)
    #[cfg(test)]
    pub(crate) fn build(
        scene: &Scene,
        sizes: MeshSizes,
        method: PatchMethod,
        occluder: Option<&dyn Occluder>,
    ) -> Result<Self> {
        Self::build_within(scene, sizes, method, occluder, None)
    }

    /// Builds both meshes with the given patch method, refusing meshing, and then meshing with
    /// 2MSC's probes ([`probe_bytes`]), when they would need more than `max_memory` bytes
    /// (`None`: 80% of what is available).
    pub(crate) fn build_within(
        scene: &Scene,
        sizes: MeshSizes,
        method: PatchMethod,
        occluder: Option<&dyn Occluder>,
        max_memory: Option<u64>,
    ) -> Result<Self> {
        match method {
            PatchMethod::TwoFixed => Self::two_fixed_within(scene, sizes, max_memory),
            PatchMethod::SpatialCoherence {
                threshold,
                min_patch_area,
                rule,
            } => {
                let refinement = refinement(sizes, threshold, min_patch_area, rule)?;
                Self::two_msc(scene, sizes, refinement, occluder, max_memory)
            }
        }
    }

    /// [`two_fixed_within`](Self::two_fixed_within) without a memory limit.
    #[cfg(test)]
    pub(crate) fn two_fixed(scene: &Scene, sizes: MeshSizes) -> Result<Self> {
        Self::two_fixed_within(scene, sizes, None)
    }

    /// Builds both meshes by 2MF: uniform subdivision and a uniform cut; small pieces (dense
    /// meshes) are clustered to the patch size. Meshing is planned against `max_memory`.
    fn two_fixed_within(scene: &Scene, sizes: MeshSizes, max_memory: Option<u64>) -> Result<Self> {
        let (mut elements, pieces, meshing, contacts) = fine_mesh_within(scene, sizes, max_memory)?;
        let patches = two_fixed_patches(&pieces, sizes, &mut elements);
        Ok(Self {
            meshing,
            contacts: Some(Arc::new(contacts)),
            ..Self::from_parts(elements, patches)
        })
    }

    /// Builds both meshes by 2MSC ([`coherence`]): the fine mesh of 2MF, adaptive patches
    /// probed against the 2MF patches at the patch size.
    pub(crate) fn two_msc(
        scene: &Scene,
        sizes: MeshSizes,
        refinement: coherence::Refinement,
        occluder: Option<&dyn Occluder>,
        max_memory: Option<u64>,
    ) -> Result<Self> {
        let (mut elements, pieces, mut meshing, contacts) =
            fine_mesh_within(scene, sizes, max_memory)?;
        let (probes, materials, probes_planned) = msc_inputs(
            scene,
            sizes,
            &pieces,
            &elements,
            occluder,
            (meshing.planned_bytes, max_memory),
        )?;
        meshing.planned_bytes += probes_planned;
        let patches = match refinement.rule {
            CoherenceRule::Split => coherence::two_msc(
                &pieces,
                &materials,
                &mut elements,
                sizes,
                refinement,
                &probes,
            ),
            CoherenceRule::Merge => {
                let materials: Vec<coherence::Material> =
                    elements.iter().map(|e| material(scene, e.face)).collect();
                coherence::merge::merge(&mut elements, &materials, refinement.threshold, &probes)
            }
        };
        Ok(Self {
            meshing,
            contacts: Some(Arc::new(contacts)),
            ..Self::from_parts(elements, patches)
        })
    }

    /// Sorts elements by patch (stable: generation order within a patch) and computes weights.
    /// A patch holding an element lit on its parts ([`Element::on_parts`]) holds those parts
    /// in place of its proxy.
    pub(crate) fn from_parts(elements: Vec<Element>, patches: Vec<Patch>) -> Self {
        let patches = lit_on_parts(&elements, patches);
        let mut order: Vec<u32> = (0..elements.len() as u32).collect();
        order.sort_by_key(|&e| elements[e as usize].patch);
        let mut index = vec![0u32; patches.len() + 1];
        for e in &elements {
            index[e.patch as usize + 1] += 1;
        }
        for p in 0..patches.len() {
            index[p + 1] += index[p];
        }
        let mut patch_area = vec![0.0; patches.len()];
        for e in &elements {
            patch_area[e.patch as usize] += e.polygon.area();
        }
        let weights = order
            .iter()
            .map(|&e| {
                let e = &elements[e as usize];
                e.polygon.area() / patch_area[e.patch as usize]
            })
            .collect();
        Self {
            elements,
            patches,
            order,
            index,
            weights,
            meshing: MeshReport::default(),
            siblings: Vec::new(),
            contacts: None,
        }
    }

    /// Bytes the mesh holds: its elements with their parts, its patches with their regions,
    /// and the per-position tables, for memory plans.
    pub(crate) fn heap_bytes(&self) -> u128 {
        let elements: u128 = (self.elements.iter())
            .map(|e| (e.parts.capacity() * size_of::<(u32, Polygon)>()) as u128)
            .sum();
        let patches: u128 = self.patches.iter().map(|p| p.shape.heap_bytes()).sum();
        let tables = self.order.capacity() * size_of::<u32>()
            + self.index.capacity() * size_of::<u32>()
            + self.weights.capacity() * size_of::<f64>()
            + self.siblings.capacity();
        elements
            + patches
            + (self.elements.capacity() * size_of::<Element>()
                + self.patches.capacity() * size_of::<Patch>()
                + tables) as u128
    }

    /// Number of elements.
    pub fn n(&self) -> usize {
        self.elements.len()
    }

    /// Number of patches.
    pub fn k(&self) -> usize {
        self.patches.len()
    }

    /// The element at a file position.
    pub fn element_at(&self, position: usize) -> &Element {
        &self.elements[self.order[position] as usize]
    }

    /// Invariant checks callable from tests: every element in exactly one patch, weights of a
    /// patch sum to 1, patch areas equal their elements' total.
    pub fn validate(&self) -> std::result::Result<(), String> {
        // Shapes first, so that no check below can index out of bounds (a plan file is read
        // back through this: damaged input must be an error, never a panic).
        let n = self.n();
        if !(self.siblings.is_empty() || self.siblings.len() == n) {
            return Err(format!(
                "{} split counts for {n} elements",
                self.siblings.len()
            ));
        }
        if self.order.len() != n || self.weights.len() != n {
            return Err(format!(
                "{} file positions and {} weights for {n} elements",
                self.order.len(),
                self.weights.len()
            ));
        }
        let mut seen = vec![false; n];
        for &id in &self.order {
            match seen.get_mut(id as usize) {
                Some(s) if !*s => *s = true,
                _ => return Err(format!("order is not a permutation (element {id})")),
            }
        }
        if self.index.len() != self.k() + 1
            || self.index[0] != 0
            || self.index[self.k()] as usize != n
            || self.index.windows(2).any(|w| w[0] > w[1])
        {
            return Err("index vector does not cover all elements".into());
        }
        for p in 0..self.k() {
            let (a, b) = (self.index[p] as usize, self.index[p + 1] as usize);
            if a >= b {
                return Err(format!("patch {p} is empty"));
            }
            let w: f64 = self.weights[a..b].iter().sum();
            if (w - 1.0).abs() > 1e-9 {
                return Err(format!("weights of patch {p} sum to {w}"));
            }
            let area: f64 = (a..b).map(|s| self.element_at(s).polygon.area()).sum();
            let pa = self.patches[p].shape.area();
            if (area - pa).abs() > 1e-9 * pa {
                return Err(format!("patch {p} area {pa} but its elements cover {area}"));
            }
            if (a..b).any(|s| self.element_at(s).patch as usize != p) {
                return Err(format!("patch {p} holds an element of another patch"));
            }
            let surface = self.patches[p].surface;
            if (a..b).any(|s| self.element_at(s).surface != surface) {
                return Err(format!("patch {p} straddles two surfaces"));
            }
            // Each polygon the element is lit on (its parts when it is lit on them) lies in
            // one of the patch's parts.
            let parts = self.patches[p].shape.parts();
            let off_patch = |s: usize| {
                (self.element_at(s).lit()).find(|e| !parts.iter().any(|part| inside(e, part)))
            };
            if let Some((s, e)) = (a..b).find_map(|s| off_patch(s).map(|e| (s, e))) {
                let off = parts
                    .iter()
                    .map(|part| outside_by(e, part) / part.max_edge())
                    .fold(f64::INFINITY, f64::min);
                return Err(format!(
                    "element {} lies outside patch {p} (inclusion): {off:.1e} of its nearest \
                     part's longest edge off it",
                    self.order[s]
                ));
            }
        }
        Ok(())
    }
}

/// True when every vertex of `e` lies in the convex polygon `part` (within a tolerance
/// relative to the part's size).
fn inside(e: &Polygon, part: &Polygon) -> bool {
    // Relative to the part's longest edge, plus the rounding of coordinates of the part's
    // magnitude: imprinted pieces are cut where two faces' planes meet, whose rounding grows as
    // they meet at a grazing angle (the hostile-geometry test found a piece 1.9e-9 of
    // sqrt(area) outside its cluster's part; 1e-9 · sqrt(area) was the bound before).
    let magnitude = part
        .vertices()
        .iter()
        .map(|v| v.abs().max_element())
        .fold(0.0, f64::max);
    outside_by(e, part) <= 1e-8 * part.max_edge() + 1e-13 * magnitude
}

/// How far the vertices of `e` lie outside the convex polygon `part` at most (scene units):
/// off its plane, or beyond one of its edges.
fn outside_by(e: &Polygon, part: &Polygon) -> f64 {
    let v = part.vertices();
    e.vertices()
        .iter()
        .map(|&x| {
            (0..v.len())
                .map(|i| {
                    let (a, b) = (v[i], v[(i + 1) % v.len()]);
                    -(b - a).cross(x - a).dot(part.normal) / (b - a).length()
                })
                .fold(part.height(x).abs(), f64::max)
        })
        .fold(0.0, f64::max)
}

/// `patches` with the proxy of each element lit on its parts ([`Element::on_parts`]) among
/// its patch's parts replaced by those parts, so that the light leaving or reaching the
/// patch there is sampled where the surface is (a proxy about the feet of boxes stands
/// partly under them). A patch that holds no such proxy (already replaced: a refined mesh's
/// patches) is left as it is.
fn lit_on_parts(elements: &[Element], mut patches: Vec<Patch>) -> Vec<Patch> {
    // Per patch, its elements lit on their parts by their proxies' corners (exact bits).
    type Corners = [[u64; 3]; 4];
    let corners = |p: &Polygon| -> Corners { p.vertices.map(|v| v.to_array().map(f64::to_bits)) };
    let mut by_patch: std::collections::BTreeMap<u32, FxHashMap<Corners, &Element>> =
        Default::default();
    for e in elements.iter().filter(|e| e.on_parts) {
        let lit = by_patch.entry(e.patch).or_default();
        lit.insert(corners(&e.polygon), e);
    }
    for (p, lit) in by_patch {
        let Some(patch) = patches.get_mut(p as usize) else {
            continue;
        };
        let mut replaced = false;
        let mut parts = Vec::with_capacity(patch.shape.parts().len());
        for q in patch.shape.parts() {
            match lit.get(&corners(q)).filter(|e| e.polygon == *q) {
                Some(e) => {
                    parts.extend(e.parts.iter().map(|(_, p)| *p));
                    replaced = true;
                }
                None => parts.push(*q),
            }
        }
        if replaced {
            patch.shape = Region::new(parts);
        }
    }
    patches
}

impl Mesh {
    /// Reflectance and emission of each element, in original id order (a textured material's
    /// reflectance averaged over each element: `Scene::reflectance_over`).
    pub(crate) fn element_materials(&self, scene: &Scene) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
        let lut = crate::scene::texture::linear_lut();
        self.elements
            .iter()
            .map(|e| {
                let m = &scene.materials[scene.faces[e.face as usize].material];
                if e.parts.is_empty() {
                    let rho = scene.reflectance_over(e.face as usize, &e.polygon, &lut);
                    return (rho, m.emission);
                }
                // A dense mesh's element: the area-weighted mean of its faces' (one material).
                let mut rho = [0.0; 3];
                let mut area = 0.0;
                for (f, p) in e.shown() {
                    let (a, r) = (p.area(), scene.reflectance_over(f as usize, p, &lut));
                    (0..3).for_each(|c| rho[c] += a * r[c]);
                    area += a;
                }
                (rho.map(|r| r / area), m.emission)
            })
            .unzip()
    }

    /// Reflectance and emission of each element, in file order.
    pub(crate) fn file_order_materials(&self, scene: &Scene) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
        let (rho, emission) = self.element_materials(scene);
        (
            self.order.iter().map(|&e| rho[e as usize]).collect(),
            self.order.iter().map(|&e| emission[e as usize]).collect(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::procedural;
    use std::path::Path;

    #[test]
    fn furnace_mesh_is_consistent() {
        let d = procedural::furnace(0.5, 1.0);
        let scene = d.build("f", Path::new(".")).unwrap();
        let sizes = MeshSizes {
            element_size: 0.125,
            patch_size: 0.25,
        };
        let mesh = Mesh::two_fixed(&scene, sizes).unwrap();
        assert_eq!(mesh.n(), 6 * 64);
        assert_eq!(mesh.k(), 6 * 16);
        mesh.validate().unwrap();
    }

    #[test]
    fn patch_smaller_than_element_makes_k_equal_n() {
        let d = procedural::furnace(0.5, 1.0);
        let scene = d.build("f", Path::new(".")).unwrap();
        let sizes = MeshSizes {
            element_size: 0.25,
            patch_size: 0.1,
        };
        let mesh = Mesh::two_fixed(&scene, sizes).unwrap();
        assert_eq!(mesh.n(), mesh.k());
        mesh.validate().unwrap();
    }

    /// A damaged mesh (as a crafted plan file could hold) fails its checks with a message,
    /// whatever is out of range, instead of indexing out of bounds.
    #[test]
    fn damaged_meshes_are_errors_not_panics() {
        let d = procedural::furnace(0.5, 1.0);
        let scene = d.build("f", Path::new(".")).unwrap();
        let sizes = MeshSizes {
            element_size: 0.25,
            patch_size: 0.5,
        };
        let good = Mesh::two_fixed(&scene, sizes).unwrap();
        let n = good.n() as u32;
        type Damage = Box<dyn Fn(&mut Mesh)>;
        let cases: Vec<(&str, Damage)> = vec![
            ("order out of range", Box::new(move |m| m.order[3] = n + 7)),
            ("order repeats", Box::new(|m| m.order[3] = m.order[4])),
            (
                "short order",
                Box::new(|m| {
                    m.order.pop();
                }),
            ),
            (
                "short weights",
                Box::new(|m| {
                    m.weights.pop();
                }),
            ),
            ("index past n", Box::new(move |m| m.index[1] = n + 100)),
            ("index decreasing", Box::new(|m| m.index.swap(1, 2))),
            ("index not from 0", Box::new(|m| m.index[0] = 1)),
            (
                "element of a patch past k",
                Box::new(|m| m.elements[0].patch = 10_000),
            ),
        ];
        for (what, damage) in cases {
            let mut m = good.clone();
            damage(&mut m);
            assert!(m.validate().is_err(), "{what}: accepted");
        }
    }
}
