//! 2MSC, two meshes with spatial coherence (DESIGN.md §3): adaptive patches.
//!
//! The low-rank operator assumes every element sees all of a patch alike,
//! `F(e, e') ≈ F(e, P) A_e'/A_P`. By reciprocity (`F(e, e')/A_e' = F(e', e)/A_e`) that holds
//! when the scene *as seen from* the points of `P` is alike: a patch is **coherent** when the
//! views from its parts agree. Patches are refined top-down:
//!
//! 1. Roots in a FIFO list: every large piece of an input face (the root of its subdivision
//!    hierarchy), and per surface one cluster of its small pieces ([`super::cluster`]).
//! 2. Take the first node. If its area is at most `A_min`, or it cannot be split (one element),
//!    it is a patch. Otherwise compute its *spread* over its children (the 2×2, 1×2 or 4
//!    subdivision children of a polygon, the two halves of a cluster's bisection); if the
//!    spread exceeds the threshold the children are pushed to the back of the list, else the
//!    node is a patch. Repeat until the list is empty: `k` is an output.
//!
//! **The measure.** Each child `c` (area `a_c`) is represented by one point `x_c` (its
//! centroid; for a cluster, the centroid of the part nearest the area centroid) with its normal.
//! Its *view vector* holds, for every probe patch `j` (the 2MF patches at `--patch-size`),
//! `v_c[j] = ρ̄_j · F(x_c → j)`: the closed-form point-to-patch factor times the visible fraction
//! of [`PROBE_RAYS`] kernel-weighted rays, times the probe's mean reflectance (an error in what
//! probe `j` receives from the patch reaches the image multiplied by `ρ_j`; a black probe
//! cannot show it). With `v̄ = Σ a_c v_c / A` the area-weighted mean,
//!
//! ```text
//! spread = Σ_c a_c ‖v_c − v̄‖₁ / (A ‖v̄‖₁)        (0 = all children see the same; ≤ 2)
//! ```
//!
//! the relative L1 deviation of the children's views: the relative error in reflected light
//! that treating the node as one patch makes, if its radiosity varied between its children as
//! much as it can. A node that sees nothing reflective (`v̄ = 0`) is coherent.
//!
//! **Cost.** One test costs `c × q × P` kernel evaluations and `c × q × PROBE_RAYS` rays, for
//! `c` children (2–4), `q` probes and `P` parts per probe (1 unless clustered); the whole
//! refinement tests each node of the final tree's interior once: about `k/3` tests for quads,
//! so `≈ 1.3 · k · q · PROBE_RAYS` rays in all, against `n · k · S` (and more, adaptively)
//! for the form factors that follow. On the Cornell box (q = 189) it is a small fraction of
//! the bake. Tests of one FIFO generation run in parallel; every decision depends only on its
//! node (rays seeded by the point), so the result does not depend on the thread count.
//!
//! **Steering `k`.** A smaller threshold splits more (threshold → 0 splits every node above
//! `A_min`); `A_min` bounds the patch size from below (default `(2 · element size)²`, about
//! 2×2 elements; 0 allows single-element patches and, with a tiny threshold, `k = n`).

use glam::DVec3;
use rayon::prelude::*;

use super::cluster::{self, Unit};
use super::subdivide::{self, Piece};
use super::{Element, MeshSizes, Patch};
use crate::formfactor::Target;
use crate::formfactor::kernel::{Polygon, point_to_polygon};
use crate::formfactor::sampling::mix;
use crate::visibility::Occluder;

/// Visibility rays from a child's point to each probe.
pub const PROBE_RAYS: u32 = 8;

/// The 2MSC parameters, validated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Refinement {
    pub threshold: f64,
    pub min_patch_area: f64,
}

/// A node of the hierarchy: part of one piece's subdivision, or a cluster of small pieces.
#[derive(Debug, Clone, PartialEq)]
pub enum Node {
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

/// What a probe sees: the probe patches and their mean reflectance.
pub struct Probes<'a> {
    pub targets: Vec<Target>,
    pub reflectance: Vec<f64>,
    pub occluder: Option<&'a dyn Occluder>,
}

/// Refines the hierarchy over `pieces` and returns the patches, with `elements[..].patch` set.
/// Patches are numbered by their smallest element id.
pub fn two_msc(
    pieces: &[Piece],
    elements: &mut [Element],
    sizes: MeshSizes,
    refinement: Refinement,
    probes: &Probes,
) -> Vec<Patch> {
    let ctx = Ctx {
        pieces,
        units: pieces.iter().map(|p| Unit::of(&p.polygon)).collect(),
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
        let spread = ctx.spread(&children, probes);
        (spread > refinement.threshold).then_some(children)
    });
    let mut patches: Vec<(u32, Patch, Vec<(u32, u32)>)> =
        nodes.into_iter().map(|n| ctx.patch(&n)).collect();
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

/// Top-down refinement with a FIFO list: `split` returns a node's children when it must be
/// split. Nodes come out in the order they were accepted. One generation of the list is
/// decided in parallel, which is the FIFO order exactly (a decision depends on its node only).
pub fn fifo_refine<N: Send + Sync>(
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
                if polygon.size() <= self.element_size {
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

    /// The relative L1 spread of the children's view vectors (module docs).
    fn spread(&self, children: &[Node], probes: &Probes) -> f64 {
        let q = probes.targets.len();
        let mut views = Vec::with_capacity(children.len());
        let mut total_area = 0.0;
        for child in children {
            let (x, normal, area) = self.representative(child);
            let mut v = vec![0.0; q];
            view(probes, x, normal, &mut v);
            views.push((area, v));
            total_area += area;
        }
        let mut mean = vec![0.0; q];
        for (a, v) in &views {
            for (m, x) in mean.iter_mut().zip(v) {
                *m += a * x / total_area;
            }
        }
        let norm: f64 = mean.iter().sum();
        if norm <= 0.0 {
            return 0.0;
        }
        let deviation: f64 = views
            .iter()
            .map(|(a, v)| a * v.iter().zip(&mean).map(|(x, m)| (x - m).abs()).sum::<f64>())
            .sum();
        deviation / (total_area * norm)
    }

    /// The patch of an accepted node: (smallest element id, patch, element id ranges).
    fn patch(&self, node: &Node) -> (u32, Patch, Vec<(u32, u32)>) {
        match node {
            Node::Polygon {
                polygon,
                piece,
                first,
                count,
            } => {
                let p = &self.pieces[*piece as usize];
                let patch = Patch {
                    shape: Target::single(*polygon),
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
                    shape: Target::new(parts),
                    face: p0.face,
                    surface: p0.surface,
                };
                (p0.first, patch, ranges)
            }
        }
    }
}

/// The view vector of a surface point: `ρ̄_j · F(x → probe j)` with visibility.
pub fn view(probes: &Probes, x: DVec3, normal: DVec3, out: &mut [f64]) {
    let seed = mix(x.x.to_bits() ^ mix(x.y.to_bits() ^ mix(x.z.to_bits())));
    for (j, (probe, out)) in probes.targets.iter().zip(out.iter_mut()).enumerate() {
        let f: f64 = probe
            .parts()
            .iter()
            .map(|part| point_to_polygon(x, normal, part))
            .sum();
        *out = 0.0;
        if f <= 0.0 || probes.reflectance[j] <= 0.0 {
            continue;
        }
        let visible = match probes.occluder {
            None => 1.0,
            Some(occ) => visible_fraction(occ, x, normal, probe, seed ^ j as u64),
        };
        *out = probes.reflectance[j] * f * visible;
    }
}

/// Kernel-weighted fraction of [`PROBE_RAYS`] unblocked segments from `x` to the probe.
fn visible_fraction(occ: &dyn Occluder, x: DVec3, normal: DVec3, probe: &Target, seed: u64) -> f64 {
    let (mut total, mut visible) = (0.0, 0.0);
    for i in 0..PROBE_RAYS {
        let (j, s) = probe.pair_point(i, seed);
        let part_normal = probe.parts()[j].normal;
        let d = s.point - x;
        let (cos_x, cos_y) = (d.dot(normal), -d.dot(part_normal));
        if cos_x <= 0.0 || cos_y <= 0.0 {
            continue;
        }
        let r2 = d.length_squared();
        let w = s.weight * cos_x * cos_y / (r2 * r2);
        if !w.is_finite() {
            continue;
        }
        total += w;
        if !occ.occluded(x, normal, s.point, part_normal) {
            visible += w;
        }
    }
    if total > 0.0 {
        return visible / total;
    }
    let t = probe.nearest_part(x);
    if occ.occluded(x, normal, t.centroid(), t.normal) {
        0.0
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{Mesh, PatchMethod};
    use crate::scene::{Scene, procedural};
    use crate::visibility::obvhs::ObvhsOccluder;
    use std::path::Path;

    fn cornell() -> Scene {
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
        };
        Mesh::build(scene, sizes, method, Some(&occ)).unwrap()
    }

    #[test]
    fn smaller_threshold_never_gives_fewer_patches() {
        let scene = cornell();
        let sizes = MeshSizes::resolve(&scene, None, None).unwrap();
        let fixed = Mesh::two_fixed(&scene, sizes).unwrap();
        let mut last = 0;
        for t in [1.0, 0.3, 0.1, 0.03] {
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

    #[test]
    fn min_patch_area_stops_refinement() {
        // A threshold far below any spread splits every node larger than A_min: every patch
        // is then at most A_min (or one element), and a larger A_min gives fewer patches.
        let scene = cornell();
        let mut ks = Vec::new();
        for a_min in [40_000.0, 10_000.0] {
            let mesh = msc(&scene, 1e-12, Some(a_min));
            mesh.validate().unwrap();
            for p in 0..mesh.k() {
                let elements = mesh.index[p + 1] - mesh.index[p];
                let area = mesh.patches[p].shape.area();
                assert!(area <= a_min || elements == 1, "patch {p}: area {area}");
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
        let adaptive = msc(&scene, 0.1, None);
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
