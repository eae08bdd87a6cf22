//! Point-to-region form factors with visibility: what a surface point sees of a patch.
//!
//! The closed-form kernel ([`super::contour`]) summed over the region's parts, times a
//! kernel-weighted visible fraction of a few rays to area-proportional pair points on the
//! region. 2MSC ([`crate::patches::coherence`]) describes a candidate patch by these factors
//! from points inside it to a set of probe patches.

use glam::DVec3;

use super::contour::point_to_polygon;
use crate::geometry::Region;
use crate::visibility::Occluder;

/// `F(x → region)` for a point `x` with unit `normal`, visibility from `rays` segments seeded
/// by `seed` (`occluder` `None`: nothing occludes).
pub(crate) fn point_to_region(
    x: DVec3,
    normal: DVec3,
    region: &Region,
    occluder: Option<&dyn Occluder>,
    rays: u32,
    seed: u64,
) -> f64 {
    let f: f64 = region
        .parts()
        .iter()
        .map(|part| point_to_polygon(x, normal, part))
        .sum();
    if f <= 0.0 {
        return 0.0;
    }
    let visible = match occluder {
        None => 1.0,
        Some(occ) => visible_fraction(occ, x, normal, region, rays, seed),
    };
    f * visible
}

/// `F(x → region)` estimated from `rays` area-proportional points on the region instead of
/// the closed form, visibility included: `A · mean(V cos θx cos θy / (π r²))`. Its cost does
/// not grow with the region's parts, which makes it the far-field estimate of the merge rule's
/// views of clustered probes (a dense mesh's cluster has as many parts as faces; the closed
/// form over every part from every element would cost `n ×` the faces).
pub(crate) fn point_to_region_sampled(
    x: DVec3,
    normal: DVec3,
    region: &Region,
    occluder: Option<&dyn Occluder>,
    rays: u32,
    seed: u64,
) -> f64 {
    let sum: f64 = kernel_points(x, normal, region, rays, seed)
        .filter(|&(_, to, to_normal)| {
            !occluder.is_some_and(|o| o.occluded(x, normal, to, to_normal))
        })
        .map(|(w, _, _)| w)
        .sum();
    region.area() * sum / (std::f64::consts::PI * f64::from(rays.max(1)))
}

/// Kernel-weighted fraction of `rays` unblocked segments from `x` to pair points on `probe`
/// (seeded by `seed`); one centroid-to-centroid ray decides when every segment grazed.
fn visible_fraction(
    occ: &dyn Occluder,
    x: DVec3,
    normal: DVec3,
    probe: &Region,
    rays: u32,
    seed: u64,
) -> f64 {
    let (mut total, mut visible) = (0.0, 0.0);
    for (w, to, to_normal) in kernel_points(x, normal, probe, rays, seed) {
        total += w;
        if !occ.occluded(x, normal, to, to_normal) {
            visible += w;
        }
    }
    if total > 0.0 {
        return visible / total;
    }
    let t = probe.nearest_part(x);
    if occ.occluded(x, normal, t.centroid(), t.normal) {
        0.0
    } else {
        1.0
    }
}

/// The `rays` pair points on `region` that exchange light with `x` (normal `normal`), each
/// with its weight `cos θx cos θy / r²` times the sample's area weight, its point and its
/// part's normal; grazing and non-finite ones are skipped.
fn kernel_points<'a>(
    x: DVec3,
    normal: DVec3,
    region: &'a Region,
    rays: u32,
    seed: u64,
) -> impl Iterator<Item = (f64, DVec3, DVec3)> + 'a {
    (0..rays).filter_map(move |i| {
        let (j, s) = region.pair_point(i, seed);
        let part_normal = region.parts()[j].normal;
        let d = s.point - x;
        let (cos_x, cos_y) = (d.dot(normal), -d.dot(part_normal));
        if cos_x <= 0.0 || cos_y <= 0.0 {
            return None;
        }
        let r2 = d.length_squared();
        let w = s.weight * cos_x * cos_y / (r2 * r2);
        w.is_finite().then_some((w, s.point, part_normal))
    })
}
