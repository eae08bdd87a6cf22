//! Groups of an occluder's triangles that the rays leaving a polygon cannot meet: the
//! [`Clear`] hint of [`Occluder::clear_of`](super::Occluder::clear_of).
//!
//! A group is a connected piece of the occluder (triangles joined by shared corners) of at
//! least [`MIN_TRIANGLES`] triangles: a sphere, a box, a column. Every point of it lies at or
//! below its support plane in any direction `n`, `n · x ≤ h(n)` with `h(n)` the largest
//! `n · v` over its corners. A segment from a point `p` of a polygon with normal `n` whose
//! every corner is at or above that plane (`min n · v ≥ h(n)`, the polygon's *clearance*
//! `min n · v − h(n)` ≥ 0), going to the polygon's front (`n · d = s > 0`), rises above the
//! plane from its start: at `t` it is `clearance + t·s` above it, so over the part of the
//! segment the exact test looks at (`t ≥ ε`, `SEGMENT_EPSILON` of its length) it stays
//! `clearance + ε·s` above the group, and nothing of the group can block it. The same holds at
//! the segment's end, which arrives at the target's front.
//!
//! What this is for: a polygon of a convex group (its face, or the planar proxy of a dense
//! mesh's grouped faces, which stands on their highest corner) has a clearance of 0 against
//! its own group, up to rounding. Its rays start among the group's triangles, so without the
//! hint a traversal enters the nodes around the start point on every level and tests the
//! triangles there (the 20 480-triangle sphere's rays cost about twice the 80-triangle
//! sphere's, docs/PERFORMANCE.md). With it the BVH's children whose triangles are all of that
//! group ([`FlatBvh::tag`](super::flat::FlatBvh::tag)) are not entered. The answers are the
//! same: a group is skipped only where `clearance + ε·s` exceeds a margin far above the
//! rounding of the terms (`MARGIN`, relative to the scene's diagonal).

use glam::DVec3;
use rayon::prelude::*;
use rustc_hash::FxHashMap;

use super::flat::NO_GROUP;
use super::occluder::Clear;
use crate::geometry::Polygon;
use crate::geometry::boxes::{BoxGrid, overlaps};

/// Fewest triangles a group has: smaller pieces cost a traversal little (a box's 12
/// triangles sit in one or two nodes).
const MIN_TRIANGLES: usize = 16;

/// Most groups: tags are `u16`, 0 is [`NO_GROUP`] and `u16::MAX` is [`NO_SKIP`](super::occluder::NO_SKIP).
const MAX_GROUPS: usize = u16::MAX as usize - 1;

/// Corners per leaf of a group's corner tree.
const LEAF: usize = 8;

/// The distance, relative to the scene's diagonal, a segment must keep above a group's
/// support plane for the group to be skipped: about 10⁴ times the rounding of the dot
/// products that place the segment and the group against the plane.
pub(super) const MARGIN: f64 = 1e-12;

/// The groups of one occluder.
pub(super) struct Groups {
    /// Each primitive's group tag, in the BVH's primitive order ([`NO_GROUP`]: none).
    pub(super) tags: Vec<u16>,
    /// Group `g`'s balls when it is a closed convex surface (tag `g + 1`).
    pub(super) balls: Vec<Option<Ball>>,
    /// Group `g`'s corners (tag `g + 1`).
    hulls: Vec<Corners>,
    /// The groups' bounding boxes, indexed.
    grid: BoxGrid,
    boxes: Vec<(DVec3, DVec3)>,
}

impl Groups {
    /// The groups of `triangles` (coordinates relative to the occluder's centre, in the BVH's
    /// primitive order): connected pieces of at least [`MIN_TRIANGLES`], numbered in the order
    /// of their first triangle. Corners are shared when their coordinates are bit for bit the
    /// same.
    pub(super) fn of(triangles: &[[DVec3; 3]]) -> Self {
        // Corners by their bits, then the pieces by union-find over the corners.
        let key = |v: DVec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
        let mut id: FxHashMap<[u64; 3], u32> = FxHashMap::default();
        let mut position: Vec<DVec3> = Vec::new();
        let corners: Vec<[u32; 3]> = (triangles.iter())
            .map(|t| {
                t.map(|v| {
                    *id.entry(key(v)).or_insert_with(|| {
                        position.push(v);
                        position.len() as u32 - 1
                    })
                })
            })
            .collect();
        drop(id);
        let mut parent: Vec<u32> = (0..position.len() as u32).collect();
        for [a, b, c] in &corners {
            union(&mut parent, *a, *b);
            union(&mut parent, *a, *c);
        }
        let mut size = vec![0u32; position.len()];
        for [a, _, _] in &corners {
            size[find(&mut parent, *a) as usize] += 1;
        }
        // Tags in the order of the groups' first triangles.
        let mut tag_of_root = vec![NO_GROUP; position.len()];
        let mut groups = 0usize;
        let mut tags = vec![NO_GROUP; triangles.len()];
        let mut members: Vec<Vec<[u32; 3]>> = Vec::new();
        for (i, t) in corners.iter().enumerate() {
            let root = find(&mut parent, t[0]) as usize;
            if (size[root] as usize) < MIN_TRIANGLES {
                continue;
            }
            if tag_of_root[root] == NO_GROUP {
                if groups == MAX_GROUPS {
                    continue;
                }
                groups += 1;
                tag_of_root[root] = groups as u16;
                members.push(Vec::new());
            }
            tags[i] = tag_of_root[root];
            members[tags[i] as usize - 1].push(*t);
        }
        let mut points: Vec<Vec<DVec3>> = vec![Vec::new(); groups];
        for (i, p) in position.iter().enumerate() {
            let tag = tag_of_root[find(&mut parent, i as u32) as usize];
            if tag != NO_GROUP {
                points[tag as usize - 1].push(*p);
            }
        }
        let hulls: Vec<Corners> = points.into_iter().map(Corners::new).collect();
        let boxes: Vec<(DVec3, DVec3)> = hulls.iter().map(|h| h.bounds()).collect();
        let balls = (members.par_iter().zip(&hulls))
            .map(|(m, h)| Ball::of(m, &position, h))
            .collect();
        Self {
            tags,
            balls,
            grid: BoxGrid::new(&boxes),
            boxes,
            hulls,
        }
    }

    /// Number of groups.
    pub(super) fn len(&self) -> usize {
        self.hulls.len()
    }

    /// The group near polygon `p` (coordinates relative to the occluder's centre, `centre`
    /// subtracted here) with the largest clearance ([module docs](self)), when it is at
    /// least `-margin`; otherwise [`Clear::NONE`].
    pub(super) fn clear_of(&self, p: &Polygon, centre: DVec3, margin: f64) -> Clear {
        let n = p.normal;
        if self.hulls.is_empty() || !n.is_finite() {
            return Clear::NONE;
        }
        let vertices = p.vertices();
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        let mut low = f64::INFINITY;
        for v in vertices {
            let v = *v - centre;
            lo = lo.min(v);
            hi = hi.max(v);
            low = low.min(n.dot(v));
        }
        // The groups within the polygon's size of it: its own (a proxy stands a little in
        // front of its faces), the ones it touches.
        let reach = DVec3::splat((hi - lo).length());
        let query = (lo - reach, hi + reach);
        if !(query.0.is_finite() && query.1.is_finite() && low.is_finite()) {
            return Clear::NONE;
        }
        let mut best = Clear::NONE;
        for g in self.grid.candidates(query) {
            let g = g as usize;
            if !overlaps(query, self.boxes[g]) {
                continue;
            }
            let clearance = low - self.hulls[g].support(n);
            if clearance >= -margin && clearance > best.clearance {
                best = Clear {
                    group: g as u16 + 1,
                    clearance,
                };
            }
        }
        best
    }
}

/// Two balls of a group that is a closed, consistently oriented surface (each edge used once
/// each way), about the mean of its corners: the outer one holds every corner; the inner one
/// meets no triangle's plane, and the centre lies inside the surface (its winding number is
/// not 0). A sphere, a box, a column: any closed surface whose centre sees every plane at a
/// distance.
///
/// - A segment that keeps out of the outer ball cannot meet the group.
/// - A segment whose ends lie outside the outer ball and that passes through the inner ball
///   goes from where the winding number is 0 to where it is not (the inner ball meets no
///   triangle, so all of it has the centre's): it crosses the surface, through a triangle
///   (or an edge or corner between triangles, which the watertight exact test does not let
///   through), away from its ends. Neither end lies in that triangle's plane, which would
///   hold the whole segment and so a point of the inner ball (up to the own-face rule's
///   tolerance, which `BALL_CLEARANCE` in `obvhs` bounds): the exact test finds it blocking.
///
/// A sphere tessellated finely has balls a hair apart, so the rays that cross it are answered
/// without a descent through its thousands of triangles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Ball {
    pub(super) centre: DVec3,
    pub(super) inner: f64,
    pub(super) outer: f64,
}

impl Ball {
    /// The balls of the group of `triangles` (corner indices into `position`) with corners
    /// `corners`, when it is a closed surface about its centre (above).
    fn of(triangles: &[[u32; 3]], position: &[DVec3], corners: &Corners) -> Option<Self> {
        // Closed and consistently oriented: each edge used once each way.
        let mut edges: Vec<(u32, u32, bool)> = Vec::with_capacity(3 * triangles.len());
        for &[a, b, c] in triangles {
            for (u, v) in [(a, b), (b, c), (c, a)] {
                if u == v {
                    return None;
                }
                edges.push((u.min(v), u.max(v), u < v));
            }
        }
        edges.sort_unstable();
        let paired = edges
            .chunks(2)
            .all(|pair| matches!(pair, [x, y] if (x.0, x.1) == (y.0, y.1) && x.2 != y.2));
        if !paired {
            return None;
        }
        drop(edges);
        let points = &corners.points;
        let centre = points.iter().sum::<DVec3>() / points.len() as f64;
        let outer = points
            .iter()
            .map(|p| p.distance(centre))
            .fold(0.0, f64::max);
        let (inner, solid) = triangles
            .par_iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| position[i as usize] - centre);
                let n = (b - a).cross(c - a).normalize_or_zero();
                let plane = if n == DVec3::ZERO {
                    f64::INFINITY // a degenerate triangle has no plane, and no area
                } else {
                    n.dot(a).abs()
                };
                // The solid angle the triangle subtends at the centre (Van Oosterom and
                // Strackee), signed by its orientation.
                let (la, lb, lc) = (a.length(), b.length(), c.length());
                let below = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
                (plane, 2.0 * a.dot(b.cross(c)).atan2(below))
            })
            .reduce(|| (f64::INFINITY, 0.0), |x, y| (x.0.min(y.0), x.1 + y.1));
        let winding = solid / (4.0 * std::f64::consts::PI);
        let inside = (winding.abs() - 1.0).abs() < 0.25;
        (inside && inner > 0.0 && inner.is_finite() && outer.is_finite()).then_some(Self {
            centre,
            inner,
            outer,
        })
    }
}

/// The root of `i`'s set (with path halving).
fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        parent[i as usize] = parent[parent[i as usize] as usize];
        i = parent[i as usize];
    }
    i
}

/// Joins the sets of `a` and `b` (the smaller root under the larger: deterministic).
fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        let (lo, hi) = (ra.min(rb), ra.max(rb));
        parent[hi as usize] = lo;
    }
}

/// A group's corners in a tree of boxes, for its support function.
struct Corners {
    points: Vec<DVec3>,
    nodes: Vec<CornerNode>,
}

/// A node of [`Corners`]: its box and its corners `points[start..end]`; an inner node's first
/// child follows it, `right` is its second.
struct CornerNode {
    lo: DVec3,
    hi: DVec3,
    start: u32,
    end: u32,
    right: u32,
}

impl Corners {
    fn new(mut points: Vec<DVec3>) -> Self {
        points.sort_unstable_by(|a, b| {
            (a.x.to_bits(), a.y.to_bits(), a.z.to_bits()).cmp(&(
                b.x.to_bits(),
                b.y.to_bits(),
                b.z.to_bits(),
            ))
        });
        points.dedup();
        let mut nodes = Vec::with_capacity(2 * points.len().div_ceil(LEAF));
        let count = points.len();
        build(&mut points, 0, count, &mut nodes);
        Self { points, nodes }
    }

    fn bounds(&self) -> (DVec3, DVec3) {
        self.nodes
            .first()
            .map_or((DVec3::ZERO, DVec3::ZERO), |n| (n.lo, n.hi))
    }

    /// The largest `n · v` over the corners (branch and bound: a node whose box cannot beat
    /// the best so far is not opened).
    fn support(&self, n: DVec3) -> f64 {
        let best = std::cell::Cell::new(f64::NEG_INFINITY);
        self.search(
            n,
            |bound| bound <= best.get(),
            |value| {
                best.set(best.get().max(value));
                false
            },
        );
        best.get()
    }

    /// Visits the corners by their nodes, the more promising child first, skipping the nodes
    /// whose bound on `n · v` `prune` says cannot matter, until `found` says yes of a corner's
    /// `n · v`; returns whether it did.
    fn search(
        &self,
        n: DVec3,
        mut prune: impl FnMut(f64) -> bool,
        mut found: impl FnMut(f64) -> bool,
    ) -> bool {
        let bound = |node: &CornerNode| (n * node.lo).max(n * node.hi).element_sum();
        let Some(root) = self.nodes.first() else {
            return false;
        };
        // Depth is at most log2 of the corners (median splits): two entries a level. Each
        // entry keeps its node's bound.
        let mut stack = [(0u32, 0f64); 2 * 64];
        stack[0] = (0, bound(root));
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let (i, b) = stack[top];
            if prune(b) {
                continue;
            }
            let node = &self.nodes[i as usize];
            if node.right == 0 {
                for p in &self.points[node.start as usize..node.end as usize] {
                    if found(n.dot(*p)) {
                        return true;
                    }
                }
                continue;
            }
            let (left, right) = (i + 1, node.right);
            let (bl, br) = (
                bound(&self.nodes[left as usize]),
                bound(&self.nodes[right as usize]),
            );
            let (first, second) = if bl > br {
                ((left, bl), (right, br))
            } else {
                ((right, br), (left, bl))
            };
            stack[top] = second;
            stack[top + 1] = first;
            top += 2;
        }
        false
    }
}

/// Appends the node over `points[start..end]` and its subtree (preorder); returns its index.
fn build(points: &mut [DVec3], start: usize, end: usize, nodes: &mut Vec<CornerNode>) -> u32 {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for p in &points[start..end] {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let at = nodes.len();
    nodes.push(CornerNode {
        lo,
        hi,
        start: start as u32,
        end: end as u32,
        right: 0,
    });
    if end - start > LEAF {
        let axis = (hi - lo).max_position();
        let mid = start + (end - start) / 2;
        points[start..end].select_nth_unstable_by(mid - start, |a, b| a[axis].total_cmp(&b[axis]));
        build(points, start, mid, nodes);
        let right = build(points, mid, end, nodes);
        nodes[at].right = right;
    }
    at as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The triangles of an icosphere of radius 1 about `c`, subdivided `levels` times.
    fn sphere(c: DVec3, levels: u32) -> Vec<[DVec3; 3]> {
        let polygons = crate::scene::procedural::icosphere(levels, c.to_array(), 1.0);
        polygons
            .iter()
            .map(|p| [0, 1, 2].map(|i| DVec3::from_array(p[i])))
            .collect()
    }

    #[test]
    fn the_support_is_the_largest_corner_whatever_the_direction() {
        let tris = sphere(DVec3::new(0.3, -2.0, 5.0), 3);
        let corners: Vec<DVec3> = tris.iter().flatten().copied().collect();
        let tree = Corners::new(corners.clone());
        let mut state = 9u64;
        for _ in 0..500 {
            let mut next = || {
                state = crate::geometry::hash::mix(state);
                (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            };
            let n = DVec3::new(next(), next(), next()).normalize();
            let brute = corners
                .iter()
                .map(|c| n.dot(*c))
                .fold(f64::NEG_INFINITY, f64::max);
            assert_eq!(tree.support(n), brute);
        }
    }

    #[test]
    fn a_sphere_is_one_group_and_its_faces_clear_it() {
        let centre = DVec3::new(1.0, 2.0, 3.0);
        let mut tris = sphere(centre, 2); // 320 triangles
        let floor = [
            [
                DVec3::new(-5.0, -1.5, -5.0),
                DVec3::new(5.0, -1.5, -5.0),
                DVec3::new(5.0, -1.5, 5.0),
            ],
            [
                DVec3::new(-5.0, -1.5, -5.0),
                DVec3::new(5.0, -1.5, 5.0),
                DVec3::new(-5.0, -1.5, 5.0),
            ],
        ];
        tris.extend(floor);
        let groups = Groups::of(&tris);
        assert_eq!(
            groups.len(),
            1,
            "the floor's two triangles are too few to be a group"
        );
        assert!(groups.tags[..320].iter().all(|&t| t == 1));
        assert_eq!(groups.tags[320..], [NO_GROUP, NO_GROUP]);
        let margin = 1e-12 * 20.0;
        for t in &tris[..320] {
            // Each face, oriented outwards, clears the sphere (up to rounding).
            let p = Polygon::new(&[t[0], t[1], t[2]]).unwrap();
            let outward = p.normal.dot(p.centroid() - centre) > 0.0;
            let p = if outward {
                p
            } else {
                Polygon::new(&[t[0], t[2], t[1]]).unwrap()
            };
            let c = groups.clear_of(&p, DVec3::ZERO, margin);
            assert_eq!(c.group, 1);
            assert!(c.clearance.abs() <= margin, "{}", c.clearance);
            // Turned inwards it does not.
            let q = Polygon::new(&[p.vertices()[0], p.vertices()[2], p.vertices()[1]]).unwrap();
            assert_eq!(groups.clear_of(&q, DVec3::ZERO, margin), Clear::NONE);
        }
        // A plane just below the sphere's top, facing up, does not clear it; one above it does.
        let top = centre.y + 1.0;
        let square = |y: f64| {
            Polygon::new(&[
                DVec3::new(0.9, y, 2.9),
                DVec3::new(1.1, y, 2.9),
                DVec3::new(1.1, y, 3.1),
                DVec3::new(0.9, y, 3.1),
            ])
            .unwrap()
        };
        let (below, above) = (square(top - 1e-3), square(top + 1e-3));
        let up = |p: Polygon| {
            if p.normal.y > 0.0 {
                p
            } else {
                let mut v = p.vertices().to_vec();
                v.reverse();
                Polygon::new(&v).unwrap()
            }
        };
        assert_eq!(
            groups.clear_of(&up(below), DVec3::ZERO, margin),
            Clear::NONE
        );
        let c = groups.clear_of(&up(above), DVec3::ZERO, margin);
        assert_eq!(c.group, 1);
        assert!((c.clearance - 1e-3).abs() < 1e-9, "{}", c.clearance);
    }
}
