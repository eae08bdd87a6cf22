//! Form-factor targets made of several convex polygons: the clustered patches of dense meshes.
//!
//! A patch built by clustering (see [`crate::patches::cluster`]) is a union of the small input
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

use super::contour::point_to_polygon;
use super::visible::{Shape, faces_away, visible_fraction};
use crate::geometry::Polygon;
use crate::geometry::sampling::Sample;
use crate::visibility::Occluder;

/// `F(e → target)` for a target of several parts, the rays cast and the visible fraction
/// (`None` when every part faces away from `e`: a culled pair).
pub(super) fn multi_part(
    occluder: Option<&dyn Occluder>,
    e: &Polygon,
    points: &[Sample],
    target: &Region,
    seed: u64,
    adaptive: u32,
) -> Option<(f64, u64, f64)> {
    let mut unoccluded = 0.0;
    let mut any = false;
    for part in target.parts() {
        if faces_away(e, part) {
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
    let (visible, rays) = visible_fraction(occ, e, Shape::Union(target), points, seed, adaptive);
    Some((unoccluded * visible, rays, visible))
}

#[cfg(test)]
mod tests {
    use super::*;
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
