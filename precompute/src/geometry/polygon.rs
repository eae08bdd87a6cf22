//! Planar convex polygons: the shape of every face, element and patch part.
//!
//! [`Polygon`] keeps up to four vertices (counter-clockwise around its unit normal) with the
//! quantities the form-factor kernel and the meshers need precomputed; [`area_vector`] is
//! Newell's area vector. All tolerances built on [`Polygon::scale`] are relative to the
//! polygon's size, so nothing here depends on the scene's units.

use glam::DVec3;

/// A planar convex polygon (3 or 4 vertices, counter-clockwise around `normal`), with the
/// quantities the kernel needs precomputed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Polygon {
    /// Vertices in scene units; only the first `count` are used, the rest stay zero.
    pub vertices: [DVec3; 4],
    /// Number of vertices: 3 or 4.
    pub count: usize,
    /// Unit normal of the front side (counter-clockwise vertex order).
    pub normal: DVec3,
    /// Length scale for tolerances: square root of the area.
    pub scale: f64,
}

impl Polygon {
    /// Builds a polygon from 3 or 4 vertices; the normal comes from the vertex order.
    /// Returns `None` for a degenerate polygon (zero area) or a wrong vertex count.
    pub fn new(vertices: &[DVec3]) -> Option<Self> {
        if !(3..=4).contains(&vertices.len()) {
            return None;
        }
        let area_vector = area_vector(vertices);
        let twice_area = area_vector.length();
        if twice_area.is_nan() || twice_area <= 0.0 || !twice_area.is_finite() {
            return None;
        }
        let mut v = [DVec3::ZERO; 4];
        v[..vertices.len()].copy_from_slice(vertices);
        Some(Self {
            vertices: v,
            count: vertices.len(),
            normal: area_vector / twice_area,
            scale: (0.5 * twice_area).sqrt(),
        })
    }

    /// The `count` used vertices.
    pub fn vertices(&self) -> &[DVec3] {
        &self.vertices[..self.count]
    }

    /// Area in scene units².
    pub fn area(&self) -> f64 {
        0.5 * area_vector(self.vertices()).length()
    }

    /// Area-weighted centroid.
    pub fn centroid(&self) -> DVec3 {
        // Area-weighted centroid of the fan triangles (exact for any planar convex polygon).
        let v = self.vertices();
        let mut sum = DVec3::ZERO;
        let mut weight = 0.0;
        for i in 1..v.len() - 1 {
            let a = 0.5 * (v[i] - v[0]).cross(v[i + 1] - v[0]).length();
            sum += a * (v[0] + v[i] + v[i + 1]) / 3.0;
            weight += a;
        }
        sum / weight
    }

    /// The size meshing compares with the element and patch sizes: the longest edge of a quad,
    /// the second-longest edge of a triangle (so the two triangles of a split quad refine like
    /// the quad, not like its diagonal; a sliver still refines along its length).
    pub fn size(&self) -> f64 {
        if self.count == 3 {
            let v = self.vertices();
            let mut e = [
                (v[1] - v[0]).length(),
                (v[2] - v[1]).length(),
                (v[0] - v[2]).length(),
            ];
            e.sort_by(f64::total_cmp);
            e[1]
        } else {
            self.max_edge()
        }
    }

    /// Longest edge.
    pub fn max_edge(&self) -> f64 {
        let v = self.vertices();
        (0..v.len())
            .map(|i| (v[(i + 1) % v.len()] - v[i]).length())
            .fold(0.0, f64::max)
    }

    /// Signed distance of `x` from the polygon's plane (positive in front).
    pub fn height(&self, x: DVec3) -> f64 {
        (x - self.vertices[0]).dot(self.normal)
    }
}

/// Twice the area times the unit normal (Newell's method, robust for slightly non-planar input).
pub fn area_vector(v: &[DVec3]) -> DVec3 {
    let mut s = DVec3::ZERO;
    for i in 0..v.len() {
        s += v[i].cross(v[(i + 1) % v.len()]);
    }
    s
}

/// An axis-aligned rectangle `[x0, x1] × [y0, y1]` at height `z`, facing +z (or −z when
/// `down`): the fixture of the geometry and form-factor unit tests.
#[cfg(test)]
pub(crate) fn rectangle(x0: f64, x1: f64, y0: f64, y1: f64, z: f64, down: bool) -> Polygon {
    let mut v = vec![
        DVec3::new(x0, y0, z),
        DVec3::new(x1, y0, z),
        DVec3::new(x1, y1, z),
        DVec3::new(x0, y1, z),
    ];
    if down {
        v.reverse();
    }
    Polygon::new(&v).unwrap()
}

/// Relative slack of a size test: a node whose size equals the element or patch size up to
/// rounding fits it. A room 8 element sizes wide, scaled by 1e-3, has nodes of
/// 1.2500000000000002e-4 against a size of 1.25e-4: without the slack some were split once
/// more, and the scaled dense sphere meshed to 910 elements instead of 724.
const SIZE_SLACK: f64 = 1e-9;

/// Whether `size` is at most `limit` (a mesh size), up to rounding ([`SIZE_SLACK`]).
pub(crate) fn within(size: f64, limit: f64) -> bool {
    size <= limit * (1.0 + SIZE_SLACK)
}

/// Whether `long` is at least `ratio` times `short` up to rounding ([`SIZE_SLACK`]): a
/// rectangle of exactly two to one stays two to one when its scene is scaled by 0.01.
pub(crate) fn at_least(long: f64, ratio: f64, short: f64) -> bool {
    long >= ratio * short * (1.0 - SIZE_SLACK)
}
