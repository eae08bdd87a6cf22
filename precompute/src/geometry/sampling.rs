//! Deterministic sample points on elements and patches.
//!
//! Quadrature points on an element integrate the point-to-patch kernel over the element's area;
//! their count `S` is the bake's `--samples`. When `S` is a perfect square `m²` the points are a
//! midpoint rule (m×m cell centres of a quad's bilinear map, or the centroids of the m² similar
//! sub-triangles of a triangle): O(h²) accurate on the smooth kernel and free of clustering.
//! Otherwise the R2 low-discrepancy sequence (Roberts 2018) is used, folded onto triangles.
//!
//! Points on the *patch* end of a visibility ray use the R2 sequence shifted by a hash of the
//! (element, patch) pair (Cranley–Patterson rotation): deterministic, independent of thread
//! count and order of evaluation, and decorrelated between pairs.

use glam::DVec3;

use super::Polygon;
use super::hash::mix;

/// A quadrature point with its weight (weights of one element sum to 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Position in scene units.
    pub point: DVec3,
    /// Quadrature weight (the weights of one polygon sum to 1).
    pub weight: f64,
}

/// The plastic-number constants of the R2 sequence.
const R2_A1: f64 = 0.754_877_666_246_692_8;
const R2_A2: f64 = 0.569_840_290_998_053_2;

/// The Cranley–Patterson rotation of the R2 sequence for `seed`: two uniform numbers in
/// [0, 1) from its hash.
pub(crate) fn shift(seed: u64) -> (f64, f64) {
    let h = mix(seed);
    (
        (h >> 11) as f64 / (1u64 << 53) as f64,
        (mix(h) >> 11) as f64 / (1u64 << 53) as f64,
    )
}

/// `i`-th point of the R2 sequence in the unit square, shifted by `shift`.
pub(crate) fn r2(i: u32, shift: (f64, f64)) -> (f64, f64) {
    let i = f64::from(i);
    (
        (0.5 + shift.0 + R2_A1 * i).fract(),
        (0.5 + shift.1 + R2_A2 * i).fract(),
    )
}

/// Quadrature points on a polygon (3 or 4 vertices), `count` of them.
pub fn quadrature(polygon: &Polygon, count: u32, out: &mut Vec<Sample>) {
    out.clear();
    let count = count.max(1);
    let m = (f64::from(count).sqrt().round()) as u32;
    let v = polygon.vertices();
    if m * m == count {
        if v.len() == 3 {
            triangle_midpoints(v, m, out);
        } else {
            quad_midpoints(v, m, out);
        }
    } else {
        for i in 0..count {
            let (u, w) = r2(i, (0.0, 0.0));
            out.push(map_unit_square(v, u, w));
        }
        normalise(out);
    }
}

/// Quadrature points on a union of polygons (`parts`, with anything beside each), `count` of
/// them: the R2 sequence's first coordinate picks the part by area and places the point
/// across it, the second along it (as [`crate::geometry::Region::pair_point`] does, unshifted),
/// each weighted by the part's local area density so that the weights integrate uniformly
/// over the union and sum to 1. An element lit on its parts (`Element::on_parts`) is
/// integrated with them.
pub fn quadrature_parts<T>(parts: &[(T, Polygon)], count: u32, out: &mut Vec<Sample>) {
    out.clear();
    // Running sums of the parts' areas, from 0, worked out once.
    let mut cumulative = Vec::with_capacity(parts.len() + 1);
    cumulative.push(0.0);
    for (_, p) in parts {
        cumulative.push(cumulative[cumulative.len() - 1] + p.area());
    }
    let total = cumulative[parts.len()];
    if parts.is_empty() || total.is_nan() || total <= 0.0 {
        return;
    }
    for i in 0..count.max(1) {
        let (u, w) = r2(i, (0.0, 0.0));
        let a = u * total;
        // The first part whose running sum exceeds a.
        let pick = cumulative[1..]
            .partition_point(|&c| c <= a)
            .min(parts.len() - 1);
        let (part, lo) = (&parts[pick].1, cumulative[pick]);
        let area = part.area();
        let u = ((a - lo) / area).clamp(0.0, 1.0);
        let mut s = map_unit_square(part.vertices(), u, w);
        if part.count == 4 {
            s.weight /= area; // the bilinear Jacobian relative to the part's area
        }
        out.push(s);
    }
    normalise(out);
}

/// The `i`-th point of a pair-specific sequence on a polygon (for the far end of a ray), with
/// its area density relative to uniform (the bilinear Jacobian of a quad; 1 on triangles).
/// Ray weights must include it: a wedge-shaped quad's bilinear map crowds points toward its
/// short side, and unweighted rays biased Cornell-box view factors by 0.2%.
pub(crate) fn pair_point(polygon: &Polygon, i: u32, seed: u64) -> Sample {
    let shift = shift(seed);
    let (u, w) = r2(i, shift);
    let mut s = map_unit_square(polygon.vertices(), u, w);
    if polygon.count == 4 {
        s.weight /= polygon.area(); // Jacobian / area: 1 on average
    }
    s
}

/// Maps (u, w) in the unit square onto the polygon; the weight is the local area density.
pub(crate) fn map_unit_square(v: &[DVec3], u: f64, w: f64) -> Sample {
    if v.len() == 3 {
        // Fold the square onto the triangle: area-preserving.
        let (u, w) = if u + w > 1.0 {
            (1.0 - u, 1.0 - w)
        } else {
            (u, w)
        };
        Sample {
            point: v[0] + (v[1] - v[0]) * u + (v[2] - v[0]) * w,
            weight: 1.0,
        }
    } else {
        bilinear(v, u, w)
    }
}

/// Bilinear map of a quad with its Jacobian as the (unnormalised) weight.
fn bilinear(v: &[DVec3], u: f64, w: f64) -> Sample {
    let point = v[0] * ((1.0 - u) * (1.0 - w))
        + v[1] * (u * (1.0 - w))
        + v[2] * (u * w)
        + v[3] * ((1.0 - u) * w);
    let du = (v[1] - v[0]) * (1.0 - w) + (v[2] - v[3]) * w;
    let dw = (v[3] - v[0]) * (1.0 - u) + (v[2] - v[1]) * u;
    Sample {
        point,
        weight: du.cross(dw).length(),
    }
}

fn quad_midpoints(v: &[DVec3], m: u32, out: &mut Vec<Sample>) {
    let step = 1.0 / f64::from(m);
    for j in 0..m {
        for i in 0..m {
            let u = (f64::from(i) + 0.5) * step;
            let w = (f64::from(j) + 0.5) * step;
            out.push(bilinear(v, u, w));
        }
    }
    normalise(out);
}

/// Centroids of the m² congruent sub-triangles (m divisions per edge): equal weights.
fn triangle_midpoints(v: &[DVec3], m: u32, out: &mut Vec<Sample>) {
    let e1 = (v[1] - v[0]) / f64::from(m);
    let e2 = (v[2] - v[0]) / f64::from(m);
    let weight = 1.0 / f64::from(m * m);
    for j in 0..m {
        for i in 0..m - j {
            let a = v[0] + e1 * f64::from(i) + e2 * f64::from(j);
            // upward triangle (a, a+e1, a+e2)
            out.push(Sample {
                point: a + (e1 + e2) / 3.0,
                weight,
            });
            if i + j + 1 < m {
                // downward triangle (a+e1, a+e1+e2, a+e2)
                out.push(Sample {
                    point: a + (e1 + e2) * (2.0 / 3.0),
                    weight,
                });
            }
        }
    }
}

fn normalise(out: &mut [Sample]) {
    let total: f64 = out.iter().map(|s| s.weight).sum();
    if total > 0.0 {
        for s in out.iter_mut() {
            s.weight /= total;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> Polygon {
        Polygon::new(&[
            DVec3::ZERO,
            DVec3::new(3.0, 0.0, 0.0),
            DVec3::new(0.0, 2.0, 0.0),
        ])
        .unwrap()
    }

    fn trapezoid() -> Polygon {
        Polygon::new(&[
            DVec3::ZERO,
            DVec3::new(4.0, 0.0, 0.0),
            DVec3::new(3.0, 1.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
        ])
        .unwrap()
    }

    fn parallelogram() -> Polygon {
        Polygon::new(&[
            DVec3::ZERO,
            DVec3::new(3.0, 0.0, 0.0),
            DVec3::new(4.0, 1.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
        ])
        .unwrap()
    }

    /// Distance between the weighted mean of the points and the centroid.
    fn centroid_error(p: &Polygon, count: u32) -> f64 {
        let mut s = Vec::new();
        quadrature(p, count, &mut s);
        assert_eq!(s.len(), count as usize);
        let w: f64 = s.iter().map(|s| s.weight).sum();
        assert!((w - 1.0).abs() < 1e-12);
        let c: DVec3 = s.iter().map(|s| s.point * s.weight).sum();
        (c - p.centroid()).length()
    }

    #[test]
    fn midpoint_rules_are_exact_for_linear_functions_on_affine_shapes() {
        for count in [1, 4, 9, 16, 25] {
            assert!(centroid_error(&tri(), count) < 1e-12);
            assert!(centroid_error(&parallelogram(), count) < 1e-12);
        }
    }

    #[test]
    fn midpoint_rule_on_a_trapezoid_converges_quadratically() {
        // The bilinear Jacobian makes the integrand quadratic: O(h²) error.
        let e4 = centroid_error(&trapezoid(), 4);
        let e16 = centroid_error(&trapezoid(), 16);
        let e64 = centroid_error(&trapezoid(), 64);
        assert!(e16 < e4 / 3.5 && e64 < e16 / 3.5, "{e4} {e16} {e64}");
    }

    #[test]
    fn r2_points_are_close_to_centroid() {
        // The fallback for non-square counts: within ~3% of the shapes' size (3).
        for count in [50, 99, 200] {
            assert!(centroid_error(&tri(), count) < 0.1);
            assert!(centroid_error(&parallelogram(), count) < 0.1);
        }
    }

    #[test]
    fn pair_points_lie_inside_and_depend_on_seed() {
        let p = trapezoid();
        let a = pair_point(&p, 0, 1).point;
        let b = pair_point(&p, 0, 2).point;
        assert_ne!(a, b);
        let mut mean_weight = 0.0;
        for i in 0..64 {
            mean_weight += pair_point(&p, i, 7).weight / 64.0;
            let x = pair_point(&p, i, 7).point;
            assert!(x.y >= 0.0 && x.y <= 1.0 && x.x >= x.y - 1e-12 && x.x <= 4.0 - x.y + 1e-12);
        }
        assert!((mean_weight - 1.0).abs() < 0.05, "{mean_weight}");
    }
}
