//! Form-factor targets made of several convex polygons: the clustered patches of dense meshes.
//!
//! A patch built by clustering (see [`crate::geometry::cluster`]) is a union of the small input
//! faces it groups, not one polygon. Form factors are additive over disjoint parts, so
//!
//! ```text
//! F(e → T) = Σ_parts F_unoccluded(e → part) · visibility(e, T)
//! ```
//!
//! with the closed-form kernel summed over the parts (exact, `S × parts` kernel evaluations per
//! pair) and one kernel-weighted visibility fraction over the whole target: segment `i` ends on
//! the part an area-proportional choice picks, so the rays sample the union uniformly by area.
//! The rays of one pair are grouped by the part they land on and each group is answered by one
//! [`Occluder::occluded_bundle`] call (a bundle is a coherent set between two polygons).
//!
//! A one-part target is handled by the single-polygon code of [`super::FormFactors::row`],
//! unchanged: 2MF bakes of meshes without clusters give the same bytes as before targets had parts.

use crate::geometry::Region;

use super::contour::{point_to_outline, point_to_polygon};
use super::visible::{Shape, faces_away_from, visible_fraction};
use crate::geometry::Outline;
use crate::geometry::Polygon;
use crate::geometry::sampling::Sample;
use crate::visibility::{Clear, Occluder};

/// `F(e → target)` for a target of several parts, the rays cast and the visible fraction
/// (`None` when every part faces away from `e`: a culled pair).
pub(super) fn multi_part(
    occluder: Option<&dyn Occluder>,
    (e, e_parts): (&Polygon, &[(u32, Polygon)]),
    points: &[Sample],
    target: &Region,
    seed: u64,
    adaptive: u32,
    ends: (Clear, &[Clear]),
) -> Option<(f64, u64, f64)> {
    let mut unoccluded = 0.0;
    let mut any = false;
    let outline = target.outline().filter(|o| outline_applies(e, e_parts, o));
    if let Some(outline) = outline {
        // Every part faces `e` unclipped: the outline's contour integral is their sum.
        any = true;
        unoccluded = points
            .iter()
            .map(|s| s.weight * point_to_outline(s.point, e.normal, &outline.edges))
            .sum::<f64>();
    }
    let parts = if outline.is_some() {
        &[][..]
    } else {
        target.kernel_parts()
    };
    for part in parts {
        if faces_away_from(e, e_parts, part) {
            continue;
        }
        any = true;
        unoccluded += points
            .iter()
            .map(|s| s.weight * point_to_polygon(s.point, e.normal, part))
            .sum::<f64>();
    }
    if !any {
        return None;
    }
    if unoccluded <= 0.0 {
        return Some((0.0, 0, 1.0));
    }
    let Some(occ) = occluder else {
        return Some((unoccluded, 0, 1.0));
    };
    let (visible, rays) = visible_fraction(
        occ,
        e,
        Shape::Union(target),
        ends,
        points,
        seed,
        adaptive,
        if target.outline().is_some() {
            1
        } else {
            rounds(e, target)
        },
    );
    Some((unoccluded * visible, rays, visible))
}

/// Most rounds of rays a pair with a target of several parts casts ([`rounds`]).
pub(crate) const MAX_UNION_ROUNDS: u32 = 8;

/// Rounds of `--samples` rays for a target of several parts, not planar (a planar one, which
/// has an outline, casts one round), `m` times the element's area: `√m` rounded, 1 to
/// [`MAX_UNION_ROUNDS`]. A patch of `m` elements stands for `m` element pairs, each of which
/// the exact solve samples with `--samples` rays: with one round its visible fraction is the
/// noisiest factor of the bake. Measured (docs/MESHING.md): with the rounds on its curved
/// patches the dense sphere's quick equal-error ratio against 2MF rose from 1.64 to 1.99; on
/// the Cornell box's planar ones they took the error against the exact solve from 1.1e-3 to
/// 8.8e-4 at k = 195 but left the error against the path tracer as it was (smooth median /
/// p90 1.28% / 4.15% without, 1.32% / 4.23% with) for 15% more bake time.
fn rounds(e: &Polygon, target: &Region) -> u32 {
    let m = target.area() / e.area();
    (m.sqrt().round().clamp(1.0, f64::from(MAX_UNION_ROUNDS))) as u32
}

/// Whether the outline's contour integral equals the sum over the parts for every point of
/// `e`: `e` lies strictly in front of the region's plane (no part faces away from it, and
/// none has `e`'s points in its plane) and every outline vertex is on or above `e`'s plane
/// (the region is planar, so its lowest point is an outline vertex: nothing is clipped).
/// For an element lit on its parts (`e_parts`) every part must lie in front; they lie in
/// `e`'s plane or below it (`mesh::dense`), so an outline above `e`'s plane is above theirs.
fn outline_applies(e: &Polygon, e_parts: &[(u32, Polygon)], o: &Outline) -> bool {
    let eps = 1e-9 * o.scale;
    let front = |p: &Polygon| p.vertices().iter().all(|&v| o.height(v) > eps);
    let front = if e_parts.is_empty() {
        front(e)
    } else {
        e_parts.iter().all(|(_, p)| front(p))
    };
    front && o.edges.iter().all(|&(a, _)| e.height(a) >= 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A planar region of a 4×4 grid of quads with one cell missing (not convex, with a hole
    /// on its edge): the outline's contour integral equals the sum over the parts, from points
    /// in front of it at many places and tilts, and its outline is the boundary alone.
    #[test]
    fn outline_equals_the_sum_over_parts() {
        use glam::DVec3;
        let mut parts = Vec::new();
        for i in 0..4 {
            for j in 0..4 {
                if (i, j) == (3, 1) {
                    continue;
                }
                let (x, y) = (i as f64 * 0.25, j as f64 * 0.25);
                parts.push(crate::geometry::rectangle(
                    x,
                    x + 0.25,
                    y,
                    y + 0.25,
                    0.0,
                    false,
                ));
            }
        }
        let region = Region::new(parts.clone());
        let outline = region.outline().expect("coplanar parts");
        // The square's 16 outer edges less the missing cell's outer one, plus its 3 inner
        // ones, with straight runs joined: 4 sides of the square, the right side in two, and
        // the notch's 3: 8 edges.
        assert_eq!(outline.edges.len(), 8, "{:?}", outline.edges);
        let mut checked = 0;
        for k in 0..200 {
            let t = k as f64 * 0.37;
            let x = DVec3::new(
                0.5 + 0.6 * t.sin(),
                0.5 + 0.6 * (1.3 * t).cos(),
                0.3 + (k % 7) as f64 * 0.3,
            );
            let n = DVec3::new(0.2 * (2.1 * t).sin(), 0.2 * (0.7 * t).cos(), -1.0).normalize();
            let lowest = parts
                .iter()
                .flat_map(|p| p.vertices())
                .map(|v| (*v - x).dot(n))
                .fold(f64::INFINITY, f64::min);
            if lowest < 0.0 {
                continue; // clipped: the outline does not apply
            }
            let sum: f64 = parts.iter().map(|p| point_to_polygon(x, n, p)).sum();
            let o = point_to_outline(x, n, &outline.edges);
            assert!((o - sum).abs() <= 1e-13, "{x:?} {n:?}: {o} vs {sum}");
            checked += 1;
        }
        assert!(checked > 50, "{checked}");
    }
    use crate::formfactor::FormFactors;
    use crate::geometry::rectangle as square;

    #[test]
    fn parts_add_up_to_the_whole() {
        // The unit square split into four quads (and one split into triangles) as a target
        // must give the same factor as the whole square: the closed form is additive.
        let e = square(0.0, 1.0, 0.0, 1.0, 0.0, false);
        let whole = Region::single(square(0.0, 1.0, 0.0, 1.0, 1.0, true));
        let quarters = Region::new(vec![
            square(0.0, 0.5, 0.0, 0.5, 1.0, true),
            square(0.5, 1.0, 0.0, 0.5, 1.0, true),
            square(0.0, 0.5, 0.5, 1.0, 1.0, true),
            square(0.5, 1.0, 0.5, 1.0, 1.0, true),
        ]);
        assert!((quarters.area() - 1.0).abs() < 1e-12);
        let ff = FormFactors::new(400, None);
        let mut out = [0.0; 2];
        ff.matrix(&[e], &[0], &[whole, quarters], &mut out, &|_| {});
        assert!((out[0] - 0.199825).abs() < 1e-4, "{}", out[0]);
        assert!((out[1] - out[0]).abs() < 1e-12, "{} vs {}", out[1], out[0]);
    }
}
