//! Patches for dense meshes: grouping small input faces by position and normal.
//!
//! A scanned statue or a finely tessellated prop is made of faces smaller than the patch size:
//! the 2MF cut would make each face its own patch (`k ≈` number of faces). Such *small pieces*
//! (pieces whose size is at most the patch size, see [`crate::mesh::subdivide::is_small`]) are
//! instead grouped per surface by recursive bisection: a set is split in two at the median of
//! its pieces' centroids along the longest axis of their bounding box, until
//! - (2MF, [`by_size`]) the vertex bounding box of the set has no side longer than the patch
//!   size and every normal lies within [`NORMAL_CONE_DEGREES`] of the set's mean normal, or
//! - (2MSC, [`super::coherence`]) the set is spatially coherent (the same bisection gives the
//!   children of a cluster node).
//!
//! A cluster patch is the union of its pieces (a [`crate::geometry::Region`] of several
//! parts); it never spans two surfaces. Bisection is deterministic (ties broken by piece
//! index) and costs O(m log² m) for m pieces. A lone small piece is its own patch, exactly as
//! the 2MF cut made it, so scenes without dense parts mesh as they did before clustering.

use glam::DVec3;

use crate::geometry::{Polygon, Region};

/// Largest angle between a piece's normal and its 2MF cluster's mean normal.
pub(crate) const NORMAL_CONE_DEGREES: f64 = 45.0;

/// What clustering needs of a piece.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Unit {
    pub centroid: DVec3,
    pub normal: DVec3,
    pub area: f64,
    /// Bounding box of the vertices.
    pub lo: DVec3,
    pub hi: DVec3,
}

impl Unit {
    pub(crate) fn of(p: &Polygon) -> Self {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for v in p.vertices() {
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
        Self {
            centroid: p.centroid(),
            normal: p.normal,
            area: p.area(),
            lo,
            hi,
        }
    }

    /// A region as one unit: its parts' bounding box, area and centroid, and their
    /// area-weighted mean normal (the first part's where they cancel).
    pub(crate) fn of_region(r: &Region) -> Self {
        let parts = r.parts();
        let mut u = Self::of(&parts[0]);
        let mut normal = DVec3::ZERO;
        for q in parts {
            let v = Self::of(q);
            u.lo = u.lo.min(v.lo);
            u.hi = u.hi.max(v.hi);
            normal += v.area * v.normal;
        }
        u.centroid = r.centroid();
        u.area = r.area();
        u.normal = normal.try_normalize().unwrap_or(parts[0].normal);
        u
    }
}

/// Splits `set` (at least two indices into `units`) into two non-empty halves at the median
/// of the centroids along the longest axis of their bounding box; each half sorted by index.
pub(crate) fn bisect(units: &[Unit], set: &[usize]) -> [Vec<usize>; 2] {
    debug_assert!(set.len() >= 2);
    let (lo, hi) = span(set.iter().map(|&u| units[u].centroid));
    median_split(units, set, widest_axis(hi - lo), |u| u.centroid)
}

/// The componentwise minimum and maximum of `points`.
fn span(points: impl Iterator<Item = DVec3>) -> (DVec3, DVec3) {
    points.fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(p), hi.max(p)),
    )
}

/// Where `v` lies in `[lo, hi]` on a grid of 2⁻²⁴ of the range: bisection compares these, not
/// raw coordinates, so that a scaled scene (whose coordinates round differently) makes the
/// same choices unless a value falls within rounding of a grid line (as `coherence::view_seed`
/// does for the view rays' seeds).
fn quantized(v: f64, lo: f64, hi: f64) -> i64 {
    if hi > lo {
        ((v - lo) / (hi - lo) * (1u64 << 24) as f64).round() as i64
    } else {
        0
    }
}

/// The axis (0, 1, 2) of the largest component of `extent` (the first on ties, compared on a
/// grid of 2⁻²⁴ of the largest: [`quantized`]).
fn widest_axis(extent: DVec3) -> usize {
    let m = extent.max_element();
    let [x, y, z] = extent.to_array().map(|e| quantized(e, 0.0, m));
    if x >= y && x >= z {
        0
    } else if y >= z {
        1
    } else {
        2
    }
}

/// `set` halved at the median of `value(unit)[axis]` ([`quantized`] over the set's range;
/// ties by index), each half sorted.
fn median_split(
    units: &[Unit],
    set: &[usize],
    axis: usize,
    value: impl Fn(&Unit) -> DVec3,
) -> [Vec<usize>; 2] {
    let (lo, hi) = set
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &u| {
            let v = value(&units[u])[axis];
            (l.min(v), h.max(v))
        });
    // The keys are distinct (ties by index): selecting the median splits the set as a full
    // sort would.
    let mut keyed: Vec<(i64, usize)> = set
        .iter()
        .map(|&u| (quantized(value(&units[u])[axis], lo, hi), u))
        .collect();
    let mid = keyed.len() / 2;
    if mid < keyed.len() {
        keyed.select_nth_unstable(mid);
    }
    let half = |k: &[(i64, usize)]| {
        let mut h: Vec<usize> = k.iter().map(|&(_, u)| u).collect();
        h.sort_unstable();
        h
    };
    [half(&keyed[..mid]), half(&keyed[mid..])]
}

/// A set's vertex bounding box and whether its normals lie within the cone of
/// [`NORMAL_CONE_DEGREES`] around their area-weighted mean.
fn summary(units: &[Unit], set: &[usize]) -> (DVec3, DVec3, bool) {
    summary_within(units, set, NORMAL_CONE_DEGREES)
}

/// [`summary`] for a cone of `cone_degrees`.
fn summary_within(units: &[Unit], set: &[usize], cone_degrees: f64) -> (DVec3, DVec3, bool) {
    let lo = span(set.iter().map(|&u| units[u].lo)).0;
    let hi = span(set.iter().map(|&u| units[u].hi)).1;
    let mean: DVec3 = set.iter().map(|&u| units[u].area * units[u].normal).sum();
    let cos = cone_degrees.to_radians().cos();
    let within = mean
        .try_normalize()
        .is_some_and(|m| set.iter().all(|&u| units[u].normal.dot(m) >= cos));
    (lo, hi, within)
}

/// True when the set's vertex bounding box has no side longer than `size` and its normals lie
/// within the cone of [`NORMAL_CONE_DEGREES`] around their area-weighted mean.
pub(crate) fn fits(units: &[Unit], set: &[usize], size: f64) -> bool {
    let (lo, hi, within) = summary(units, set);
    super::within((hi - lo).max_element(), size) && within
}

/// The 2MF clusters of `set`: bisected until each [`fits`] the patch size. Each cluster is
/// sorted by index; clusters come in the order of their smallest index.
pub(crate) fn by_size(units: &[Unit], set: Vec<usize>, size: f64) -> Vec<Vec<usize>> {
    by_size_within(units, set, size, f64::INFINITY, NORMAL_CONE_DEGREES)
}

/// [`by_size`] for a cone of `cone_degrees`, with sets also bisected by position until their
/// area is at most `max_area` (the elements of dense meshes, `crate::mesh::dense`).
pub(crate) fn by_size_within(
    units: &[Unit],
    set: Vec<usize>,
    size: f64,
    max_area: f64,
    cone_degrees: f64,
) -> Vec<Vec<usize>> {
    let mut out = Vec::new();
    let mut stack = vec![set];
    while let Some(s) = stack.pop() {
        let (lo, hi, within) = summary_within(units, &s, cone_degrees);
        let box_fits = super::within((hi - lo).max_element(), size);
        let area: f64 = s.iter().map(|&u| units[u].area).sum();
        if s.len() <= 1 || (box_fits && within && area <= max_area) {
            if !s.is_empty() {
                out.push(s);
            }
            continue;
        }
        // A set within the size whose normals leave the cone (the sides of a pillar, a step)
        // is split by its normals: halving it by position may never part opposite faces, and
        // a game level's details would end one piece per patch.
        let [a, b] = if box_fits && !within {
            bisect_normals(units, &s)
        } else {
            bisect(units, &s)
        };
        stack.push(a);
        stack.push(b);
    }
    out.sort_by_key(|c| c[0]);
    out
}

/// The sets of `sets` split until there are `budget` of them (or no set has two units left):
/// each step splits the set whose normals leave the cone of [`NORMAL_CONE_DEGREES`] by its
/// normals, else the set of the widest vertex bounding box by position ([`bisect`]); ties go
/// to the smaller first index. Deterministic; sets sorted, in the order of their smallest index.
pub(crate) fn to_budget(units: &[Unit], sets: Vec<Vec<usize>>, budget: usize) -> Vec<Vec<usize>> {
    use std::cmp::Reverse;
    use std::collections::BinaryHeap;
    // (normals outside the cone, box diagonal's bits, first index): f64 bits of a
    // non-negative number order as the number does.
    let key = |set: &[usize]| {
        let (lo, hi, within) = summary(units, set);
        let diagonal = (hi - lo).length();
        let diagonal = if diagonal.is_finite() { diagonal } else { 0.0 };
        (
            !within && set.len() > 1,
            diagonal.to_bits(),
            Reverse(set[0]),
        )
    };
    let mut heap: BinaryHeap<_> = sets
        .into_iter()
        .filter(|s| !s.is_empty())
        .map(|s| (key(&s), s))
        .collect();
    let mut done = Vec::new();
    while heap.len() + done.len() < budget {
        let Some(((spread, _, _), set)) = heap.pop() else {
            break;
        };
        if set.len() < 2 {
            done.push(set);
            continue;
        }
        let halves = if spread {
            bisect_normals(units, &set)
        } else {
            bisect(units, &set)
        };
        for h in halves {
            heap.push((key(&h), h));
        }
    }
    let mut out: Vec<Vec<usize>> = done
        .into_iter()
        .chain(heap.into_iter().map(|(_, s)| s))
        .collect();
    out.sort_by_key(|c| c[0]);
    out
}

/// Splits `set` (at least two) by its normals along the axis they spread most, at the middle
/// of their range (a box's six sides part cleanly: a median would cut through one side's
/// normals); at the median when all fall on one side of the middle.
fn bisect_normals(units: &[Unit], set: &[usize]) -> [Vec<usize>; 2] {
    let (lo, hi) = span(set.iter().map(|&u| units[u].normal));
    let axis = widest_axis(hi - lo);
    let middle = 1i64 << 23; // the middle of the range, quantized
    let (below, above): (Vec<usize>, Vec<usize>) = set
        .iter()
        .partition(|&&u| quantized(units[u].normal[axis], lo[axis], hi[axis]) < middle);
    if !below.is_empty() && !above.is_empty() {
        return [below, above];
    }
    median_split(units, set, axis, |u| u.normal)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid of `m × m` small squares in the plane z = 0, side `h`.
    fn grid(m: usize, h: f64) -> Vec<Unit> {
        let mut units = Vec::new();
        for j in 0..m {
            for i in 0..m {
                let (x, y) = (i as f64 * h, j as f64 * h);
                let p = Polygon::new(&[
                    DVec3::new(x, y, 0.0),
                    DVec3::new(x + h, y, 0.0),
                    DVec3::new(x + h, y + h, 0.0),
                    DVec3::new(x, y + h, 0.0),
                ])
                .unwrap();
                units.push(Unit::of(&p));
            }
        }
        units
    }

    #[test]
    fn every_unit_in_exactly_one_cluster_of_the_patch_size() {
        let units = grid(16, 0.1);
        let clusters = by_size(&units, (0..units.len()).collect(), 0.41);
        let mut seen = vec![0; units.len()];
        for c in &clusters {
            assert!(fits(&units, c, 0.41));
            for &u in c {
                seen[u] += 1;
            }
        }
        assert!(seen.iter().all(|&s| s == 1), "{seen:?}");
        // 1.6 × 1.6 in boxes of at most 0.41: at least 16 clusters, and bisection of a
        // regular grid gives exactly 4×4.
        assert_eq!(clusters.len(), 16);
    }

    #[test]
    fn opposite_normals_are_never_grouped() {
        let up = Polygon::new(&[
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.1, 0.0, 0.0),
            DVec3::new(0.0, 0.1, 0.0),
        ])
        .unwrap();
        let down = Polygon::new(&[
            DVec3::new(0.0, 0.0, 0.01),
            DVec3::new(0.0, 0.1, 0.01),
            DVec3::new(0.1, 0.0, 0.01),
        ])
        .unwrap();
        let units = vec![Unit::of(&up), Unit::of(&down)];
        let clusters = by_size(&units, vec![0, 1], 1.0);
        assert_eq!(clusters, vec![vec![0], vec![1]]);
    }

    #[test]
    fn bisection_is_deterministic_and_balanced() {
        let units = grid(5, 0.1);
        let set: Vec<usize> = (0..25).collect();
        let [a, b] = bisect(&units, &set);
        assert_eq!((a.len(), b.len()), (12, 13));
        assert_eq!(bisect(&units, &set), [a, b]);
    }

    /// Two opposite sheets of 16 × 16 squares (a thin wall's sides) cut to 8 sets: never both
    /// sides in one set, every unit once, and the same sets again.
    #[test]
    fn a_budget_keeps_opposite_sides_apart() {
        let mut units = grid(16, 0.1);
        let back: Vec<Unit> = units
            .iter()
            .map(|u| Unit {
                normal: -u.normal,
                ..*u
            })
            .collect();
        units.extend(back);
        let all: Vec<usize> = (0..units.len()).collect();
        let sets = to_budget(&units, vec![all.clone()], 8);
        assert_eq!(sets.len(), 8);
        let mut seen = vec![0; units.len()];
        for s in &sets {
            let up = units[s[0]].normal.z > 0.0;
            assert!(s.iter().all(|&u| (units[u].normal.z > 0.0) == up), "{s:?}");
            for &u in s {
                seen[u] += 1;
            }
        }
        assert!(seen.iter().all(|&c| c == 1));
        assert_eq!(to_budget(&units, vec![all], 8), sets);
        // a budget above the count leaves every unit alone
        assert_eq!(to_budget(&units, vec![(0..4).collect()], 100).len(), 4);
    }

    /// A small box (well within the patch size) whose six sides are each a 4 × 4 grid of
    /// squares: clusters part it by normal, six of them, never one square each.
    #[test]
    fn a_small_detail_is_clustered_by_its_normals() {
        let mut units = Vec::new();
        for axis in 0..3 {
            for side in [0.0, 1.0] {
                for j in 0..4 {
                    for i in 0..4 {
                        let (a, b) = (i as f64 * 0.25, j as f64 * 0.25);
                        let corner = |da: f64, db: f64| {
                            let mut v = [0.0; 3];
                            v[axis] = side;
                            v[(axis + 1) % 3] = a + da;
                            v[(axis + 2) % 3] = b + db;
                            DVec3::from_array(v)
                        };
                        let mut quad = [
                            corner(0.0, 0.0),
                            corner(0.25, 0.0),
                            corner(0.25, 0.25),
                            corner(0.0, 0.25),
                        ];
                        if side == 0.0 {
                            quad.reverse();
                        }
                        units.push(Unit::of(&Polygon::new(&quad).unwrap()));
                    }
                }
            }
        }
        let clusters = by_size(&units, (0..units.len()).collect(), 10.0);
        assert_eq!(clusters.len(), 6, "{clusters:?}");
        assert!(
            clusters
                .iter()
                .all(|c| c.len() == 16 && fits(&units, c, 10.0))
        );
    }
}
