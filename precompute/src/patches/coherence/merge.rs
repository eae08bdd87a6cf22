//! 2MSC by merging (the default rule, issue #14): patches grown bottom-up from single elements.
//!
//! The split rule ([`super::two_msc`]) cuts the subdivision hierarchy top-down and can only
//! stop at its nodes: a patch is a quadtree cell of one piece. Merging starts from every
//! element as its own patch (`k = n`, the exact solve) and repeatedly joins the two touching
//! patches whose union adds the least estimated error, until the next join would take the
//! estimated error of the whole coarse mesh past the threshold. A patch is then any connected
//! set of elements of one surface within the 2MF normal cone: across pieces and subdivision
//! cells, shaped by where light changes (docs/MESHING.md, "2MSC by merging").
//!
//! **The estimate.** Keeping `P` whole makes a receiver `j` gather `F(j → P) B̄_P` instead of
//! `Σ_{e∈P} F_je B_e`: an error `δ_j = ρ_j (s_j B̄_P − t_j)` with, by reciprocity,
//!
//! ```text
//! s_j = Σ_{e∈P} A_e F(x_e → j) / A_j        t_j = Σ_{e∈P} A_e F(x_e → j) b_e / A_j
//! ```
//!
//! over the probes `j` (the 2MF patches at the patch size, as the split rule uses), where
//! `F(x_e → j)` is the closed-form point-to-patch factor from the element's centroid times the
//! visible fraction of [`PROBE_RAYS`] rays (sampled instead for clustered probes far from the
//! element: `FarField`), and `b_e = E_e + ρ_e Σ_j F(x_e → j) B_j` the
//! element's radiosity gathered from the probes' coarse solve (means over the channels). A
//! patch's error is `err(P) = Σ_j c_j δ_j²` with `c_j` the elements in probe `j` (so that it
//! stands for the squared error summed over the elements, which the relative L2 error of
//! `lrr accuracy` measures); the coarse mesh's estimated relative error is
//! `sqrt(Σ_P err(P) / Σ_e b_e²)`. `s` and `t` add when patches join, so a join costs `O(q)`.
//! The estimate is first order (one gather, no bounces) and ignores how the errors of
//! different patches cancel or add; `--threshold` is that estimate, not a guarantee.
//!
//! **Cost.** `n · q` point-to-patch factors (`n · q · PROBE_RAYS` rays) and `2 · n · q` f32
//! of working memory, then about `3 n` candidate joins of `O(q)` each. Deterministic: every
//! parallel step is a map; joins are taken in order of (cost, smaller id, larger id).

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use rustc_hash::FxHashMap;

use glam::DVec3;
use rayon::prelude::*;

use super::{Material, PROBE_RAYS, Probes, view_seed};
use crate::formfactor::point::{point_to_region, point_to_region_sampled};
use crate::geometry::cluster::NORMAL_CONE_DEGREES;
use crate::geometry::{Polygon, Region};
use crate::mesh::Element;
use crate::patches::Patch;

/// Revision of the merge rule: part of the checkpoint key (`checkpoint::key`) and of a shard
/// plan's settings, since a change gives other patches for the same flags.
pub(crate) const REVISION: u32 = 2;

/// Default `--threshold` of the merge rule: the estimated (first-order) relative L2 error of
/// the coarse mesh (module docs). On the Cornell box's default mesh (n = 2 116) it gives
/// k = 167 at a measured relative error of 1.1e-3 against the exact solve (k = 162 at 1.2e-3
/// with the seeds before issue #31), where the split
/// rule's default gave k = 333 at 9.3e-4; against the path tracer the default bake's smooth
/// median and p90 are 1.33% and 4.35% (the split rule's: 1.34%, 4.65%), its bake 1.9× the
/// CPU time of the former default (2MF, unrefined; the split rule's 1.6×; docs/MESHING.md,
/// docs/ACCURACY.md). A smaller threshold buys accuracy against the exact solve with bake
/// time: 5e-5 gives k = 195 at 8.8e-4 in 2.0× the former default's time.
pub const DEFAULT_THRESHOLD: f64 = 7e-5;

/// A bounding cone of normals: every normal is within `angle` (radians) of `axis`.
#[derive(Debug, Clone, Copy)]
struct Cone {
    axis: DVec3,
    angle: f64,
}

impl Cone {
    /// The smallest cone around both (exact for cones; conservative for the normals inside).
    fn union(self, other: Cone) -> Cone {
        let between = self.axis.dot(other.axis).clamp(-1.0, 1.0).acos();
        if between + other.angle <= self.angle {
            return self;
        }
        if between + self.angle <= other.angle {
            return other;
        }
        let angle = (between + self.angle + other.angle) / 2.0;
        if between < 1e-12 {
            return Cone {
                axis: self.axis,
                angle,
            };
        }
        if angle >= std::f64::consts::PI {
            return Cone {
                axis: self.axis,
                angle: std::f64::consts::PI,
            };
        }
        // Rotate `self.axis` towards `other.axis` by `angle − self.angle`.
        let t = (angle - self.angle) / between;
        let (s, a, b) = (between.sin(), (1.0 - t) * between, t * between);
        let axis = (self.axis * a.sin() + other.axis * b.sin()) / s;
        Cone {
            axis: axis.normalize(),
            angle,
        }
    }
}

/// Whether two element polygons touch: a vertex of one within `eps` of an edge of the other.
pub(crate) fn touch(a: &Polygon, b: &Polygon, eps: f64) -> bool {
    let on = |p: DVec3, q: &Polygon| {
        let v = q.vertices();
        (0..v.len()).any(|i| {
            let (s, t) = (v[i], v[(i + 1) % v.len()]);
            let d = t - s;
            let u = ((p - s).dot(d) / d.length_squared()).clamp(0.0, 1.0);
            (s + d * u - p).length_squared() <= eps * eps
        })
    };
    a.vertices().iter().any(|&p| on(p, b)) || b.vertices().iter().any(|&p| on(p, a))
}

/// Whether two elements touch: one of the polygons drawn of one ([`Element::shown`]: a dense
/// mesh's element is its faces, not its proxy) touches one of the other's. Only the polygons
/// within `eps` of the other element's bounding box (`boxes`, as [`neighbours`] has them) are
/// paired: a grouped element's interior faces cannot touch another element.
fn elements_touch(a: &Element, b: &Element, boxes: [(DVec3, DVec3); 2], eps: f64) -> bool {
    let near = |p: &Polygon, (lo, hi): (DVec3, DVec3)| {
        let v = p.vertices();
        let (plo, phi) = v
            .iter()
            .fold((v[0], v[0]), |(l, h), &x| (l.min(x), h.max(x)));
        plo.cmple(hi + eps).all() && phi.cmpge(lo - eps).all()
    };
    let near_b: Vec<&Polygon> = b
        .shown()
        .map(|(_, q)| q)
        .filter(|q| near(q, boxes[0]))
        .collect();
    a.shown()
        .map(|(_, p)| p)
        .filter(|p| near(p, boxes[1]))
        .any(|p| near_b.iter().any(|q| touch(p, q, eps)))
}

/// The bounding box of what is drawn of `e`.
fn element_box(e: &Element) -> (DVec3, DVec3) {
    let v = e.shown().flat_map(|(_, p)| p.vertices().iter().copied());
    v.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), x| {
        (lo.min(x), hi.max(x))
    })
}

/// For every element, the touching elements of the same surface (ascending ids), found
/// through a uniform grid of cells about the size of the larger elements.
fn neighbours(elements: &[Element]) -> Vec<Vec<u32>> {
    let n = elements.len();
    let boxes: Vec<(DVec3, DVec3)> = elements.iter().map(element_box).collect();
    let (lo, hi) = boxes
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), &(a, b)| {
            (l.min(a), h.max(b))
        });
    let extent = (hi - lo).length().max(f64::MIN_POSITIVE);
    let eps = 1e-7 * extent;
    // Cell: the 90th percentile of the elements' largest box side (a few huge elements then
    // span several cells instead of making every cell huge).
    let mut sides: Vec<f64> = boxes.iter().map(|(a, b)| (*b - *a).max_element()).collect();
    sides.sort_by(f64::total_cmp);
    let cell = sides
        .get(sides.len() * 9 / 10)
        .copied()
        .unwrap_or(1.0)
        .max(extent * 1e-6);
    let index = |x: DVec3| ((x - lo) / cell).floor().as_i64vec3();
    let mut grid: FxHashMap<glam::I64Vec3, Vec<u32>> = FxHashMap::default();
    for (e, &(a, b)) in boxes.iter().enumerate() {
        let (i0, i1) = (index(a - eps), index(b + eps));
        for x in i0.x..=i1.x {
            for y in i0.y..=i1.y {
                for z in i0.z..=i1.z {
                    grid.entry(glam::I64Vec3::new(x, y, z))
                        .or_default()
                        .push(e as u32);
                }
            }
        }
    }
    (0..n)
        .into_par_iter()
        .map(|e| {
            let (a, b) = boxes[e];
            let (i0, i1) = (index(a - eps), index(b + eps));
            let mut near = Vec::new();
            for x in i0.x..=i1.x {
                for y in i0.y..=i1.y {
                    for z in i0.z..=i1.z {
                        if let Some(cell) = grid.get(&glam::I64Vec3::new(x, y, z)) {
                            near.extend(cell.iter().copied());
                        }
                    }
                }
            }
            near.sort_unstable();
            near.dedup();
            near.retain(|&o| {
                let o = o as usize;
                o != e
                    && elements[o].surface == elements[e].surface
                    && boxes[o].0.cmple(b + eps).all()
                    && boxes[o].1.cmpge(a - eps).all()
                    && elements_touch(&elements[e], &elements[o], [boxes[e], boxes[o]], eps)
            });
            near
        })
        .collect()
}

/// A patch while merging: its elements, area, `Σ A_e b_e`, normal cone, the per-probe sums
/// `s` and `t` (module docs) and its error.
struct Group {
    members: Vec<u32>,
    area: f64,
    weighted: f64,
    cone: Cone,
    s: Vec<f32>,
    t: Vec<f32>,
    error: f64,
    /// Touching groups (ids, ascending).
    near: Vec<u32>,
}

/// A candidate join, smallest cost first (ties: smaller ids first).
#[derive(Debug, Clone, Copy)]
struct Join {
    cost: f64,
    a: u32,
    b: u32,
    version_a: u32,
    version_b: u32,
}

impl PartialEq for Join {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Join {}
impl PartialOrd for Join {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
/// A join's cost to about 9 significant digits (the low 22 bits of the mantissa cleared): costs
/// that differ only by the rounding of a scaled scene's coordinates order as ties, broken by
/// the ids, so a scene scaled by 1e-3 joins in the same order (a symmetric room's equal
/// joins came out in another order).
fn coarse(cost: f64) -> f64 {
    f64::from_bits(cost.to_bits() & !((1u64 << 22) - 1))
}

impl Ord for Join {
    fn cmp(&self, other: &Self) -> Ordering {
        // Reversed: `BinaryHeap` is a max-heap.
        coarse(other.cost)
            .total_cmp(&coarse(self.cost))
            .then(other.a.cmp(&self.a))
            .then(other.b.cmp(&self.b))
    }
}

/// What the joins see: per-probe weights `c_j ρ_j²` and the cone limit.
struct Ctx {
    weight: Vec<f64>,
    max_angle: f64,
}

impl Ctx {
    fn error(&self, area: f64, weighted: f64, s: &[f32], t: &[f32]) -> f64 {
        let mean = weighted / area;
        s.iter()
            .zip(t)
            .zip(&self.weight)
            .map(|((&s, &t), &w)| w * (s as f64 * mean - t as f64).powi(2))
            .sum()
    }

    /// The error of `a ∪ b` minus theirs, or `None` when the union leaves the normal cone.
    fn cost(&self, a: &Group, b: &Group) -> Option<f64> {
        // Strictly inside the cone: two faces at exactly 90° (a box's edge) are not joined,
        // whatever the rounding of their normals.
        if a.cone.union(b.cone).angle >= self.max_angle * (1.0 - 1e-9) {
            return None;
        }
        let (area, weighted) = (a.area + b.area, a.weighted + b.weighted);
        let mean = weighted / area;
        let mut union = 0.0;
        for j in 0..self.weight.len() {
            let s = a.s[j] as f64 + b.s[j] as f64;
            let t = a.t[j] as f64 + b.t[j] as f64;
            union += self.weight[j] * (s * mean - t).powi(2);
        }
        Some(union - a.error - b.error)
    }
}

/// Merges the elements into patches under `threshold` (the estimated relative L2 error) and
/// returns them, with `elements[..].patch` set. Patches are numbered by their smallest
/// element id; a patch's parts are its elements' polygons in id order.
pub(crate) fn merge(
    elements: &mut [Element],
    materials: &[Material],
    threshold: f64,
    probes: &Probes,
) -> Vec<Patch> {
    let n = elements.len();
    let q = probes.targets.len();
    let probe_area: Vec<f64> = probes.targets.iter().map(Region::area).collect();
    let ctx = Ctx {
        weight: (0..q)
            .map(|j| probes.elements[j] * probes.reflectance[j].powi(2))
            .collect(),
        max_angle: NORMAL_CONE_DEGREES.to_radians(),
    };
    // Each element's view of the probes and its gathered radiosity.
    let far = FarField::of(probes);
    let views: Vec<(Vec<f32>, f64)> = elements
        .par_iter()
        .zip(materials)
        .map(|(e, m)| {
            let mut f = vec![0.0; q];
            // Seen from the surface: an element lit on its parts is seen from its largest
            // part, not from its proxy (which may stand under a box while its parts do not,
            // or the other way round).
            let x = e.on_surface().centroid();
            far.view(probes, x, e.polygon.normal, &mut f);
            let gathered: f64 = f.iter().zip(&probes.radiosity).map(|(f, b)| f * b).sum();
            let direct = probes.direct(m.reflectance, x, e.polygon.normal);
            let b = m.emission + direct + m.reflectance * gathered;
            let a = e.polygon.area();
            let s = f
                .iter()
                .zip(&probe_area)
                .map(|(f, pa)| (a * f / pa) as f32)
                .collect();
            (s, b)
        })
        .collect();
    let norm: f64 = views.iter().map(|(_, b)| b * b).sum();
    let budget = threshold * threshold * norm;
    let near = neighbours(elements);
    let mut groups: Vec<Option<Group>> = views
        .into_par_iter()
        .zip(near)
        .enumerate()
        .map(|(e, ((s, b), near))| {
            let polygon = &elements[e].polygon;
            let area = polygon.area();
            let t = s.iter().map(|&s| s * b as f32).collect();
            Some(Group {
                members: vec![e as u32],
                area,
                weighted: area * b,
                cone: Cone {
                    axis: polygon.normal,
                    angle: 0.0,
                },
                s,
                t,
                error: 0.0,
                near,
            })
        })
        .collect();
    // The single elements' errors are 0 up to the f32 rounding of `t`; start from theirs.
    groups.par_iter_mut().for_each(|g| {
        let g = g.as_mut().expect("every element is a group");
        g.error = ctx.error(g.area, g.weighted, &g.s, &g.t);
    });
    let mut version = vec![0u32; n];
    let pairs: Vec<(u32, u32)> = groups
        .iter()
        .enumerate()
        .flat_map(|(a, g)| {
            let near = &g.as_ref().expect("group").near;
            near.iter()
                .filter(move |&&b| b as usize > a)
                .map(move |&b| (a as u32, b))
        })
        .collect();
    let mut heap: BinaryHeap<Join> = pairs
        .par_iter()
        .filter_map(|&(a, b)| {
            ctx.cost(group(&groups, a), group(&groups, b))
                .map(|cost| Join {
                    cost,
                    a,
                    b,
                    version_a: 0,
                    version_b: 0,
                })
        })
        .collect::<Vec<_>>()
        .into();
    let mut total: f64 = groups.iter().flatten().map(|g| g.error).sum();
    while let Some(join) = heap.pop() {
        let (a, b) = (join.a as usize, join.b as usize);
        if version[a] != join.version_a
            || version[b] != join.version_b
            || groups[a].is_none()
            || groups[b].is_none()
        {
            continue; // stale
        }
        if total + join.cost > budget {
            break;
        }
        total += join.cost;
        let gb = groups[b].take().expect("live");
        let ga = groups[a].as_mut().expect("live");
        ga.members.extend(gb.members);
        ga.area += gb.area;
        ga.weighted += gb.weighted;
        ga.cone = ga.cone.union(gb.cone);
        for (x, y) in ga.s.iter_mut().zip(&gb.s) {
            *x += y;
        }
        for (x, y) in ga.t.iter_mut().zip(&gb.t) {
            *x += y;
        }
        ga.error = ctx.error(ga.area, ga.weighted, &ga.s, &ga.t);
        let mut near: Vec<u32> = ga.near.iter().chain(&gb.near).copied().collect();
        near.sort_unstable();
        near.dedup();
        near.retain(|&x| x as usize != a && x as usize != b);
        ga.near = near.clone();
        version[a] += 1;
        version[b] += 1;
        // `b` is gone: its neighbours now touch `a`.
        for &x in &near {
            let g = groups[x as usize].as_mut().expect("live neighbour");
            g.near.retain(|&y| y as usize != b);
            if let Err(at) = g.near.binary_search(&(a as u32)) {
                g.near.insert(at, a as u32);
            }
        }
        let ga = group(&groups, a as u32);
        let joins: Vec<Join> = near
            .par_iter()
            .filter_map(|&x| {
                ctx.cost(ga, group(&groups, x)).map(|cost| {
                    let (lo, hi) = (x.min(a as u32), x.max(a as u32));
                    Join {
                        cost,
                        a: lo,
                        b: hi,
                        version_a: version[lo as usize],
                        version_b: version[hi as usize],
                    }
                })
            })
            .collect();
        heap.extend(joins);
    }
    // Number the patches by their smallest element id (the group's id is its smallest).
    let mut patches = Vec::new();
    for g in groups.into_iter().flatten() {
        let mut members = g.members;
        members.sort_unstable();
        let id = patches.len() as u32;
        let first = &elements[members[0] as usize];
        let (face, surface) = (first.face, first.surface);
        let parts: Vec<Polygon> = members
            .iter()
            .map(|&e| elements[e as usize].polygon)
            .collect();
        for &e in &members {
            elements[e as usize].patch = id;
        }
        patches.push(Patch {
            shape: Region::new(parts),
            face,
            surface,
        });
    }
    patches
}

/// How far a point must be from a clustered probe, in the probe's radii, for its view of it to
/// be sampled instead of integrated in closed form.
const FAR_RADII: f64 = 3.0;

/// The probes of several parts (clusters of a dense mesh), by centroid and radius: an
/// element's view of one is the closed form over every part near it and a sampled estimate
/// (`point_to_region_sampled`, as many points as rays) beyond [`FAR_RADII`] radii. The closed
/// form from every element to every part would cost `n ×` the dense mesh's faces (10¹⁰ for
/// `lrr scene dense`); single-polygon probes keep it (the Cornell box's views are exact).
struct FarField(Vec<Option<(DVec3, f64)>>);

impl FarField {
    fn of(probes: &Probes) -> Self {
        Self(
            probes
                .targets
                .iter()
                .map(|t| {
                    (t.parts().len() > 1).then(|| {
                        let c = t.centroid();
                        let r = t
                            .parts()
                            .iter()
                            .flat_map(|p| p.vertices())
                            .map(|v| v.distance(c))
                            .fold(0.0, f64::max);
                        (c, r)
                    })
                })
                .collect(),
        )
    }

    /// The view of every probe from `x` (as `coherence::view`, the same rays).
    fn view(&self, probes: &Probes, x: DVec3, normal: DVec3, out: &mut [f64]) {
        let seed = view_seed(&probes.frame, x);
        for (j, (target, out)) in probes.targets.iter().zip(out.iter_mut()).enumerate() {
            let seed = seed ^ j as u64;
            let occ = probes.occluder;
            *out = match self.0[j] {
                Some((c, r)) if x.distance(c) > FAR_RADII * r => {
                    point_to_region_sampled(x, normal, target, occ, PROBE_RAYS, seed)
                }
                _ => point_to_region(x, normal, target, occ, PROBE_RAYS, seed),
            };
        }
    }
}

/// A live group.
fn group(groups: &[Option<Group>], i: u32) -> &Group {
    groups[i as usize].as_ref().expect("a live group")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::MeshSizes;
    use crate::patches::{CoherenceRule, Mesh, PatchMethod};
    use crate::scene::{Scene, procedural};
    use crate::visibility::obvhs::ObvhsOccluder;
    use std::path::Path;

    use super::super::tests::cornell;

    fn merged(scene: &Scene, sizes: MeshSizes, threshold: f64) -> Mesh {
        let occ = ObvhsOccluder::build(scene);
        let method = PatchMethod::SpatialCoherence {
            threshold,
            min_patch_area: None,
            rule: CoherenceRule::Merge,
        };
        Mesh::build(scene, sizes, method, Some(&occ)).unwrap()
    }

    /// The joins come in one order whatever the threshold, which only says where to stop: a
    /// smaller threshold never gives fewer patches, and every patch is a connected set of
    /// touching elements of one surface within the normal cone (`validate` checks the rest:
    /// one surface, inclusion, weights).
    #[test]
    fn smaller_threshold_never_gives_fewer_patches() {
        let scene = cornell();
        let sizes = MeshSizes::resolve(&scene, Some(96.074), None).unwrap();
        let fixed = Mesh::two_fixed(&scene, sizes).unwrap();
        let mut last = 0;
        for t in [1e-2, 1e-3, 1e-4, 1e-5] {
            let mesh = merged(&scene, sizes, t);
            mesh.validate().unwrap();
            assert_eq!(mesh.n(), fixed.n());
            println!("threshold {t}: k = {} of n = {}", mesh.k(), mesh.n());
            assert!(mesh.k() > last, "threshold {t}: k = {} <= {last}", mesh.k());
            last = mesh.k();
            for p in &mesh.patches {
                let parts = p.shape.parts();
                // Within a cone of 45°: no two normals more than 90° apart.
                for a in parts {
                    assert!(parts.iter().all(|b| a.normal.dot(b.normal) > 0.0));
                }
                // Connected: a walk over touching parts reaches every part.
                let eps = 1e-7 * scene.extent();
                let mut seen = vec![false; parts.len()];
                let mut stack = vec![0];
                seen[0] = true;
                while let Some(a) = stack.pop() {
                    for b in 0..parts.len() {
                        if !seen[b] && touch(&parts[a], &parts[b], eps) {
                            seen[b] = true;
                            stack.push(b);
                        }
                    }
                }
                assert!(
                    seen.iter().all(|&s| s),
                    "a patch of {} parts is not connected",
                    parts.len()
                );
            }
        }
        assert!(last < fixed.n(), "k = {last}");
    }

    /// Toward a zero threshold nothing is joined but what the estimate finds exact (elements of
    /// equal estimated radiosity that nothing reflects: the light): `k` ends near `n`, where
    /// the low-rank solve is the exact one.
    #[test]
    fn tiny_thresholds_keep_single_elements() {
        let scene = cornell();
        let sizes = MeshSizes::resolve(&scene, Some(96.074), None).unwrap();
        let mesh = merged(&scene, sizes, 1e-12);
        mesh.validate().unwrap();
        println!("k = {} of n = {}", mesh.k(), mesh.n());
        assert!(
            mesh.k() as f64 >= 0.95 * mesh.n() as f64,
            "k = {}",
            mesh.k()
        );
    }

    /// The neighbours found through the grid are exactly the touching pairs of one surface
    /// (checked against all pairs), on a mesh with T-junctions (the dense sphere's room).
    #[test]
    fn neighbours_are_the_touching_elements() {
        for scene in [
            cornell(),
            procedural::dense_sphere(2)
                .build("d", Path::new("."))
                .unwrap(),
        ] {
            let sizes = MeshSizes::resolve(&scene, None, None).unwrap();
            let mesh = Mesh::two_fixed(&scene, sizes).unwrap();
            let near = neighbours(&mesh.elements);
            let eps = 1e-7 * scene.extent();
            let e = &mesh.elements;
            let mut pairs = 0;
            for a in 0..e.len() {
                let all: Vec<u32> = (0..e.len())
                    .filter(|&b| {
                        b != a
                            && e[b].surface == e[a].surface
                            && elements_touch(
                                &e[a],
                                &e[b],
                                [element_box(&e[a]), element_box(&e[b])],
                                eps,
                            )
                    })
                    .map(|b| b as u32)
                    .collect();
                assert_eq!(near[a], all, "element {a}");
                pairs += all.len();
            }
            assert!(
                pairs >= 2 * e.len(),
                "{pairs} neighbour pairs for {} elements",
                e.len()
            );
        }
    }

    #[test]
    fn cones_bound_their_normals() {
        let a = Cone {
            axis: DVec3::Z,
            angle: 0.0,
        };
        let b = Cone {
            axis: DVec3::X,
            angle: 0.0,
        };
        let u = a.union(b);
        assert!((u.angle - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        assert!((u.axis - DVec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-12);
        // A cone inside another is absorbed; the union of a cone with itself is itself.
        assert_eq!(u.union(a).angle, u.angle);
        let c = u.union(u);
        assert!((c.angle - u.angle).abs() < 1e-12);
        let d = u.union(Cone {
            axis: -DVec3::Z,
            angle: 0.0,
        });
        assert!((d.angle - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!(d.axis.dot(DVec3::X) > 1.0 - 1e-12);
    }
}
