//! Regions of a surface: one convex polygon, or the union of several (a patch built by
//! clustering the small faces of a dense mesh), with area-proportional sample points.

use rustc_hash::FxHashMap;

use glam::DVec3;

use super::Polygon;
use super::sampling::{Sample, map_unit_square, r2, shift};

/// A form-factor target: one convex polygon, or the union of several (a cluster patch).
#[derive(Debug, Clone, PartialEq)]
pub struct Region {
    parts: Vec<Polygon>,
    /// Running sums of the parts' areas (`parts.len() + 1` values from 0).
    cumulative: Vec<f64>,
    /// For several parts in one plane: the edges left when the edges two parts share (the
    /// same two vertices, opposite directions) cancel.
    outline: Option<Outline>,
    /// The same area in fewer polygons, for the closed-form factor alone
    /// ([`Region::kernel_parts`]); empty: `parts`.
    kernel: Vec<Polygon>,
}

/// A vertex by its exact coordinates: shared vertices of a subdivision are bit-identical.
type Key = [u64; 3];

fn key(v: DVec3) -> Key {
    [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]
}

/// The items not marked `gone`, in order.
fn kept<T>(items: Vec<T>, gone: &[bool]) -> Vec<T> {
    items
        .into_iter()
        .zip(gone)
        .filter(|(_, g)| !**g)
        .map(|(x, _)| x)
        .collect()
}

/// The outline of a planar region of several parts ([`Region::outline`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Outline {
    /// The plane's unit normal (the parts' front).
    pub normal: DVec3,
    /// A point on the plane.
    pub origin: DVec3,
    /// The largest part's size (tolerances are relative to it).
    pub scale: f64,
    /// Directed edges `(a, b)`, as the parts run them (counter-clockwise about `normal`).
    pub edges: Vec<(DVec3, DVec3)>,
}

impl Outline {
    /// Height of `x` above the plane.
    pub fn height(&self, x: DVec3) -> f64 {
        (x - self.origin).dot(self.normal)
    }

    /// The outline of `parts` when there are several and they share one plane (normals equal
    /// to 1e-12, every vertex within 1e-9 of the largest part's size from the first part's
    /// plane); else `None`.
    fn of(parts: &[Polygon]) -> Option<Outline> {
        let first = parts.first()?;
        if parts.len() < 2 {
            return None;
        }
        let scale = parts.iter().map(|p| p.scale).fold(0.0, f64::max);
        let coplanar = parts.iter().all(|p| {
            (p.normal - first.normal).length() <= 1e-12
                && p.vertices()
                    .iter()
                    .all(|&v| first.height(v).abs() <= 1e-9 * scale)
        });
        if !coplanar {
            return None;
        }
        let mut count: FxHashMap<(Key, Key), i64> = FxHashMap::default();
        let mut edges = Vec::new();
        for p in parts {
            let v = p.vertices();
            for i in 0..v.len() {
                let (a, b) = (v[i], v[(i + 1) % v.len()]);
                edges.push((a, b));
                *count.entry((key(a), key(b))).or_default() += 1;
            }
        }
        // An edge cancels against one run the other way; kept in the parts' order.
        let mut cancelled: FxHashMap<(Key, Key), i64> = FxHashMap::default();
        let edges = edges
            .into_iter()
            .filter(|&(a, b)| {
                let back = count.get(&(key(b), key(a))).copied().unwrap_or(0);
                let used = cancelled.entry((key(a), key(b))).or_default();
                if *used < back {
                    *used += 1;
                    false
                } else {
                    true
                }
            })
            .collect();
        Some(Outline {
            normal: first.normal,
            origin: first.vertices[0],
            scale,
            edges: join_collinear(edges),
        })
    }
}

/// Fewer, larger parts for a patch of coplanar elements: two parts that share an edge (the
/// same two vertices, opposite directions) become one where their union, its collinear
/// vertices dropped, is a convex polygon of at most 4 vertices (two grid cells of a piece
/// make a rectangle, two rows of cells of equal span a larger one). The union covers exactly
/// the same area, so the closed-form factor to it is the same (summed over fewer parts where
/// the outline cannot be used: [`Region::kernel_parts`]). The visibility rays still sample
/// the parts: sampled over the coarsened ones, the Cornell box's merged patches' error
/// against the exact solve rose from 8.8e-4 to 1.0e-3 at k = 195.
fn coarsen(mut parts: Vec<Polygon>) -> Vec<Polygon> {
    loop {
        let mut by_edge: FxHashMap<(Key, Key), usize> = FxHashMap::default();
        for (i, p) in parts.iter().enumerate() {
            let v = p.vertices();
            for a in 0..v.len() {
                by_edge.insert((key(v[a]), key(v[(a + 1) % v.len()])), i);
            }
        }
        let mut gone = vec![false; parts.len()];
        let mut merged = false;
        for i in 0..parts.len() {
            if gone[i] {
                continue;
            }
            let v = parts[i].vertices().to_vec();
            for a in 0..v.len() {
                let (p, q) = (v[a], v[(a + 1) % v.len()]);
                let Some(&j) = by_edge.get(&(key(q), key(p))) else {
                    continue;
                };
                if j == i || gone[j] {
                    continue;
                }
                if let Some(u) = join(&parts[i], &parts[j], a, q) {
                    parts[i] = u;
                    gone[j] = true;
                    merged = true;
                    break; // the edges of `i` changed: its other joins wait for the next pass
                }
            }
        }
        if !merged {
            return parts;
        }
        parts = kept(parts, &gone);
    }
}

/// The union of `a` and `b`, which share `a`'s edge `a_edge` (run the other way by `b`, from
/// `q`), when it is convex with at most 4 vertices once collinear ones are dropped.
fn join(a: &Polygon, b: &Polygon, a_edge: usize, q: DVec3) -> Option<Polygon> {
    if (a.normal - b.normal).length() > 1e-12 {
        return None;
    }
    let (va, vb) = (a.vertices(), b.vertices());
    let (na, nb) = (va.len(), vb.len());
    // `a` from the shared edge's end `q` round to its start, then `b` from there round to `q`.
    let start_b = vb.iter().position(|&x| x == q)?;
    let mut loop_ = Vec::with_capacity(na + nb - 2);
    for i in 0..na {
        loop_.push(va[(a_edge + 1 + i) % na]);
    }
    for i in 0..nb - 2 {
        loop_.push(vb[(start_b + 2 + i) % nb]);
    }
    // Drop collinear vertices (relative tolerance), then require a convex turn everywhere.
    let n = a.normal;
    let turn = |p: DVec3, x: DVec3, r: DVec3| {
        let (d1, d2) = (x - p, r - x);
        n.dot(d1.cross(d2)) / (d1.length() * d2.length())
    };
    let mut kept: Vec<DVec3> = Vec::with_capacity(loop_.len());
    let m = loop_.len();
    for i in 0..m {
        let (p, x, r) = (loop_[(i + m - 1) % m], loop_[i], loop_[(i + 1) % m]);
        if turn(p, x, r).abs() > 1e-12 {
            kept.push(x);
        }
    }
    if !(3..=4).contains(&kept.len()) {
        return None;
    }
    let k = kept.len();
    if (0..k).any(|i| turn(kept[(i + k - 1) % k], kept[i], kept[(i + 1) % k]) <= 1e-12) {
        return None;
    }
    let u = Polygon::new(&kept)?;
    let (area, parts) = (u.area(), a.area() + b.area());
    ((area - parts).abs() <= 1e-12 * parts && (u.normal - n).length() <= 1e-9).then_some(u)
}

/// Joins outline edges `(a, b)`, `(b, c)` into `(a, c)` where `b` starts and ends exactly
/// one edge each and `c` lies straight ahead (relative tolerance 1e-12): the contour integral
/// over a straight run is the sum over its pieces, so a long side made of element edges
/// costs one term.
fn join_collinear(mut edges: Vec<(DVec3, DVec3)>) -> Vec<(DVec3, DVec3)> {
    loop {
        let mut starts: FxHashMap<Key, Vec<usize>> = FxHashMap::default();
        let mut ends: FxHashMap<Key, usize> = FxHashMap::default();
        for (i, &(a, b)) in edges.iter().enumerate() {
            starts.entry(key(a)).or_default().push(i);
            *ends.entry(key(b)).or_default() += 1;
        }
        let mut gone = vec![false; edges.len()];
        let mut joined = false;
        for i in 0..edges.len() {
            if gone[i] {
                continue;
            }
            let (a, b) = edges[i];
            let next = match starts.get(&key(b)) {
                Some(v) if v.len() == 1 && ends.get(&key(b)) == Some(&1) => v[0],
                _ => continue,
            };
            if next == i || gone[next] {
                continue;
            }
            let c = edges[next].1;
            let (d1, d2) = (b - a, c - b);
            let straight =
                d1.cross(d2).length() <= 1e-12 * d1.length() * d2.length() && d1.dot(d2) > 0.0;
            if straight {
                edges[i] = (a, c);
                gone[next] = true;
                joined = true;
            }
        }
        if !joined {
            return edges;
        }
        edges = kept(edges, &gone);
    }
}

impl Region {
    /// A region from its parts (at least one; the parts must not overlap).
    pub fn new(parts: Vec<Polygon>) -> Self {
        assert!(!parts.is_empty(), "a region has at least one part");
        let mut cumulative = Vec::with_capacity(parts.len() + 1);
        cumulative.push(0.0);
        let mut sum = 0.0;
        for p in &parts {
            sum += p.area();
            cumulative.push(sum);
        }
        let outline = Outline::of(&parts);
        // Planar regions (2MSC's merged patches): the same area in fewer polygons. Made here,
        // from the parts alone, so a region read back (a shard plan) is the region written.
        let kernel = if outline.is_some() {
            coarsen(parts.clone())
        } else {
            Vec::new()
        };
        Self {
            parts,
            cumulative,
            outline,
            kernel,
        }
    }

    /// The polygons the closed-form factor sums over where the outline does not apply: for a
    /// planar region, its parts coarsened into fewer convex ones of the same area; else the
    /// parts.
    pub fn kernel_parts(&self) -> &[Polygon] {
        if self.kernel.is_empty() {
            &self.parts
        } else {
            &self.kernel
        }
    }

    /// The outline of a region of several parts in one plane (`None` for one part, or parts
    /// in several planes): the closed-form factor to the region is the contour integral over
    /// these edges alone, where no part needs clipping.
    pub fn outline(&self) -> Option<&Outline> {
        self.outline.as_ref()
    }

    /// Bytes the region holds on the heap (its parts, their running areas, the outline's
    /// edges and the coarsened parts), for memory plans.
    pub(crate) fn heap_bytes(&self) -> u128 {
        let polygons = self.parts.capacity() + self.kernel.capacity();
        let edges = self.outline.as_ref().map_or(0, |o| o.edges.capacity());
        (polygons * size_of::<Polygon>()
            + self.cumulative.capacity() * size_of::<f64>()
            + edges * size_of::<(DVec3, DVec3)>()) as u128
    }

    /// A region of one polygon.
    pub fn single(p: Polygon) -> Self {
        Self::new(vec![p])
    }

    /// The polygons the region is made of.
    pub fn parts(&self) -> &[Polygon] {
        &self.parts
    }

    /// The polygon when the region has exactly one part.
    pub fn as_single(&self) -> Option<&Polygon> {
        match self.parts.as_slice() {
            [p] => Some(p),
            _ => None,
        }
    }

    /// Total area of the parts, in scene units².
    pub fn area(&self) -> f64 {
        self.cumulative[self.parts.len()]
    }

    /// Area-weighted centroid of the parts (may lie off the surface of a curved cluster).
    pub fn centroid(&self) -> DVec3 {
        let mut sum = DVec3::ZERO;
        for p in &self.parts {
            sum += p.area() * p.centroid();
        }
        sum / self.area()
    }

    /// The part whose centroid is nearest `x` (ties: the first), for a representative point.
    pub fn nearest_part(&self, x: DVec3) -> &Polygon {
        let mut best = &self.parts[0];
        let mut best_d = f64::INFINITY;
        for p in &self.parts {
            let d = p.centroid().distance_squared(x);
            if d < best_d {
                best_d = d;
                best = p;
            }
        }
        best
    }

    /// The `i`-th pair point on the union (R2 shifted by `seed`, the first coordinate choosing
    /// the part by area): the part's index and the sample, whose weight is the area density
    /// relative to uniform over the union (1 on average, like `sampling::pair_point`).
    pub fn pair_point(&self, i: u32, seed: u64) -> (usize, Sample) {
        let (u, w) = r2(i, shift(seed));
        let a = u * self.area();
        // first part whose running sum exceeds a
        let j = self.cumulative[1..]
            .partition_point(|&c| c <= a)
            .min(self.parts.len() - 1);
        let part = &self.parts[j];
        let (lo, area) = (
            self.cumulative[j],
            self.cumulative[j + 1] - self.cumulative[j],
        );
        let u = ((a - lo) / area).clamp(0.0, 1.0);
        let mut s = map_unit_square(part.vertices(), u, w);
        if part.count == 4 {
            s.weight /= area; // the bilinear Jacobian relative to the part's area
        }
        (j, s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    /// Grid cells coarsen into rectangles covering the same area (a 4×3 block of cells into
    /// one quad; an L of three cells into two), and a notched block keeps its notch.
    #[test]
    fn coplanar_cells_coarsen_into_rectangles() {
        let cell = |i: i32, j: i32| {
            let (x, y) = (f64::from(i), f64::from(j));
            square(x, x + 1.0, y, y + 1.0, 0.0, false)
        };
        let block: Vec<Polygon> = (0..4)
            .flat_map(|i| (0..3).map(move |j| cell(i, j)))
            .collect();
        let out = coarsen(block);
        assert_eq!(out.len(), 1, "{out:?}");
        assert!((out[0].area() - 12.0).abs() < 1e-12);
        let l = coarsen(vec![cell(0, 0), cell(1, 0), cell(0, 1)]);
        assert_eq!(l.len(), 2);
        assert!((l.iter().map(Polygon::area).sum::<f64>() - 3.0).abs() < 1e-12);
        // Two triangles of a square (sharing its diagonal) make the square.
        let v = |x: f64, y: f64| DVec3::new(x, y, 0.0);
        let t1 = Polygon::new(&[v(0.0, 0.0), v(1.0, 0.0), v(1.0, 1.0)]).unwrap();
        let t2 = Polygon::new(&[v(0.0, 0.0), v(1.0, 1.0), v(0.0, 1.0)]).unwrap();
        let square = coarsen(vec![t1, t2]);
        assert_eq!(square.len(), 1);
        assert_eq!(square[0].count, 4);
        assert!((square[0].area() - 1.0).abs() < 1e-12);
        let notched: Vec<Polygon> = (0..4)
            .flat_map(|i| (0..4).map(move |j| (i, j)))
            .filter(|&c| c != (3, 1))
            .map(|(i, j)| cell(i, j))
            .collect();
        let out = coarsen(notched);
        assert!(out.len() < 6, "{} parts", out.len());
        assert!((out.iter().map(Polygon::area).sum::<f64>() - 15.0).abs() < 1e-12);
        // The notch stays uncovered: its centre lies in no part.
        let centre = DVec3::new(3.5, 1.5, 0.0);
        let inside = |p: &Polygon| {
            let v = p.vertices();
            (0..v.len()).all(|i| (v[(i + 1) % v.len()] - v[i]).cross(centre - v[i]).z >= 0.0)
        };
        assert!(!out.iter().any(inside));
    }

    use crate::geometry::rectangle as square;

    #[test]
    fn pair_points_cover_parts_by_area() {
        let t = Region::new(vec![
            square(0.0, 1.0, 0.0, 1.0, 0.0, false),
            square(2.0, 5.0, 0.0, 1.0, 0.0, false),
        ]);
        let mut counts = [0usize; 2];
        let mut weight = 0.0;
        for i in 0..4000 {
            let (j, s) = t.pair_point(i, 7);
            counts[j] += 1;
            weight += s.weight;
            let p = &t.parts()[j];
            assert!(p.height(s.point).abs() < 1e-12);
        }
        let share = counts[1] as f64 / 4000.0;
        assert!((share - 0.75).abs() < 0.01, "{share}");
        assert!((weight / 4000.0 - 1.0).abs() < 1e-9, "{}", weight / 4000.0);
    }
}
