//! Lightmap charts from an operator file's display faces (`OperatorFile::faces`: section FACES,
//! else GEOMETRY's elements; "element" below means a display face): connected sets of coplanar
//! elements (same plane within a tolerance relative to the element sizes, sharing a piece of an
//! edge), each flattened onto its plane. Elements coplanar with no neighbour (the triangles of a
//! curved surface) are then grown into charts of their own: from the first such element, its
//! neighbours of the same kind whose normals lie within [`CURVED_ANGLE`] of the first's,
//! projected onto the first's plane (texels shrink by at most cos 30° across them); a chart
//! whose projected faces would overlap (a surface that winds over itself) is left as single
//! faces. A sphere of 10⁵ triangles is a few hundred charts instead of 10⁵.
//!
//! Two elements share an edge when at least two distinct points of one lie on the other's
//! boundary (shared corners, T-junctions of adaptive subdivision and imprinting, offset grids);
//! touching at a single corner does not join charts. Candidate pairs come from a uniform grid
//! over element boxes, or from a hierarchy of grids where a few boxes far larger than the rest
//! would fill too many cells, so the work is near linear in the element count.

use crate::geometry::boxes::{BoxGrid, overlaps};
use rayon::prelude::*;
use rustc_hash::FxHashMap as HashMap;

use glam::{DVec2, DVec3};
use lrr_formats::Geometry;

/// One chart: display faces (increasing) flattened onto one plane.
#[derive(Debug, Clone)]
pub struct Chart {
    /// The chart's display faces (file positions of elements when the file has no section
    /// FACES), increasing.
    pub faces: Vec<u32>,
    /// The plane's frame: `point = origin + x u + y v`, with `u × v` the elements' normal.
    pub origin: DVec3,
    /// The plane's first axis (see `origin`).
    pub u: DVec3,
    /// The plane's second axis (see `origin`).
    pub v: DVec3,
    /// Extent of the flattened elements: `x` in `[0, size.x]`, `y` in `[0, size.y]`.
    pub size: DVec2,
}

impl Chart {
    /// The chart coordinates of a point of its plane.
    pub fn flatten(&self, p: DVec3) -> DVec2 {
        let d = p - self.origin;
        DVec2::new(d.dot(self.u), d.dot(self.v))
    }

    /// The point of the plane at chart coordinates `q`.
    pub fn lift(&self, q: DVec2) -> DVec3 {
        self.origin + q.x * self.u + q.y * self.v
    }
}

/// An element's corners in f64.
pub fn corners(g: &Geometry, s: usize) -> Vec<DVec3> {
    (0..usize::from(g.vertex_count[s]))
        .map(|i| {
            let b = 12 * s + 3 * i;
            DVec3::new(
                f64::from(g.vertices[b]),
                f64::from(g.vertices[b + 1]),
                f64::from(g.vertices[b + 2]),
            )
        })
        .collect()
}

/// An element's unit normal.
pub fn normal(g: &Geometry, s: usize) -> DVec3 {
    DVec3::new(
        f64::from(g.normals[3 * s]),
        f64::from(g.normals[3 * s + 1]),
        f64::from(g.normals[3 * s + 2]),
    )
    .normalize_or_zero()
}

/// Largest angle between the normals of elements of one chart (radians).
const ANGLE: f64 = 1e-3;
/// Largest angle between the normal of an element of a curved chart and its first element's
/// (radians): 30°.
pub const CURVED_ANGLE: f64 = std::f64::consts::FRAC_PI_6;
/// Distance tolerance, relative to the median element's longest edge.
const RELATIVE_DISTANCE: f64 = 1e-4;

/// The charts of `g`, ordered by their first element.
pub fn charts(g: &Geometry) -> Vec<Chart> {
    let n = g.vertex_count.len();
    let polys: Vec<Vec<DVec3>> = (0..n).map(|s| corners(g, s)).collect();
    let normals: Vec<DVec3> = (0..n).map(|s| normal(g, s)).collect();
    let eps = RELATIVE_DISTANCE * median_edge(&polys);
    let mut sets = UnionFind::new(n);
    let pairs = candidate_pairs(&polys, eps);
    // Whether each pair shares an edge, tested in parallel, in the pairs' order.
    let sharing: Vec<bool> = pairs
        .par_iter()
        .map(|&(a, b)| share_edge(&polys[a], &polys[b], eps))
        .collect();
    for (&(a, b), &shared) in pairs.iter().zip(&sharing) {
        if shared && coplanar(&polys, &normals, a, b, eps) {
            sets.union(a, b);
        }
    }
    let mut members: HashMap<usize, Vec<u32>> = HashMap::default();
    for s in 0..n {
        members.entry(sets.find(s)).or_default().push(s as u32);
    }
    let (alone, mut groups): (Vec<Vec<u32>>, Vec<Vec<u32>>) =
        members.into_values().partition(|m| m.len() == 1);
    let mut single = vec![false; n];
    for m in &alone {
        single[m[0] as usize] = true;
    }
    groups.extend(curved_charts(
        &polys, &normals, &pairs, &sharing, &single, eps,
    ));
    groups.sort_unstable_by_key(|m| m[0]);
    groups
        .into_iter()
        .map(|elements| flatten(&polys, &normals, elements))
        .collect()
}

/// Charts of the `single` elements (coplanar with no neighbour): from each not yet taken, in
/// order, its neighbours (sharing an edge: `pairs` the candidates, `sharing` whether each
/// does) that are single and untaken
/// with normals within [`CURVED_ANGLE`] of its own, breadth first; a chart whose faces,
/// projected onto its first element's plane, would overlap is left as single elements.
fn curved_charts(
    polys: &[Vec<DVec3>],
    normals: &[DVec3],
    pairs: &[(usize, usize)],
    sharing: &[bool],
    single: &[bool],
    eps: f64,
) -> Vec<Vec<u32>> {
    let n = polys.len();
    let cone = CURVED_ANGLE.cos();
    let mut around: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (&(a, b), &shared) in pairs.iter().zip(sharing) {
        if single[a] && single[b] && normals[a].dot(normals[b]) >= cone && shared {
            around[a].push(b);
            around[b].push(a);
        }
    }
    let mut taken = vec![false; n];
    let mut charts = Vec::new();
    for seed in (0..n).filter(|&s| single[s]) {
        if taken[seed] {
            continue;
        }
        taken[seed] = true;
        let axis = normals[seed];
        let mut chart = vec![seed];
        let mut next = 0;
        while next < chart.len() {
            let s = chart[next];
            next += 1;
            for &t in &around[s] {
                if !taken[t] && normals[t].dot(axis) >= cone {
                    taken[t] = true;
                    chart.push(t);
                }
            }
        }
        if chart.len() > 1 && projections_overlap(polys, &chart, axis, eps) {
            charts.extend(chart.iter().map(|&s| vec![s as u32]));
        } else {
            chart.sort_unstable();
            charts.push(chart.into_iter().map(|s| s as u32).collect());
        }
    }
    charts
}

/// Whether two of `faces`, projected along `axis` (each a convex polygon), overlap by more than
/// `eps` (faces sharing an edge or a corner touch, they do not overlap). Candidates from a
/// uniform grid over the projected boxes.
fn projections_overlap(polys: &[Vec<DVec3>], faces: &[usize], axis: DVec3, eps: f64) -> bool {
    let (u, v) = frame(&polys[faces[0]], axis);
    let flat: Vec<Vec<DVec2>> = faces
        .iter()
        .map(|&s| {
            polys[s]
                .iter()
                .map(|p| DVec2::new(p.dot(u), p.dot(v)))
                .collect()
        })
        .collect();
    let boxes: Vec<(DVec2, DVec2)> = flat
        .iter()
        .map(|p| {
            let lo = p.iter().fold(DVec2::INFINITY, |a, b| a.min(*b));
            let hi = p.iter().fold(DVec2::NEG_INFINITY, |a, b| a.max(*b));
            (lo, hi)
        })
        .collect();
    let mut diag: Vec<f64> = boxes.iter().map(|(lo, hi)| lo.distance(*hi)).collect();
    let mid = diag.len() / 2;
    let cell = 2.0 * diag.select_nth_unstable_by(mid, f64::total_cmp).1.max(eps);
    let key = |p: DVec2| (p / cell).floor().as_i64vec2();
    let mut grid: HashMap<[i64; 2], Vec<usize>> = HashMap::default();
    for (i, (lo, hi)) in boxes.iter().enumerate() {
        let (a, b) = (key(*lo), key(*hi));
        for x in a.x..=b.x {
            for y in a.y..=b.y {
                grid.entry([x, y]).or_default().push(i);
            }
        }
    }
    // Boxes apart (not touching) hold polygons apart, which the separating axes find too.
    let apart = |i: usize, j: usize| {
        let ((la, ha), (lb, hb)) = (boxes[i], boxes[j]);
        la.cmpgt(hb).any() || lb.cmpgt(ha).any()
    };
    grid.values().any(|cell| {
        cell.iter().enumerate().any(|(k, &i)| {
            cell[k + 1..]
                .iter()
                .any(|&j| !apart(i, j) && convex_overlap(&flat[i], &flat[j], eps))
        })
    })
}

/// Whether convex polygons `a` and `b` overlap by more than `eps` along every axis their edges
/// give (separating axis test; degenerate polygons never overlap).
fn convex_overlap(a: &[DVec2], b: &[DVec2], eps: f64) -> bool {
    for poly in [a, b] {
        for i in 0..poly.len() {
            let e = poly[(i + 1) % poly.len()] - poly[i];
            let Some(axis) = DVec2::new(-e.y, e.x).try_normalize() else {
                continue;
            };
            let span = |p: &[DVec2]| {
                p.iter()
                    .map(|x| x.dot(axis))
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), d| {
                        (lo.min(d), hi.max(d))
                    })
            };
            let ((alo, ahi), (blo, bhi)) = (span(a), span(b));
            if ahi.min(bhi) - alo.max(blo) <= eps {
                return false;
            }
        }
    }
    a.len() >= 3 && b.len() >= 3
}

/// The chart frame of `elements`: the normal of the first, `u` along its first edge, the
/// origin at the corner of the flattened bounding box.
fn flatten(polys: &[Vec<DVec3>], normals: &[DVec3], elements: Vec<u32>) -> Chart {
    let first = &polys[elements[0] as usize];
    let (u, v) = frame(first, normals[elements[0] as usize]);
    let mut lo = DVec2::splat(f64::INFINITY);
    let mut hi = DVec2::splat(f64::NEG_INFINITY);
    for &s in &elements {
        for p in &polys[s as usize] {
            let d = *p - first[0];
            let q = DVec2::new(d.dot(u), d.dot(v));
            lo = lo.min(q);
            hi = hi.max(q);
        }
    }
    Chart {
        faces: elements,
        origin: first[0] + lo.x * u + lo.y * v,
        u,
        v,
        size: hi - lo,
    }
}

/// A chart's axes from its first face: `u` along the face's first edge in its plane (its longest
/// when the first has no length), `v = n × u`. A face with no usable edge or normal (a needle,
/// a point: real scenes have them) still gets an orthonormal frame, so no coordinate is ever
/// NaN.
fn frame(face: &[DVec3], n: DVec3) -> (DVec3, DVec3) {
    let edges = (0..face.len())
        .map(|i| face[(i + 1) % face.len()] - face[i])
        .map(|e| e - n * e.dot(n));
    let longest = edges
        .clone()
        .max_by(|a, b| a.length_squared().total_cmp(&b.length_squared()))
        .unwrap_or(DVec3::ZERO);
    let first = edges.take(1).next().unwrap_or(DVec3::ZERO);
    let longest = if first.length() > 1e-9 * longest.length() {
        first
    } else {
        longest
    };
    let n = if n.is_finite() && n.length_squared() > 0.5 {
        n
    } else {
        let across = if face.len() >= 3 {
            (face[1] - face[0])
                .cross(face[2] - face[0])
                .normalize_or_zero()
        } else {
            DVec3::ZERO
        };
        if across == DVec3::ZERO {
            DVec3::Z
        } else {
            across
        }
    };
    let u = match longest.try_normalize() {
        Some(u) if u.dot(n).abs() < 1e-6 => u,
        _ => n.any_orthonormal_vector(),
    };
    (u, n.cross(u))
}

fn median_edge(polys: &[Vec<DVec3>]) -> f64 {
    let mut longest: Vec<f64> = polys
        .iter()
        .map(|p| {
            (0..p.len())
                .map(|i| p[i].distance(p[(i + 1) % p.len()]))
                .fold(0.0, f64::max)
        })
        .collect();
    if longest.is_empty() {
        return 1.0;
    }
    let mid = longest.len() / 2;
    *longest.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// Pairs `(a, b)`, `a < b`, whose boxes (grown by `eps`) overlap or touch, each once, sorted.
fn candidate_pairs(polys: &[Vec<DVec3>], eps: f64) -> Vec<(usize, usize)> {
    let boxes: Vec<(DVec3, DVec3)> = polys
        .iter()
        .map(|p| {
            let lo = p.iter().fold(DVec3::INFINITY, |a, b| a.min(*b)) - eps;
            let hi = p.iter().fold(DVec3::NEG_INFINITY, |a, b| a.max(*b)) + eps;
            (lo, hi)
        })
        .collect();
    // Cells of twice the median box diagonal: most elements fall in a few cells.
    let mut diag: Vec<f64> = boxes.iter().map(|(lo, hi)| lo.distance(*hi)).collect();
    let mid = diag.len() / 2;
    let cell = 2.0 * diag.select_nth_unstable_by(mid, f64::total_cmp).1.max(eps);
    let key = |p: DVec3| (p / cell).floor().as_i64vec3();
    // A few boxes far larger than the median (a game level's floor among its details) would
    // be in millions of cells: then the hierarchy of grids (at most 8 cells a box), which
    // costs more per box where boxes are alike (a tessellated sphere: 0.05 against 0.03 s).
    // Both give every overlapping pair, so the pairs are the same.
    if crowded(&boxes, cell) {
        return hierarchical_pairs(&boxes);
    }
    // (cell, box) for every cell a box meets, sorted: each cell's boxes are one run.
    let mut entries: Vec<([i64; 3], u32)> = Vec::with_capacity(boxes.len() * 2);
    for (s, (lo, hi)) in boxes.iter().enumerate() {
        let (a, b) = (key(*lo), key(*hi));
        for x in a.x..=b.x {
            for y in a.y..=b.y {
                for z in a.z..=b.z {
                    entries.push(([x, y, z], s as u32));
                }
            }
        }
    }
    entries.sort_unstable();
    let mut pairs = Vec::new();
    for cell in entries.chunk_by(|p, q| p.0 == q.0) {
        for (i, &(_, a)) in cell.iter().enumerate() {
            for &(_, b) in &cell[i + 1..] {
                let (a, b) = (a as usize, b as usize);
                if overlaps(boxes[a], boxes[b]) {
                    pairs.push((a.min(b), a.max(b)));
                }
            }
        }
    }
    pairs.sort_unstable();
    pairs.dedup();
    pairs
}

/// Whether `boxes` would fill more than 8 cells of size `cell` each on average (counted in
/// f64: an empty or infinite box counts as infinitely many, and goes to the hierarchy, which
/// leaves it in no cell).
fn crowded(boxes: &[(DVec3, DVec3)], cell: f64) -> bool {
    let key = |p: DVec3| (p / cell).floor();
    let cells: f64 = (boxes.iter())
        .map(|&(lo, hi)| {
            let span = key(hi) - key(lo) + 1.0;
            if span.is_finite() && span.min_element() >= 1.0 {
                span.element_product()
            } else {
                f64::INFINITY
            }
        })
        .sum();
    cells > (8 * boxes.len()) as f64
}

/// [`candidate_pairs`] of `boxes` through the hierarchy of grids.
fn hierarchical_pairs(boxes: &[(DVec3, DVec3)]) -> Vec<(usize, usize)> {
    let grid = BoxGrid::new(boxes);
    let mut pairs: Vec<(usize, usize)> = (0..boxes.len())
        .into_par_iter()
        .flat_map_iter(|a| {
            (grid.candidates(boxes[a]).into_iter())
                .map(|b| b as usize)
                .filter(move |&b| b > a && overlaps(boxes[a], boxes[b]))
                .map(move |b| (a, b))
        })
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    pairs
}

/// Same orientation and every corner of each on the other's plane.
fn coplanar(polys: &[Vec<DVec3>], normals: &[DVec3], a: usize, b: usize, eps: f64) -> bool {
    let (na, nb) = (normals[a], normals[b]);
    if na.dot(nb) < ANGLE.cos() {
        return false;
    }
    let on = |p: &[DVec3], n: DVec3, q: &[DVec3]| q.iter().all(|x| (*x - p[0]).dot(n).abs() <= eps);
    on(&polys[a], na, &polys[b]) && on(&polys[b], nb, &polys[a])
}

/// At least two distinct points of one polygon lie on the other's boundary.
fn share_edge(a: &[DVec3], b: &[DVec3], eps: f64) -> bool {
    let mut first: Option<DVec3> = None;
    for (p, q) in [(a, b), (b, a)] {
        for x in p {
            if !on_boundary(*x, q, eps) {
                continue;
            }
            match first {
                None => first = Some(*x),
                Some(t) if t.distance(*x) > eps => return true,
                Some(_) => {}
            }
        }
    }
    false
}

fn on_boundary(x: DVec3, poly: &[DVec3], eps: f64) -> bool {
    (0..poly.len()).any(|i| segment_distance(x, poly[i], poly[(i + 1) % poly.len()]) <= eps)
}

fn segment_distance(x: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let t = ((x - a).dot(ab) / ab.length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
    x.distance(a + t * ab)
}

/// Disjoint sets with path halving; the smaller index becomes the root, so the result does not
/// depend on the order of unions.
struct UnionFind(Vec<usize>);

impl UnionFind {
    fn new(n: usize) -> Self {
        Self((0..n).collect())
    }

    fn find(&mut self, mut x: usize) -> usize {
        while self.0[x] != x {
            self.0[x] = self.0[self.0[x]];
            x = self.0[x];
        }
        x
    }

    fn union(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.find(a), self.find(b));
        let (lo, hi) = (ra.min(rb), ra.max(rb));
        self.0[hi] = lo;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Tiles of a floor with one face across all of them and a few far apart: both ways of
    /// finding the pairs (the uniform grid for alike boxes, the hierarchy when one box would
    /// fill too many cells) give every overlapping pair, each once, as a scan of all pairs.
    #[test]
    fn candidate_pairs_are_every_overlapping_pair_either_way() {
        let square = |x: f64, y: f64, s: f64| {
            vec![
                DVec3::new(x, y, 0.0),
                DVec3::new(x + s, y, 0.0),
                DVec3::new(x + s, y + s, 0.0),
                DVec3::new(x, y + s, 0.0),
            ]
        };
        let mut polys: Vec<Vec<DVec3>> = Vec::new();
        for i in 0..30 {
            for j in 0..30 {
                polys.push(square(i as f64 * 0.1, j as f64 * 0.1, 0.1));
            }
        }
        polys.push(square(0.55, 0.55, 0.1));
        polys.push(square(-100.0, -100.0, 1.0));
        let eps = 1e-9;
        let scan = |polys: &[Vec<DVec3>]| {
            let boxes: Vec<(DVec3, DVec3)> = (polys.iter())
                .map(|p| {
                    let lo = p.iter().fold(DVec3::INFINITY, |a, b| a.min(*b)) - eps;
                    let hi = p.iter().fold(DVec3::NEG_INFINITY, |a, b| a.max(*b)) + eps;
                    (lo, hi)
                })
                .collect();
            let mut pairs = Vec::new();
            for a in 0..boxes.len() {
                for b in a + 1..boxes.len() {
                    if overlaps(boxes[a], boxes[b]) {
                        pairs.push((a, b));
                    }
                }
            }
            (boxes, pairs)
        };
        let (boxes, want) = scan(&polys);
        // Cells of twice the median diagonal; each box straddles z = 0, so two cells deep.
        let cell = 2.0 * (0.1f64 * 0.1 * 2.0 + 4.0 * eps * eps).sqrt();
        assert!(!crowded(&boxes, cell));
        assert_eq!(candidate_pairs(&polys, eps), want, "alike boxes");
        assert_eq!(
            hierarchical_pairs(&boxes),
            want,
            "the hierarchy on alike boxes"
        );
        // One face over the whole floor, about 63 000 cells of the uniform grid: the hierarchy.
        polys.push(square(-1.0, -1.0, 50.0));
        let (boxes, want) = scan(&polys);
        assert!(crowded(&boxes, cell));
        assert!(want.len() > 3 * 900);
        assert_eq!(candidate_pairs(&polys, eps), want, "one face over all");
    }

    /// Geometry of quads given by their corners (normals from the vertex order).
    fn geometry(quads: &[[[f32; 3]; 4]]) -> Geometry {
        let mut g = Geometry {
            vertex_count: vec![],
            vertices: vec![],
            normals: vec![],
        };
        for q in quads {
            g.vertex_count.push(4);
            g.vertices.extend(q.iter().flatten());
            let p: Vec<DVec3> = q
                .iter()
                .map(|c| DVec3::from_array(c.map(f64::from)))
                .collect();
            let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
            g.normals.extend([n.x as f32, n.y as f32, n.z as f32]);
        }
        g
    }

    fn square(x: f32, y: f32, s: f32, z: f32) -> [[f32; 3]; 4] {
        [[x, y, z], [x + s, y, z], [x + s, y + s, z], [x, y + s, z]]
    }

    #[test]
    fn a_grid_with_a_t_junction_is_one_chart_and_a_step_or_a_corner_splits_it() {
        // Two small squares beside one big one (T-junction), a square touching at a corner only,
        // and one a little above the plane.
        let g = geometry(&[
            square(0.0, 0.0, 2.0, 0.0),
            square(2.0, 0.0, 1.0, 0.0),
            square(2.0, 1.0, 1.0, 0.0),
            square(3.0, 2.0, 1.0, 0.0),
            square(-1.0, 0.0, 1.0, 0.01),
        ]);
        let c = charts(&g);
        let sets: Vec<Vec<u32>> = c.iter().map(|c| c.faces.clone()).collect();
        assert_eq!(sets, vec![vec![0, 1, 2], vec![3], vec![4]]);
        assert!((c[0].size - DVec2::new(3.0, 2.0)).abs().max_element() < 1e-6);
        // The frame flattens and lifts back, and u × v is the normal.
        let p = DVec3::new(2.5, 1.5, 0.0);
        assert!(c[0].lift(c[0].flatten(p)).distance(p) < 1e-9);
        assert!((c[0].u.cross(c[0].v) - DVec3::Z).length() < 1e-9);
    }

    #[test]
    fn degenerate_faces_get_finite_frames() {
        // A needle (two corners at one point, the first edge zero), a point, and a face whose
        // normal is zero.
        let mut g = geometry(&[square(0.0, 0.0, 1.0, 0.0)]);
        g.vertex_count.extend([3, 3]);
        g.vertices.extend([
            1.0, 1.0, 0.0, 1.0, 1.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 0.0, //
            5.0, 5.0, 5.0, 5.0, 5.0, 5.0, 5.0, 5.0, 5.0, 0.0, 0.0, 0.0,
        ]);
        g.normals.extend([0.0, 0.0, 1.0, 0.0, 0.0, 0.0]);
        for c in charts(&g) {
            for w in [c.u, c.v, c.origin] {
                assert!(w.is_finite(), "{c:?}");
            }
            assert!(
                (c.u.length() - 1.0).abs() < 1e-12 && c.u.dot(c.v).abs() < 1e-12,
                "{c:?}"
            );
        }
    }

    /// Quads around the axis z, each turned `step` degrees from the last (outward normals), from
    /// `from` degrees, `rise` up per quad.
    fn arc(count: usize, step: f64, from: f64, rise: f64) -> Vec<[[f32; 3]; 4]> {
        let at = |deg: f64, z: f64| {
            let a = deg.to_radians();
            [a.cos() as f32, a.sin() as f32, z as f32]
        };
        (0..count)
            .map(|i| {
                let (a, b) = (from + i as f64 * step, from + (i + 1) as f64 * step);
                let (z0, z1) = (i as f64 * rise, (i + 1) as f64 * rise);
                [at(a, z0), at(b, z1), at(b, z1 + 1.0), at(a, z0 + 1.0)]
            })
            .collect()
    }

    #[test]
    fn a_curved_strip_is_cut_into_charts_within_thirty_degrees() {
        // Normals 12° apart: quads 0–2 lie within 30° of quad 0 (0°, 12°, 24°), 3–5 of quad 3,
        // 6–7 of quad 6.
        let g = geometry(&arc(8, 12.0, 0.0, 0.0));
        let c = charts(&g);
        let sets: Vec<Vec<u32>> = c.iter().map(|c| c.faces.clone()).collect();
        assert_eq!(sets, vec![vec![0, 1, 2], vec![3, 4, 5], vec![6, 7]]);
        // Projected onto the first quad's plane, each chart keeps its faces apart.
        for chart in &c {
            let faces: Vec<usize> = chart.faces.iter().map(|&f| f as usize).collect();
            let polys: Vec<Vec<DVec3>> =
                (0..g.vertex_count.len()).map(|s| corners(&g, s)).collect();
            let axis = normal(&g, faces[0]);
            assert!(!projections_overlap(&polys, &faces, axis, 1e-9));
        }
    }

    #[test]
    fn a_surface_that_winds_over_itself_stays_single_faces() {
        // A ramp of 36 quads rising round a vertical axis twice: every normal within 30° of the
        // first (they lean out by under 30°), but the second turn lies over the first seen
        // along the first's normal.
        let mut quads = Vec::new();
        for i in 0..36 {
            let (a, b) = (
                (i as f64 * 20.0).to_radians(),
                ((i + 1) as f64 * 20.0).to_radians(),
            );
            let z = |t: f64| (t * 0.05) as f32;
            let (r0, r1) = (1.0f64, 2.0f64);
            let p = |r: f64, t: f64| [(r * t.cos()) as f32, (r * t.sin()) as f32, z(t)];
            quads.push([p(r0, a), p(r1, a), p(r1, b), p(r0, b)]);
        }
        let g = geometry(&quads);
        let normals: Vec<DVec3> = (0..36).map(|s| normal(&g, s)).collect();
        assert!(
            normals
                .iter()
                .all(|n| n.dot(normals[0]) > CURVED_ANGLE.cos())
        );
        let c = charts(&g);
        assert_eq!(
            c.len(),
            36,
            "{:?}",
            c.iter().map(|c| c.faces.len()).collect::<Vec<_>>()
        );
    }

    #[test]
    fn faces_touching_along_an_edge_do_not_overlap() {
        let a = [
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(1.0, 1.0),
        ];
        let b = [
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 1.0),
            DVec2::new(0.0, 1.0),
        ];
        assert!(!convex_overlap(&a, &b, 1e-9));
        let c = [
            DVec2::new(0.5, 0.0),
            DVec2::new(1.5, 0.0),
            DVec2::new(1.5, 1.0),
        ];
        assert!(convex_overlap(&a, &c, 1e-9));
    }

    #[test]
    fn opposite_sides_of_a_wall_are_different_charts() {
        let front = square(0.0, 0.0, 1.0, 0.0);
        let mut back = front;
        back.reverse();
        let c = charts(&geometry(&[front, back]));
        assert_eq!(c.len(), 2);
    }
}
