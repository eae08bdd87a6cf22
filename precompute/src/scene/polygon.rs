//! Splitting input polygons into planar convex pieces of 3 or 4 vertices.

use glam::DVec3;

use crate::geometry::{Polygon, area_vector};

/// Relative tolerance for planarity and degeneracy tests (scale-free: relative to edge lengths).
const PLANAR_TOLERANCE: f64 = 1e-6;
const DEGENERATE_TOLERANCE: f64 = 1e-14;

/// Splits a polygon (counter-clockwise front) into planar convex pieces of 3 or 4 vertices.
/// Returns `None` when it has no area.
pub(super) fn split_convex(input: &[DVec3]) -> Option<Vec<Vec<DVec3>>> {
    let v = dedup(input);
    if v.len() < 3 {
        return None;
    }
    let normal_area = area_vector(&v);
    let max_edge = (0..v.len())
        .map(|i| (v[(i + 1) % v.len()] - v[i]).length())
        .fold(0.0, f64::max);
    if normal_area.length() <= DEGENERATE_TOLERANCE * max_edge * max_edge {
        return None;
    }
    let n = normal_area.normalize();
    if v.len() == 3 {
        return Some(vec![v]);
    }
    if v.len() == 4 && is_planar(&v, n, max_edge) && is_convex(&v, n) {
        return Some(vec![v]);
    }
    let triangles: Vec<Vec<DVec3>> = ear_clip(&v, n)
        .into_iter()
        .filter(|t| area_vector(t).length() > DEGENERATE_TOLERANCE * max_edge * max_edge)
        .collect();
    if triangles.is_empty() {
        None
    } else {
        Some(triangles)
    }
}

/// For a polygon of 4 or more distinct vertices that is not planar (a vertex farther than
/// `PLANAR_TOLERANCE` × its longest edge from the plane through its centroid with Newell's
/// normal): that largest distance and the longest edge.
pub(super) fn non_planar(input: &[DVec3]) -> Option<(f64, f64)> {
    let v = dedup(input);
    if v.len() < 4 {
        return None;
    }
    let n = area_vector(&v).normalize_or_zero();
    let centre = v.iter().copied().sum::<DVec3>() / v.len() as f64;
    let off = v
        .iter()
        .map(|p| (*p - centre).dot(n).abs())
        .fold(0.0, f64::max);
    let edge = (0..v.len())
        .map(|i| (v[(i + 1) % v.len()] - v[i]).length())
        .fold(0.0, f64::max);
    (off > PLANAR_TOLERANCE * edge).then_some((off, edge))
}

fn dedup(input: &[DVec3]) -> Vec<DVec3> {
    let mut v: Vec<DVec3> = Vec::with_capacity(input.len());
    for p in input {
        if v.last() != Some(p) {
            v.push(*p);
        }
    }
    while v.len() > 1 && v.first() == v.last() {
        v.pop();
    }
    v
}

fn is_planar(v: &[DVec3], n: DVec3, size: f64) -> bool {
    v.iter()
        .all(|p| (*p - v[0]).dot(n).abs() <= PLANAR_TOLERANCE * size)
}

fn is_convex(v: &[DVec3], n: DVec3) -> bool {
    (0..v.len()).all(|i| {
        let a = v[i];
        let b = v[(i + 1) % v.len()];
        let c = v[(i + 2) % v.len()];
        (b - a).cross(c - b).dot(n) > 0.0
    })
}

/// Ear clipping in the plane of the polygon's average normal. For a non-planar quad this picks
/// the diagonal that keeps both triangles facing the front; for convex input it is a fan.
fn ear_clip(v: &[DVec3], n: DVec3) -> Vec<Vec<DVec3>> {
    let mut idx: Vec<usize> = (0..v.len()).collect();
    let mut out = Vec::new();
    let mut guard = 0;
    while idx.len() > 3 && guard < 10 * v.len() {
        guard += 1;
        let m = idx.len();
        // Prefer the ear with the shortest diagonal (better-shaped triangles).
        let mut best: Option<(usize, f64)> = None;
        for i in 0..m {
            let (a, b, c) = (v[idx[(i + m - 1) % m]], v[idx[i]], v[idx[(i + 1) % m]]);
            if (b - a).cross(c - b).dot(n) <= 0.0 {
                continue; // reflex or flat corner
            }
            let contains_other = idx.iter().any(|&j| {
                let p = v[j];
                p != a && p != b && p != c && in_triangle(p, a, b, c, n)
            });
            if contains_other {
                continue;
            }
            let d = (c - a).length();
            if best.is_none_or(|(_, bd)| d < bd) {
                best = Some((i, d));
            }
        }
        let Some((i, _)) = best else { break };
        let m = idx.len();
        out.push(vec![
            v[idx[(i + m - 1) % m]],
            v[idx[i]],
            v[idx[(i + 1) % m]],
        ]);
        idx.remove(i);
    }
    if idx.len() == 3 {
        out.push(idx.iter().map(|&i| v[i]).collect());
    }
    out
}

fn in_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3, n: DVec3) -> bool {
    let s1 = (b - a).cross(p - a).dot(n);
    let s2 = (c - b).cross(p - b).dot(n);
    let s3 = (a - c).cross(p - c).dot(n);
    s1 >= 0.0 && s2 >= 0.0 && s3 >= 0.0
}

/// Key identifying a face by its vertex set and side, for duplicate detection.
pub(super) fn duplicate_key(p: &Polygon) -> Vec<[i64; 3]> {
    let q = p.scale * 1e-9;
    let quantise = |v: &DVec3| {
        [
            (v.x / q).round() as i64,
            (v.y / q).round() as i64,
            (v.z / q).round() as i64,
        ]
    };
    let mut key: Vec<[i64; 3]> = p.vertices().iter().map(quantise).collect();
    key.sort_unstable();
    let side = p.normal * 1e6;
    key.push([
        side.x.round() as i64,
        side.y.round() as i64,
        side.z.round() as i64,
    ]);
    key
}

#[cfg(test)]
mod tests {
    use super::*;

    fn d(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x, y, z)
    }

    #[test]
    fn planar_convex_quad_stays_whole() {
        let q = [d(0., 0., 0.), d(1., 0., 0.), d(1., 1., 0.), d(0., 1., 0.)];
        assert_eq!(split_convex(&q).unwrap().len(), 1);
    }

    #[test]
    fn non_planar_quad_is_split_and_keeps_orientation() {
        let q = [d(0., 0., 0.), d(1., 0., 0.), d(1., 1., 0.1), d(0., 1., 0.)];
        let pieces = split_convex(&q).unwrap();
        assert_eq!(pieces.len(), 2);
        for p in pieces {
            assert!(area_vector(&p).z > 0.0);
        }
    }

    #[test]
    fn concave_and_large_polygons_are_triangulated() {
        // An L shape (6 vertices, one reflex corner): total area 3.
        let l = [
            d(0., 0., 0.),
            d(2., 0., 0.),
            d(2., 1., 0.),
            d(1., 1., 0.),
            d(1., 2., 0.),
            d(0., 2., 0.),
        ];
        let pieces = split_convex(&l).unwrap();
        let area: f64 = pieces.iter().map(|p| 0.5 * area_vector(p).length()).sum();
        assert!((area - 3.0).abs() < 1e-12);
        for p in &pieces {
            assert!(area_vector(p).z > 0.0);
        }
    }

    #[test]
    fn degenerate_faces_are_rejected() {
        assert!(split_convex(&[d(0., 0., 0.), d(1., 0., 0.), d(2., 0., 0.)]).is_none());
        assert!(split_convex(&[d(0., 0., 0.), d(0., 0., 0.), d(1., 0., 0.)]).is_none());
    }

    #[test]
    fn slivers_are_kept() {
        // Aspect ratio 1e4 is thin but not degenerate.
        let s = [d(0., 0., 0.), d(1., 0., 0.), d(0.5, 1e-4, 0.)];
        assert!(split_convex(&s).is_some());
    }
}
