//! 2MSC, two meshes with spatial coherence (DESIGN.md §3): adaptive patches.
//!
//! The low-rank operator assumes every element sees all of a patch alike,
//! `F(e, e') ≈ F(e, P) A_e'/A_P`. By reciprocity (`F(e, e')/A_e' = F(e', e)/A_e`) that holds
//! when the scene *as seen from* the points of `P` is alike: a patch is **coherent** when the
//! views from its parts agree. Patches are refined top-down:
//!
//! 1. Roots in a FIFO list: every piece of an input face (the root of its subdivision
//!    hierarchy), except on dense surfaces, whose small pieces form one cluster per surface
//!    (`cluster`).
//! 2. Take the first node. If its area is at most `A_min`, or it cannot be split (one element),
//!    it is a patch. A cluster whose normals spread wider than the 2MF cone
//!    (`cluster::NORMAL_CONE_DEGREES` around their mean) is split without a test: the measure
//!    below stands for each child by one point and one normal, which on a curved cluster (a
//!    hemisphere of a dense sphere) sees the scene from one direction only and underestimates
//!    the error. Otherwise estimate the *error* of keeping it whole from its children (the
//!    2×2, 1×2 or 4 subdivision children of a polygon, the two halves of a cluster's
//!    bisection); above the threshold the children are pushed to the back of the list, else
//!    the node is a patch. Repeat until the list is empty: `k` is an output.
//!
//! **The measure.** Write `B_e' = B̄ + δ_e'` over the node `P`. The error the patch makes in
//! what a viewer `j` (area `A_j`) receives is, by reciprocity,
//!
//! ```text
//! δB_j = ρ_j Σ_{e'∈P} (F_je' − F_jP A_e'/A_P) B_e' = ρ_j / A_j · Σ_{e'∈P} A_e' (F_e'j − F̄_Pj) δ_e'
//! ```
//!
//! a covariance over the patch between *how it sees* `j` and *its own radiosity*: a patch
//! whose view varies but whose radiosity is uniform (an emitter) makes no error, nor does a
//! uniformly lit patch seeing the scene alike. The measure evaluates it at the children:
//! - each child `c` (area `a_c`) is represented by one point `x_c` (its centroid; for a
//!   cluster, the centroid of the part nearest the area centroid) with its normal;
//! - its view vector `f_c[j] = F(x_c → j)` over the probe patches `j` (the 2MF patches at
//!   `--patch-size`): the closed-form point-to-patch factor times the visible fraction of
//!   `PROBE_RAYS` kernel-weighted rays;
//! - its radiosity estimate `b_c = E + ρ Σ_j f_c[j] B_j`, with `B_j` from a coarse solve on the
//!   probes (`Probes::new`; reflectance and emission averaged over the channels);
//!
//! ```text
//! error(P) = Σ_j ρ_j | Σ_c a_c (f_c[j] − f̄[j]) (b_c − b̄) |  /  (A_scene · B̄_scene)
//! ```
//!
//! the reflected power the node gets wrong (in `Σ_j A_j |δB_j|`), as a share of the scene's
//! (total area times the area-weighted mean probe radiosity). It is scale-free; the default
//! threshold [`DEFAULT_THRESHOLD`] is 3e-5.
//!
//! **Cost.** The coarse solve: `q²` point-to-patch factors (`q² · P` kernel evaluations and
//! `q² · PROBE_RAYS` rays, `P` parts per probe: 1 unless clustered) and a `q × q` LU. One node
//! test: `c × q × P` kernel evaluations and `c × q × PROBE_RAYS` rays, for `c` children (2–4).
//! Each interior node of the final tree is tested once, about `k/3` tests for quads, so
//! `≈ 1.3 · k · q · PROBE_RAYS` rays in all, against `n · k · S` (and more, adaptively) for the
//! form factors that follow: on the Cornell box (q = 242) the mesh stage takes 0.5 s of a 10 s
//! bake. Tests of one FIFO generation run in parallel; every decision depends only on its node
//! (rays seeded by the point), so the mesh does not depend on the thread count.
//!
//! **Steering `k`.** A smaller threshold splits more (threshold → 0 splits every node above
//! `A_min`, and since a decision depends only on its node, a smaller threshold never gives
//! fewer patches); `A_min` bounds the patch size from below (default `(2 · element size)²`,
//! about 2×2 elements; 0 allows single-element patches and, with a tiny threshold, `k = n`).

use glam::DVec3;
use rayon::prelude::*;

use super::patch::Patch;
use crate::error::Result;
use crate::formfactor::point::point_to_region;
use crate::geometry::Polygon;
use crate::geometry::Region;
use crate::geometry::cluster::{self, Unit};
use crate::geometry::hash::mix;
use crate::lights::{LightsOwned, SceneLights};
use crate::mesh::subdivide::{self, Piece};
use crate::mesh::{Element, MeshSizes};
use crate::visibility::Occluder;

/// Default threshold of the split rule (`lrr --method 2msc-split --threshold`; the default
/// rule is [`merge`]'s): the largest estimated share of the scene's reflected power a patch
/// may get wrong. On the Cornell box it gives k = 333 at a relative L2 error of 0.00093
/// against the exact solve, where 2MF's former default gave k = 242 at 0.0018 and 1e-4 (the
/// default before) k = 154 at 0.0015 (docs/MESHING.md).
pub const DEFAULT_THRESHOLD: f64 = 3e-5;

/// The threshold at and above which the default `--min-patch-area` is `(2h)²` (about 2×2
/// elements); below it the default area shrinks in proportion (`patches::refinement`).
pub const FULL_MIN_AREA_THRESHOLD: f64 = 1e-4;

/// Revision of the refinement rules: part of the checkpoint key (`checkpoint::key`), since a
/// rule change gives other patches (another `F_k`) for the same flags. 2: clusters wider than
/// the normal cone are always split.
pub(crate) const REVISION: u32 = 3;

/// Visibility rays from a child's point to each probe.
pub(crate) const PROBE_RAYS: u32 = 8;

/// The 2MSC parameters, validated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Refinement {
    pub threshold: f64,
    /// Split rule only (0 for the merge rule).
    pub min_patch_area: f64,
    pub rule: crate::patches::CoherenceRule,
}

/// A node of the hierarchy: part of one piece's subdivision, or a cluster of small pieces.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Node {
    Polygon {
        polygon: Polygon,
        piece: u32,
        /// Original ids `first..first + count`.
        first: u32,
        count: u32,
    },
    /// Small pieces of one surface (indices into the pieces, ascending; at least two).
    Cluster { pieces: Vec<usize> },
}

/// The probe patches (the 2MF patches at the patch size) and a coarse radiosity solve on them.
pub(crate) struct Probes<'a> {
    pub targets: Vec<Region>,
    /// Mean reflectance over the channels.
    pub reflectance: Vec<f64>,
    /// Estimated radiosity (mean over the channels): `(I - diag(ρ) F) B = E` on the probes.
    pub radiosity: Vec<f64>,
    /// Area-weighted mean of `radiosity`: the scale errors are relative to.
    pub mean_radiosity: f64,
    /// Total area of the probes (the scene's surface area).
    pub total_area: f64,
    /// Elements in each probe (the merge rule's weights; `patches::msc_inputs` counts them).
    pub elements: Vec<f64>,
    pub occluder: Option<&'a dyn Occluder>,
    /// What view seeds are measured from ([`view_seed`]).
    pub frame: SeedFrame,
    /// The scene's lights that are not surfaces: their reflected direct light is emission to
    /// every estimate (`crate::lights`).
    pub lights: LightsOwned,
}

impl Probes<'_> {
    /// The scene's lights that are not surfaces, shadowed by the probes' occluder.
    pub(crate) fn lights(&self) -> SceneLights<'_> {
        SceneLights::new(&self.lights, self.occluder)
    }

    /// `ρ H` at `x` (mean over the channels): the reflected direct light of the lights that
    /// are not surfaces, for a surface of mean reflectance `rho`.
    pub(crate) fn direct(&self, rho: f64, x: DVec3, normal: DVec3) -> f64 {
        if self.lights.is_empty() {
            return 0.0;
        }
        rho * self.lights().mean_irradiance(x, normal)
    }
}

/// The scene's bounding-box corner and extent: view seeds hash positions relative to them, so
/// that a scene in millimetres and the same scene in metres cast the same rays and join the
/// same patches (before issue #31 the seeds hashed the raw coordinates' bits, and the Cornell
/// box ×1e4 joined patches in another order: single elements moved by 11–14%).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SeedFrame {
    pub origin: DVec3,
    pub extent: f64,
}

impl<'a> Probes<'a> {
    /// Builds the probes and solves the coarse system with point-to-patch form factors from
    /// each probe's representative point (q² kernel sums, `q² · PROBE_RAYS` rays).
    pub(crate) fn new(
        targets: Vec<Region>,
        reflectance: Vec<f64>,
        emission: Vec<f64>,
        occluder: Option<&'a dyn Occluder>,
        frame: SeedFrame,
        lights: LightsOwned,
    ) -> Result<Self> {
        let q = targets.len();
        let mut probes = Self {
            targets,
            reflectance,
            radiosity: Vec::new(),
            mean_radiosity: 0.0,
            total_area: 0.0,
            elements: vec![0.0; q],
            occluder,
            frame,
            lights,
        };
        // The lights' reflected direct light at each probe's representative point.
        let mut emission = emission;
        if !probes.lights.is_empty() {
            let direct: Vec<f64> = (0..q)
                .into_par_iter()
                .map(|i| {
                    let t = &probes.targets[i];
                    let part = t.nearest_part(t.centroid());
                    probes.direct(probes.reflectance[i], part.centroid(), part.normal)
                })
                .collect();
            for (e, d) in emission.iter_mut().zip(direct) {
                *e += d;
            }
        }
        let mut f = vec![0.0; q * q];
        f.par_chunks_mut(q.max(1)).enumerate().for_each(|(i, row)| {
            let t = &probes.targets[i];
            let part = t.nearest_part(t.centroid());
            view(&probes, part.centroid(), part.normal, row);
        });
        let rho: Vec<[f64; 3]> = probes.reflectance.iter().map(|&r| [r; 3]).collect();
        let e: Vec<[f64; 3]> = emission.iter().map(|&x| [x; 3]).collect();
        let data = crate::radiosity::ElementData {
            reflectance: &rho,
            emission: &e,
        };
        let b = crate::radiosity::solve_dense(&f, &data)?;
        probes.radiosity = b.iter().map(|b| b[0]).collect();
        let area: f64 = probes.targets.iter().map(Region::area).sum();
        probes.total_area = area;
        probes.mean_radiosity = probes
            .targets
            .iter()
            .zip(&probes.radiosity)
            .map(|(t, b)| t.area() * b)
            .sum::<f64>()
            / area;
        Ok(probes)
    }
}

/// Mean reflectance and emission (over the channels) of a piece's material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Material {
    pub reflectance: f64,
    pub emission: f64,
}

/// Refines the hierarchy over `pieces` and returns the patches, with `elements[..].patch` set.
/// Patches are numbered by their smallest element id.
pub(crate) fn two_msc(
    pieces: &[Piece],
    materials: &[Material],
    elements: &mut [Element],
    sizes: MeshSizes,
    refinement: Refinement,
    probes: &Probes,
) -> Vec<Patch> {
    let ctx = Ctx {
        pieces,
        units: pieces.iter().map(|p| Unit::of(&p.polygon)).collect(),
        materials,
        element_size: sizes.element_size,
    };
    let nodes = fifo_refine(roots(pieces, sizes), |node| {
        if ctx.area(node) <= refinement.min_patch_area {
            return None;
        }
        let children = ctx.children(node);
        if children.len() < 2 {
            return None;
        }
        // A cluster whose normals spread wider than the 2MF cone is split whatever its
        // estimate: one point and one normal cannot stand for how its parts see the scene.
        if ctx.too_curved(node) {
            return Some(children);
        }
        let error = ctx.error(node, &children, probes);
        (error > refinement.threshold).then_some(children)
    });
    let mut patches: Vec<(u32, Patch, Ranges)> = nodes.into_iter().map(|n| ctx.patch(&n)).collect();
    patches.sort_by_key(|p| p.0);
    patches
        .into_iter()
        .enumerate()
        .map(|(id, (_, patch, ranges))| {
            for (first, count) in ranges {
                for e in &mut elements[first as usize..(first + count) as usize] {
                    e.patch = id as u32;
                }
            }
            patch
        })
        .collect()
}

/// Element ids `(first, count)` of a patch's parts.
type Ranges = Vec<(u32, u32)>;

/// Top-down refinement with a FIFO list: `split` returns a node's children when it must be
/// split. Nodes come out in the order they were accepted. One generation of the list is
/// decided in parallel, which is the FIFO order exactly (a decision depends on its node only).
pub(crate) fn fifo_refine<N: Send + Sync>(
    roots: Vec<N>,
    split: impl Fn(&N) -> Option<Vec<N>> + Sync,
) -> Vec<N> {
    let mut accepted = Vec::new();
    let mut queue = roots;
    while !queue.is_empty() {
        let decisions: Vec<Option<Vec<N>>> = queue.par_iter().map(&split).collect();
        let mut next = Vec::new();
        for (node, decision) in queue.into_iter().zip(decisions) {
            match decision {
                Some(children) => next.extend(children),
                None => accepted.push(node),
            }
        }
        queue = next;
    }
    accepted
}

/// The roots: pieces whole, except the small pieces of dense surfaces
/// ([`subdivide::dense_sets`]): one cluster per surface.
fn roots(pieces: &[Piece], sizes: MeshSizes) -> Vec<Node> {
    let dense = subdivide::dense_sets(pieces, sizes);
    let mut clustered = vec![false; pieces.len()];
    for &i in dense.iter().flatten() {
        clustered[i] = true;
    }
    let mut out: Vec<Node> = (0..pieces.len())
        .filter(|&i| !clustered[i])
        .map(|i| piece_node(pieces, i))
        .collect();
    out.extend(dense.into_iter().map(|set| cluster_node(pieces, set)));
    out
}

fn piece_node(pieces: &[Piece], i: usize) -> Node {
    Node::Polygon {
        polygon: pieces[i].polygon,
        piece: i as u32,
        first: pieces[i].first,
        count: pieces[i].count,
    }
}

fn cluster_node(pieces: &[Piece], set: Vec<usize>) -> Node {
    if set.len() == 1 {
        piece_node(pieces, set[0])
    } else {
        Node::Cluster { pieces: set }
    }
}

struct Ctx<'a> {
    pieces: &'a [Piece],
    units: Vec<Unit>,
    materials: &'a [Material],
    element_size: f64,
}

impl Ctx<'_> {
    fn area(&self, node: &Node) -> f64 {
        match node {
            Node::Polygon { polygon, .. } => polygon.area(),
            Node::Cluster { pieces } => pieces.iter().map(|&p| self.units[p].area).sum(),
        }
    }

    fn children(&self, node: &Node) -> Vec<Node> {
        match node {
            Node::Polygon {
                polygon,
                piece,
                first,
                ..
            } => {
                if crate::mesh::within(polygon.size(), self.element_size) {
                    return Vec::new(); // an element
                }
                let mut next = *first;
                subdivide::split(polygon)
                    .into_iter()
                    .map(|child| {
                        let count = subdivide::leaf_count(child, self.element_size);
                        let node = Node::Polygon {
                            polygon: child,
                            piece: *piece,
                            first: next,
                            count,
                        };
                        next += count;
                        node
                    })
                    .collect()
            }
            Node::Cluster { pieces } => cluster::bisect(&self.units, pieces)
                .into_iter()
                .map(|set| cluster_node(self.pieces, set))
                .collect(),
        }
    }

    /// True for a cluster whose normals do not fit the 2MF cone around their mean: one
    /// point and normal cannot stand for how it sees the scene.
    fn too_curved(&self, node: &Node) -> bool {
        match node {
            Node::Polygon { .. } => false,
            Node::Cluster { pieces } => !cluster::fits(&self.units, pieces, f64::INFINITY),
        }
    }

    /// One point of the node, its normal and the node's area.
    fn representative(&self, node: &Node) -> (DVec3, DVec3, f64) {
        match node {
            Node::Polygon { polygon, .. } => (polygon.centroid(), polygon.normal, polygon.area()),
            Node::Cluster { pieces } => {
                let area = self.area(node);
                let c = pieces
                    .iter()
                    .map(|&p| self.units[p].area * self.units[p].centroid)
                    .sum::<DVec3>()
                    / area;
                let nearest = pieces
                    .iter()
                    .copied()
                    .min_by(|&a, &b| {
                        let da = self.units[a].centroid.distance_squared(c);
                        let db = self.units[b].centroid.distance_squared(c);
                        da.total_cmp(&db).then(a.cmp(&b))
                    })
                    .expect("a cluster has pieces");
                (
                    self.units[nearest].centroid,
                    self.units[nearest].normal,
                    area,
                )
            }
        }
    }

    /// The estimated error of treating `node` as one patch, as a share of the scene's
    /// reflected power (module docs).
    fn error(&self, node: &Node, children: &[Node], probes: &Probes) -> f64 {
        if probes.mean_radiosity <= 0.0 {
            return 0.0;
        }
        let piece = match node {
            Node::Polygon { piece, .. } => *piece as usize,
            Node::Cluster { pieces } => pieces[0],
        };
        let m = self.materials[piece];
        let q = probes.targets.len();
        let mut views = Vec::with_capacity(children.len());
        let mut area = 0.0;
        for child in children {
            let (x, normal, a) = self.representative(child);
            let mut f = vec![0.0; q];
            view(probes, x, normal, &mut f);
            let gathered: f64 = f.iter().zip(&probes.radiosity).map(|(f, b)| f * b).sum();
            let direct = probes.direct(m.reflectance, x, normal);
            views.push((a, m.emission + direct + m.reflectance * gathered, f));
            area += a;
        }
        let mean_b = views.iter().map(|(a, b, _)| a * b).sum::<f64>() / area;
        let mut error = 0.0;
        for j in 0..q {
            let mean_f = views.iter().map(|(a, _, f)| a * f[j]).sum::<f64>() / area;
            let covariance: f64 = views
                .iter()
                .map(|(a, b, f)| a * (f[j] - mean_f) * (b - mean_b))
                .sum();
            error += probes.reflectance[j] * covariance.abs();
        }
        // Relative to the whole scene's reflected power, not the node's own: a small node's
        // share of the error is small. Tried first: dividing by the node's area (a per-area
        // relative error); on the Cornell box it needed 152 patches for the error this gives
        // with 118, as it split small dim nodes as readily as large bright ones.
        error / (probes.total_area * probes.mean_radiosity)
    }

    /// The patch of an accepted node: (smallest element id, patch, element id ranges).
    fn patch(&self, node: &Node) -> (u32, Patch, Ranges) {
        match node {
            Node::Polygon {
                polygon,
                piece,
                first,
                count,
            } => {
                let p = &self.pieces[*piece as usize];
                let patch = Patch {
                    shape: Region::single(*polygon),
                    face: p.face,
                    surface: p.surface,
                };
                (*first, patch, vec![(*first, *count)])
            }
            Node::Cluster { pieces } => {
                let p0 = &self.pieces[pieces[0]];
                let parts = pieces.iter().map(|&p| self.pieces[p].polygon).collect();
                let ranges = pieces
                    .iter()
                    .map(|&p| (self.pieces[p].first, self.pieces[p].count))
                    .collect();
                let patch = Patch {
                    shape: Region::new(parts),
                    face: p0.face,
                    surface: p0.surface,
                };
                (p0.first, patch, ranges)
            }
        }
    }
}

/// The seed of a point's probe rays (from its coordinates: the same point, the same rays).
pub(crate) fn view_seed(frame: &SeedFrame, x: DVec3) -> u64 {
    // Scene-relative coordinates on a grid of 2⁻²⁴ of the extent: the same at any scale
    // unless a coordinate falls within rounding of a grid line.
    let r = (x - frame.origin) / frame.extent.max(f64::MIN_POSITIVE);
    let q = |v: f64| (v * (1u64 << 24) as f64).round() as i64 as u64;
    mix(q(r.x) ^ mix(q(r.y) ^ mix(q(r.z))))
}

/// The view vector of a surface point: `F(x → probe j)` with visibility.
pub(crate) fn view(probes: &Probes, x: DVec3, normal: DVec3, out: &mut [f64]) {
    let seed = view_seed(&probes.frame, x);
    for (j, (probe, out)) in probes.targets.iter().zip(out.iter_mut()).enumerate() {
        *out = point_to_region(
            x,
            normal,
            probe,
            probes.occluder,
            PROBE_RAYS,
            seed ^ j as u64,
        );
    }
}

pub mod merge;
#[cfg(test)]
mod oracle;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::patches::{Mesh, PatchMethod};
    use crate::scene::{Scene, procedural};
    use crate::visibility::obvhs::ObvhsOccluder;
    use std::path::Path;

    /// The shipped Cornell box (shared with `merge`'s tests).
    pub(super) fn cornell() -> Scene {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box/cornell-box.toml");
        crate::scene::load(&path).unwrap()
    }

    fn msc(scene: &Scene, threshold: f64, min_patch_area: Option<f64>) -> Mesh {
        let sizes = MeshSizes::resolve(scene, None, None).unwrap();
        let occ = ObvhsOccluder::build(scene);
        let method = PatchMethod::SpatialCoherence {
            threshold,
            min_patch_area,
            rule: crate::patches::CoherenceRule::Split,
        };
        Mesh::build(scene, sizes, method, Some(&occ)).unwrap()
    }

    #[test]
    fn smaller_threshold_never_gives_fewer_patches() {
        let scene = cornell();
        let sizes = MeshSizes::resolve(&scene, None, None).unwrap();
        let fixed = Mesh::two_fixed(&scene, sizes).unwrap();
        let mut last = 0;
        for t in [1e-2, 1e-3, 1e-4, 3e-5] {
            let mesh = msc(&scene, t, None);
            mesh.validate().unwrap();
            // the fine mesh does not depend on the patch method
            assert_eq!(mesh.n(), fixed.n());
            assert!(
                mesh.elements
                    .iter()
                    .zip(&fixed.elements)
                    .all(|(a, b)| a.polygon == b.polygon
                        && a.face == b.face
                        && a.surface == b.surface)
            );
            println!("threshold {t}: k = {}", mesh.k());
            assert!(mesh.k() >= last, "threshold {t}: k = {} < {last}", mesh.k());
            last = mesh.k();
        }
        assert!(last > 20 && last < fixed.n(), "k = {last}");
    }

    /// With the default `A_min` (which shrinks below the default threshold) 2MSC keeps
    /// splitting as the threshold falls, towards single elements: `k` grows strictly and ends
    /// near `n` (the floor under the blocks, which receives nothing, is never split).
    #[test]
    fn smaller_thresholds_keep_splitting_toward_single_elements() {
        let scene = cornell();
        let mut ks = Vec::new();
        for t in [1e-4, 1e-5, 1e-6, 1e-8] {
            let mesh = msc(&scene, t, None);
            println!("threshold {t}: k = {} of n = {}", mesh.k(), mesh.n());
            ks.push((mesh.k(), mesh.n()));
        }
        assert!(ks.windows(2).all(|w| w[0].0 < w[1].0), "{ks:?}");
        let (k, n) = ks[ks.len() - 1];
        assert!(k as f64 >= 0.9 * n as f64, "{ks:?}");
    }

    #[test]
    fn min_patch_area_stops_refinement() {
        // A threshold far below any error splits every node larger than A_min: every patch
        // is then at most A_min (or one element), and a larger A_min gives fewer patches.
        // Except where the error is exactly 0: the floor under the two blocks sees only the
        // backs of the blocks' faces, receives nothing and is never split.
        let scene = cornell();
        let footprints = [
            DVec3::new(185.5, 0.0, 169.0),
            DVec3::new(368.5, 0.0, 351.25),
        ];
        let mut ks = Vec::new();
        for a_min in [40_000.0, 10_000.0] {
            let mesh = msc(&scene, 1e-12, Some(a_min));
            mesh.validate().unwrap();
            for p in 0..mesh.k() {
                let elements = mesh.index[p + 1] - mesh.index[p];
                let area = mesh.patches[p].shape.area();
                let c = mesh.patches[p].shape.centroid();
                let dark = footprints.iter().any(|f| f.distance(c) < 1.0);
                assert!(
                    area <= a_min || elements == 1 || dark,
                    "patch {p}: area {area}"
                );
            }
            ks.push(mesh.k());
        }
        assert!(ks[0] < ks[1], "{ks:?}");
    }

    #[test]
    fn dense_sphere_is_clustered_by_both_methods() {
        let d = procedural::dense_sphere(3);
        let scene = d.build("dense", Path::new(".")).unwrap();
        let sizes = MeshSizes::resolve(&scene, None, None).unwrap();
        let sphere = scene.surfaces.iter().position(|s| s == "sphere").unwrap() as u32;
        let triangles = scene
            .faces
            .iter()
            .filter(|f| f.surface as u32 == sphere)
            .count();
        assert_eq!(triangles, 1280);
        let fixed = Mesh::two_fixed(&scene, sizes).unwrap();
        let adaptive = msc(&scene, 1e-4, None);
        for mesh in [&fixed, &adaptive] {
            mesh.validate().unwrap();
            let on_sphere = mesh.patches.iter().filter(|p| p.surface == sphere).count();
            println!(
                "k = {} ({on_sphere} on the sphere), n = {}",
                mesh.k(),
                mesh.n()
            );
            assert!(
                (4..=triangles / 8).contains(&on_sphere),
                "{on_sphere} sphere patches"
            );
        }
        assert_eq!(fixed.n(), adaptive.n());
    }

    /// With a threshold no estimate reaches, only the normal cone splits: each sphere cluster
    /// larger than `A_min` then fits the 2MF cone (45° around its mean normal); without the
    /// rule the whole sphere would be one patch.
    #[test]
    fn curved_clusters_are_split_to_the_normal_cone() {
        let d = procedural::dense_sphere(3);
        let scene = d.build("dense", Path::new(".")).unwrap();
        let sizes = MeshSizes::resolve(&scene, None, None).unwrap();
        let sphere = scene.surfaces.iter().position(|s| s == "sphere").unwrap() as u32;
        let mesh = msc(&scene, 1e9, None);
        mesh.validate().unwrap();
        let a_min = 4.0 * sizes.element_size * sizes.element_size;
        let cos = cluster::NORMAL_CONE_DEGREES.to_radians().cos();
        let mut on_sphere = 0;
        for p in mesh.patches.iter().filter(|p| p.surface == sphere) {
            on_sphere += 1;
            let parts = p.shape.parts();
            let mean = parts
                .iter()
                .map(|q| q.area() * q.normal)
                .sum::<DVec3>()
                .normalize();
            let fits = parts.iter().all(|q| q.normal.dot(mean) >= cos);
            assert!(
                fits || p.shape.area() <= a_min,
                "a curved cluster kept whole"
            );
        }
        println!("{on_sphere} patches on the sphere");
        assert!(on_sphere >= 8, "{on_sphere} sphere patches");
    }

    #[test]
    fn fifo_order_is_breadth_first() {
        // A binary tree over integer intervals: a node [a, b) splits while b - a > 1 and
        // a = 0. Accepted nodes come out generation by generation, in list order.
        let out = fifo_refine(vec![(0u32, 8u32)], |&(a, b)| {
            (b - a > 1 && a == 0).then(|| vec![(a, (a + b) / 2), ((a + b) / 2, b)])
        });
        assert_eq!(out, vec![(4, 8), (2, 4), (0, 1), (1, 2)]);
    }
}
