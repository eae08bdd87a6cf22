//! Groups of an occluder's triangles, and what a traversal can know of them without testing
//! their triangles.
//!
//! A group is a connected piece of the occluder (triangles joined by shared corners) of at
//! least [`MIN_TRIANGLES`] triangles: a sphere, a box, a column. The 4-wide BVH tags each
//! child whose triangles are all of one group (`FlatBvh::tag`), and the traversal asks the
//! occluder whether to enter it.
//!
//! - **Balls** ([`Ball`]): a closed group about its centre answers the segments that keep out
//!   of its outer ball (not entered) and the ones through its inner ball (blocked) without a
//!   descent. This is what makes a finely tessellated sphere's rays as cheap as a coarse
//!   one's: a third of the 256× dense sphere's rays cross it, and each descended about seven
//!   levels of its 20 480 triangles to find the face it hits (docs/PERFORMANCE.md).
//! - **Hints** ([`Clear`], [`Occluder::clear_of`](super::Occluder::clear_of)): every point
//!   of a group lies at or below its support plane in any direction `n`, `n · x ≤ h(n)` with
//!   `h(n)` the largest `n · v` over its corners. A segment from a point `p` of a polygon with
//!   normal `n` whose every corner is at or above that plane (`min n · v ≥ h(n)`, the
//!   polygon's *clearance* `min n · v − h(n)` ≥ 0), going to the polygon's front
//!   (`n · d = s > 0`), is `clearance + t·s` above the plane at `t`, so over the part of the
//!   segment the exact test looks at (`t ≥ ε`, `SEGMENT_EPSILON` of its length) it stays
//!   `clearance + ε·s` above the group, and nothing of the group can block it; the same at the
//!   segment's end, which arrives at the target's front. A face of a convex group, or the
//!   planar proxy of a dense mesh's grouped faces (which stands on their highest corner), has
//!   a clearance of 0 against its own group, up to rounding: its rays skip the group where
//!   `clearance + ε·s` exceeds [`MARGIN`]. Only about 5 % of the 256× sphere's rays start
//!   or end on it; the hints' own gain was not measured apart from the balls'.
//!
//! Both give the answers the triangles give (`obvhs`' unit tests hold them to it), so bakes
//! are the same bytes with them.

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

/// The distance, relative to the scene's size (its diagonal plus its largest coordinate: the
/// sample points are rounded in world coordinates), a segment must keep above a group's
/// support plane for the group to be skipped, and the distance from a ball's surface the
/// balls leave to the triangles: about 10⁴ times the rounding of the dot products that place
/// them.
pub(super) const MARGIN: f64 = 1e-12;

/// The groups of one occluder.
pub(super) struct Groups {
    /// Group `g`'s balls when it is a closed surface about its centre (tag `g + 1`).
    pub(super) balls: Vec<Option<Ball>>,
    /// Group `g`'s corners (tag `g + 1`).
    hulls: Vec<Corners>,
    /// The groups' bounding boxes, indexed.
    grid: BoxGrid,
    boxes: Vec<(DVec3, DVec3)>,
}

impl Groups {
    /// The groups of `triangles` (coordinates relative to the occluder's centre, in the BVH's
    /// primitive order, with their `planes` as the own-face rule takes them): connected
    /// pieces of at least [`MIN_TRIANGLES`], numbered in the order of their first triangle,
    /// and each triangle's tag ([`NO_GROUP`]: none). Corners are shared when their
    /// coordinates are bit for bit the same.
    pub(super) fn of(triangles: &[[DVec3; 3]], planes: &[(DVec3, f64)]) -> (Self, Vec<u16>) {
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
        let mut members: Vec<Vec<u32>> = Vec::new();
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
            members[tags[i] as usize - 1].push(i as u32);
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
            .map(|(m, h)| {
                let triangles: Vec<([u32; 3], (DVec3, f64))> = m
                    .iter()
                    .map(|&i| (corners[i as usize], planes[i as usize]))
                    .collect();
                Ball::of(&triangles, &position, h)
            })
            .collect();
        let groups = Self {
            balls,
            grid: BoxGrid::new(&boxes),
            boxes,
            hulls,
        };
        (groups, tags)
    }

    /// Number of groups.
    pub(super) fn len(&self) -> usize {
        self.hulls.len()
    }

    /// The group polygon `p` stands on or above (coordinates relative to the occluder's
    /// centre, `centre` subtracted here): among the groups near it whose support plane along
    /// `p`'s normal its lowest corner is at most `margin` below ([module docs](self)), the one
    /// it stands nearest (its own, which its rays start among); otherwise [`Clear::NONE`].
    pub(super) fn clear_of(&self, p: &Polygon, centre: DVec3, margin: f64) -> Clear {
        let n = p.normal;
        if self.hulls.is_empty() || !n.is_finite() {
            return Clear::NONE;
        }
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for v in p.vertices() {
            lo = lo.min(*v - centre);
            hi = hi.max(*v - centre);
        }
        let low = lowest(p, centre);
        // The groups within the polygon's size of it: its own (a proxy stands a little in
        // front of its faces), the ones it touches.
        let reach = DVec3::splat((hi - lo).length());
        let query = (lo - reach, hi + reach);
        if !(query.0.is_finite() && query.1.is_finite() && low.is_finite()) {
            return Clear::NONE;
        }
        let mut candidates = self.grid.candidates(query);
        candidates.sort_unstable();
        candidates.dedup();
        let mut best = (Clear::NONE, f64::INFINITY);
        for g in candidates {
            let g = g as usize;
            if !overlaps(query, self.boxes[g]) {
                continue;
            }
            let support = self.hulls[g].support(n);
            let clearance = low - support;
            if clearance >= -margin && clearance < best.1 {
                let clear = Clear {
                    group: g as u16 + 1,
                    normal: n,
                    support,
                };
                best = (clear, clearance);
            }
        }
        best.0
    }
}

/// The least `p.normal · (v - centre)` over `p`'s corners: where `p` stands along its normal.
pub(super) fn lowest(p: &Polygon, centre: DVec3) -> f64 {
    (p.vertices().iter())
        .map(|v| p.normal.dot(*v - centre))
        .fold(f64::INFINITY, f64::min)
}

/// Two balls of a group that is a closed, consistently oriented surface (each edge used once
/// each way), about the mean of its corners, when the centre lies inside the surface (its
/// winding number is ±1): the outer one holds every corner; the inner one meets no plane of
/// its triangles (nor so any triangle). A sphere, a box, a column: any closed surface whose
/// centre sees every plane at a distance; convexity is not needed.
///
/// - A segment that keeps out of the outer ball cannot meet the group.
/// - A segment whose ends lie outside the outer ball and that passes through the inner ball
///   goes from where the winding number is 0 to where it is ±1 (the inner ball meets no
///   triangle, so all of it has the centre's): it crosses the surface, through a triangle
///   (or an edge or corner between triangles, which the watertight exact test does not let
///   through), away from its ends. Neither end lies in that triangle's plane, which would
///   hold the whole segment and so a point of the inner ball (up to the own-face rule's
///   tolerance, which `BALL_CLEARANCE` in `obvhs` bounds): the exact test finds it blocking.
///   (The exact test is watertight along edges; at a corner shared by many triangles its
///   f64 signs could in principle leave a hair-wide gap that the balls would not.)
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
    /// The balls of the group of `triangles` (corner indices into `position`, and the plane
    /// the own-face rule takes for each) with corners `corners`, when it is a closed surface
    /// about its centre (above).
    fn of(
        triangles: &[([u32; 3], (DVec3, f64))],
        position: &[DVec3],
        corners: &Corners,
    ) -> Option<Self> {
        // Closed and consistently oriented: each edge used once each way.
        let mut edges: Vec<(u32, u32, bool)> = Vec::with_capacity(3 * triangles.len());
        for &([a, b, c], _) in triangles {
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
        let mut inner = f64::INFINITY;
        let mut solid = 0.0;
        for &(t, (n, _)) in triangles {
            let [a, b, c] = t.map(|i| position[i as usize] - centre);
            // The centre's distance to the triangle, bounded below along the own-face plane's
            // normal (whatever its rounding): the least of the corners' heights when they lie
            // on one side; 0 when they do not.
            if n != DVec3::ZERO {
                let h = [n.dot(a), n.dot(b), n.dot(c)];
                let (min, max) = (h[0].min(h[1]).min(h[2]), h[0].max(h[1]).max(h[2]));
                inner = inner.min(if min > 0.0 {
                    min
                } else if max < 0.0 {
                    -max
                } else {
                    0.0
                });
            } // (a degenerate triangle has no plane and no area: no own face, no crossing)
            // The solid angle the triangle subtends at the centre (Van Oosterom and
            // Strackee, on unit vectors: the same at any scale), signed by its orientation.
            let (a, b, c) = (a.normalize(), b.normalize(), c.normalize());
            let below = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
            solid += 2.0 * a.dot(b.cross(c)).atan2(below);
        }
        let winding = solid / (4.0 * std::f64::consts::PI);
        let inside = winding.is_finite() && (winding.abs() - 1.0).abs() < 1e-6;
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

/// Joins the sets of `a` and `b` (the larger root under the smaller: deterministic).
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
    /// the best so far is not opened; the more promising child is opened first).
    fn support(&self, n: DVec3) -> f64 {
        let bound = |node: &CornerNode| (n * node.lo).max(n * node.hi).element_sum();
        let mut best = f64::NEG_INFINITY;
        let Some(root) = self.nodes.first() else {
            return best;
        };
        // Depth is at most log2 of the corners (median splits): two entries a level. Each
        // entry keeps its node's bound.
        let mut stack = [(0u32, 0f64); 2 * 64];
        stack[0] = (0, bound(root));
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let (i, b) = stack[top];
            if b <= best {
                continue;
            }
            let node = &self.nodes[i as usize];
            if node.right == 0 {
                for p in &self.points[node.start as usize..node.end as usize] {
                    best = best.max(n.dot(*p));
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
        best
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

    /// The groups of `tris` with the own-face rule's planes.
    fn groups_of(tris: &[[DVec3; 3]]) -> (Groups, Vec<u16>) {
        let planes: Vec<(DVec3, f64)> = tris
            .iter()
            .map(super::super::occluder::triangle_plane)
            .collect();
        Groups::of(tris, &planes)
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
        let (groups, tags) = groups_of(&tris);
        assert_eq!(
            groups.len(),
            1,
            "the floor's two triangles are too few to be a group"
        );
        assert!(tags[..320].iter().all(|&t| t == 1));
        assert_eq!(tags[320..], [NO_GROUP, NO_GROUP]);
        let ball = groups.balls[0].expect("a closed sphere about its centre");
        assert!((ball.centre - centre).length() < 1e-12);
        assert!(ball.outer <= 1.0 + 1e-12 && ball.inner > 0.98 && ball.inner < ball.outer);
        let margin = 1e-12 * 20.0;
        let clearance = |p: &Polygon, c: Clear| lowest(p, DVec3::ZERO) - c.support;
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
            assert_eq!((c.group, c.normal), (1, p.normal));
            assert!(clearance(&p, c).abs() <= margin, "{}", clearance(&p, c));
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
        let above = up(above);
        let c = groups.clear_of(&above, DVec3::ZERO, margin);
        assert_eq!(c.group, 1);
        assert!(
            (clearance(&above, c) - 1e-3).abs() < 1e-9,
            "{}",
            clearance(&above, c)
        );
    }

    /// A closed torus whose corners' mean lies in its hole (winding number 0), an open
    /// hemisphere and a sphere with one face turned over get no balls, at any scale; a sphere
    /// gets them from 1e-30 to 1e30 (beyond about 1e±100 its triangles' planes under- or
    /// overflow, and a group without planes gets none).
    #[test]
    fn only_closed_surfaces_about_their_centre_get_balls() {
        let torus = |scale: f64| {
            let (big, small, m, k) = (1.0, 0.3, 24, 12);
            let at = |i: usize, j: usize| {
                let (u, v) = (
                    std::f64::consts::TAU * (i % m) as f64 / m as f64,
                    std::f64::consts::TAU * (j % k) as f64 / k as f64,
                );
                let r = big + small * v.cos();
                DVec3::new(r * u.cos(), r * u.sin(), small * v.sin()) * scale
            };
            let mut tris = Vec::new();
            for i in 0..m {
                for j in 0..k {
                    let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                    tris.push([a, b, c]);
                    tris.push([a, c, d]);
                }
            }
            tris
        };
        for scale in [1e-100, 1.0, 1e100, 1.0555e103] {
            let (groups, _) = groups_of(&torus(scale));
            assert_eq!(groups.len(), 1);
            assert_eq!(groups.balls[0], None, "a torus at {scale}");
        }
        let whole = sphere(DVec3::ZERO, 2);
        let half: Vec<[DVec3; 3]> = whole
            .iter()
            .filter(|t| t[0].y + t[1].y + t[2].y > 0.0)
            .copied()
            .collect();
        assert_eq!(groups_of(&half).0.balls[0], None, "an open hemisphere");
        let mut flipped = whole.clone();
        flipped[7].swap(1, 2);
        assert_eq!(groups_of(&flipped).0.balls[0], None, "a face turned over");
        for scale in [1e-30, 1.0, 1e30] {
            let scaled: Vec<[DVec3; 3]> = whole.iter().map(|t| t.map(|v| v * scale)).collect();
            let ball = groups_of(&scaled).0.balls[0].expect("a sphere");
            assert!(ball.inner > 0.98 * scale && ball.outer <= scale * (1.0 + 1e-12));
        }
    }
}
