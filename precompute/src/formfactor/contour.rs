//! The unoccluded point-to-polygon form factor, in closed form.
//!
//! For a point `x` with unit normal `n` and a planar convex polygon `P`, Lambert's contour
//! integral gives the form factor (the fraction of the energy leaving a differential area at `x`
//! that arrives on `P`):
//!
//! ```text
//! F(x → P) = 1/(2π) | Σ_i  γ_i  n · (r_i × r_{i+1}) / |r_i × r_{i+1}| |
//! ```
//!
//! with `r_i = v_i - x` and `γ_i` the angle between `r_i` and `r_{i+1}`. The formula is only
//! valid for the part of `P` above the tangent plane of `x`, so `P` is first clipped to that
//! half-space (Sutherland–Hodgman against one plane). It stays exact however close `x` is to
//! `P`, which is why it is used instead of sampling `cos θx cos θy / (π r²)` (that blows up for
//! neighbouring and edge-sharing elements).
//!
//! Faces are one-sided: a point behind `P`'s plane (or in it) receives nothing from `P`'s front.
//! All tolerances are relative to the polygon's size, so the kernel is scale-free.

use glam::DVec3;

use crate::geometry::Polygon;

/// Most vertices a clipped polygon can have: a quad clipped by one plane gets at most 5.
const MAX_CLIPPED: usize = 8;

/// The form factor from a differential area at `x` (unit normal `n`) to the front of `p`.
pub(super) fn point_to_polygon(x: DVec3, n: DVec3, p: &Polygon) -> f64 {
    let eps = 1e-12 * p.scale;
    if p.height(x) <= eps {
        return 0.0; // behind the one-sided polygon or in its plane
    }
    let mut clipped = [DVec3::ZERO; MAX_CLIPPED];
    let m = clip_to_hemisphere(x, n, p.vertices(), eps, &mut clipped);
    if m < 3 {
        return 0.0;
    }
    let mut sum = 0.0;
    for i in 0..m {
        let a = clipped[i];
        let b = clipped[(i + 1) % m];
        let c = a.cross(b);
        let c_len = c.length();
        if c_len <= 0.0 {
            continue; // x on the edge's line: the edge subtends no angle
        }
        let gamma = c_len.atan2(a.dot(b));
        sum += gamma * n.dot(c) / c_len;
    }
    (sum.abs() / (2.0 * std::f64::consts::PI)).min(1.0)
}

/// The form factor from `x` (unit normal `n`) to a planar region of several parts, by the
/// contour integral over its outline (the edges the parts do not share; module docs). Valid
/// where no part needs clipping: `x` in front of the region's plane and every outline vertex
/// on or above `x`'s tangent plane (`multi_part` checks both). Equal to the sum of
/// [`point_to_polygon`] over the parts up to rounding: a shared edge contributes to its two
/// parts with opposite signs.
pub(super) fn point_to_outline(x: DVec3, n: DVec3, edges: &[(DVec3, DVec3)]) -> f64 {
    let mut sum = 0.0;
    for &(a, b) in edges {
        let (a, b) = (a - x, b - x);
        let c = a.cross(b);
        let c_len = c.length();
        if c_len <= 0.0 {
            continue;
        }
        let gamma = c_len.atan2(a.dot(b));
        sum += gamma * n.dot(c) / c_len;
    }
    sum.abs() / (2.0 * std::f64::consts::PI)
}

/// Clips the polygon to the half-space `(v - x)·n >= 0`, writing vertices relative to `x`.
/// Returns the number of vertices written.
fn clip_to_hemisphere(
    x: DVec3,
    n: DVec3,
    vertices: &[DVec3],
    eps: f64,
    out: &mut [DVec3; MAX_CLIPPED],
) -> usize {
    let mut m = 0;
    let count = vertices.len();
    for i in 0..count {
        let a = vertices[i] - x;
        let b = vertices[(i + 1) % count] - x;
        let ha = a.dot(n);
        let hb = b.dot(n);
        let a_in = ha >= -eps;
        let b_in = hb >= -eps;
        if a_in {
            out[m] = a;
            m += 1;
        }
        if a_in != b_in {
            let t = ha / (ha - hb);
            out[m] = a + (b - a) * t;
            m += 1;
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(z: f64, side: f64, facing_down: bool) -> Polygon {
        let h = side / 2.0;
        let mut v = vec![
            DVec3::new(-h, -h, z),
            DVec3::new(h, -h, z),
            DVec3::new(h, h, z),
            DVec3::new(-h, h, z),
        ];
        if facing_down {
            v.reverse();
        }
        Polygon::new(&v).unwrap()
    }

    #[test]
    fn point_under_infinite_like_plane_sees_everything() {
        // A huge polygon right above the point covers almost the whole hemisphere.
        let p = square(1.0, 1e6, true);
        let f = point_to_polygon(DVec3::ZERO, DVec3::Z, &p);
        assert!((f - 1.0).abs() < 1e-5, "{f}");
    }

    #[test]
    fn point_on_axis_of_square_matches_closed_form() {
        // Point on the axis of a parallel square of side 2a at height h: four corner rectangles,
        // each F = 1/(2π) [2 X/√(1+X²) atan(X/√(1+X²))] with X = a/h; for a = h = 1 the total
        // is (4/π) s atan(s) with s = 1/√2.
        let p = square(1.0, 2.0, true);
        let f = point_to_polygon(DVec3::ZERO, DVec3::Z, &p);
        let s = 1.0 / 2f64.sqrt();
        let expected = 4.0 / std::f64::consts::PI * s * s.atan();
        assert!((f - expected).abs() < 1e-12, "{f} vs {expected}");
    }

    #[test]
    fn back_facing_and_coplanar_give_zero() {
        let up = square(1.0, 2.0, false); // faces away from the origin
        assert_eq!(point_to_polygon(DVec3::ZERO, DVec3::Z, &up), 0.0);
        let coplanar = square(0.0, 2.0, true);
        assert_eq!(
            point_to_polygon(DVec3::new(5.0, 0.0, 0.0), DVec3::Z, &coplanar),
            0.0
        );
    }

    #[test]
    fn polygon_behind_tangent_plane_is_clipped() {
        // A wall crossing the point's tangent plane: only the upper half counts.
        let wall = Polygon::new(&[
            DVec3::new(1.0, -1.0, -1.0),
            DVec3::new(1.0, -1.0, 1.0),
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(1.0, 1.0, -1.0),
        ])
        .unwrap();
        assert!(wall.normal.x < 0.0);
        let upper = Polygon::new(&[
            DVec3::new(1.0, -1.0, 0.0),
            DVec3::new(1.0, -1.0, 1.0),
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(1.0, 1.0, 0.0),
        ])
        .unwrap();
        let x = DVec3::ZERO;
        let f_wall = point_to_polygon(x, DVec3::Z, &wall);
        let f_upper = point_to_polygon(x, DVec3::Z, &upper);
        assert!(f_wall > 0.0);
        assert!((f_wall - f_upper).abs() < 1e-14);
    }

    #[test]
    fn scale_free() {
        let p = square(1.0, 2.0, true);
        let f1 = point_to_polygon(DVec3::new(0.3, 0.1, 0.0), DVec3::Z, &p);
        for s in [1e-3, 1e4] {
            let v: Vec<DVec3> = p.vertices().iter().map(|v| *v * s).collect();
            let q = Polygon::new(&v).unwrap();
            let f = point_to_polygon(DVec3::new(0.3, 0.1, 0.0) * s, DVec3::Z, &q);
            assert!((f - f1).abs() < 1e-12 * f1, "{f} vs {f1}");
        }
    }

    #[test]
    fn closed_cube_point_sums_to_one() {
        // A point on the floor of a unit cube sees the 5 other faces: their sum is 1.
        let c = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        let faces = [
            [c(0., 0., 1.), c(0., 1., 1.), c(1., 1., 1.), c(1., 0., 1.)], // ceiling, facing -z
            [c(0., 0., 0.), c(0., 0., 1.), c(1., 0., 1.), c(1., 0., 0.)], // y=0 wall, +y
            [c(0., 1., 0.), c(1., 1., 0.), c(1., 1., 1.), c(0., 1., 1.)], // y=1 wall, -y
            [c(0., 0., 0.), c(0., 1., 0.), c(0., 1., 1.), c(0., 0., 1.)], // x=0 wall, +x
            [c(1., 0., 0.), c(1., 0., 1.), c(1., 1., 1.), c(1., 1., 0.)], // x=1 wall, -x
        ];
        let x = c(0.2, 0.7, 0.0);
        let total: f64 = faces
            .iter()
            .map(|f| {
                let p = Polygon::new(f).unwrap();
                assert!(p.height(c(0.5, 0.5, 0.5)) > 0.0, "faces must look inward");
                point_to_polygon(x, DVec3::Z, &p)
            })
            .sum();
        assert!((total - 1.0).abs() < 1e-13, "{total}");
    }
}
