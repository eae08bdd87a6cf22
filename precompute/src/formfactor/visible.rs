//! Visibility of an element-target pair: the kernel-weighted fraction of unblocked segments
//! between the element's quadrature points and pair-specific points on the target, refined
//! where a shadow boundary crosses the pair, and the back-face test that culls a pair without
//! any ray.

use glam::DVec3;

use crate::geometry::sampling::{Sample, pair_point};
use crate::geometry::{Polygon, Region};
use crate::visibility::{Clear, Occluder, Segment};

/// True when the pair cannot exchange light: the target lies entirely behind (or in) the
/// element's plane, or the element entirely behind (or in) the target's plane.
pub(crate) fn faces_away(e: &Polygon, t: &Polygon) -> bool {
    behind(t, e) || behind(e, t)
}

/// True when every vertex of `p` lies behind (or in) the plane of `plane`.
fn behind(p: &Polygon, plane: &Polygon) -> bool {
    let eps = 1e-12 * plane.scale;
    p.vertices().iter().all(|v| plane.height(*v) <= eps)
}

/// [`faces_away`] for an element lit on its parts (`parts`; empty: `e` alone): the element
/// lies behind `t`'s plane when every part does, and `t` behind the element when it lies
/// behind the plane the element faces from ([`base`]).
pub(crate) fn faces_away_from(e: &Polygon, parts: &[(u32, Polygon)], t: &Polygon) -> bool {
    if parts.is_empty() {
        return faces_away(e, t);
    }
    behind(t, base(e, parts)) || parts.iter().all(|(_, p)| behind(p, t))
}

/// The plane an element lit on its parts faces from: its own where its parts lie in it (the
/// cells of a face, `mesh::dense`), else its lowest part's. Parallel faces of separate objects
/// grouped into one element lie at several heights below their proxy, which stands on the
/// highest: what lies between them is in front of the lower ones, and a test against the
/// proxy's plane culled it (a hall of boxes 9–16 % too dark, docs/MESHING.md). Parts are
/// parallel to `e` here (`mesh::dense` lights no other group on its parts), so what lies
/// behind the lowest part's plane lies behind every part's.
pub(crate) fn base<'a>(e: &'a Polygon, parts: &'a [(u32, Polygon)]) -> &'a Polygon {
    let eps = 1e-9 * e.scale;
    let lowest = (parts.iter().map(|(_, p)| p))
        .map(|p| {
            (
                p,
                p.vertices()
                    .iter()
                    .map(|&v| e.height(v))
                    .fold(f64::INFINITY, f64::min),
            )
        })
        .reduce(|a, b| if b.1 < a.1 { b } else { a });
    match lowest {
        Some((p, h)) if h < -eps => p,
        _ => e,
    }
}

/// Kernel-weighted fraction of unblocked segments between the element's points and
/// pair-specific points on the target, and the number of rays cast. Partly visible pairs get
/// `adaptive` times the rays ([`ADAPTIVE_FACTOR`] in a bake; 1: none).
///
/// Each segment is weighted by the point-to-point kernel `cos θx cos θy / r²`, so the ratio
/// converges to `∫∫ K V / ∫∫ K`, the visibility that multiplies the exact unoccluded factor.
/// An unweighted fraction (tried first) converges to the *area*-weighted visibility instead:
/// biased by ~1% on Cornell-box surface pairs at any sample count, which broke reciprocity.
///
/// `rounds` (1 but for curved targets of several parts, `union::rounds`) multiplies the
/// first rays; the adaptive refinement still ends at `adaptive` times `points.len()`.
/// `ends` are the occluder's hints ([`Occluder::clear_of`]) for `e` and for each of `t`'s parts
/// (empty: none).
#[allow(clippy::too_many_arguments)]
pub(crate) fn visible_fraction(
    occ: &dyn Occluder,
    e: &Polygon,
    t: Shape<'_>,
    ends: (Clear, &[Clear]),
    points: &[Sample],
    seed: u64,
    adaptive: u32,
    rounds: u32,
) -> (f64, u64) {
    let mut acc = Visibility::default();
    let first = points.len() as u32 * rounds;
    acc.cast(occ, e, t, ends, points, seed, 0..first);
    let adaptive_end = points.len() as u32 * adaptive;
    if adaptive_end > first && acc.visible > 0.0 && acc.visible < acc.total {
        // A shadow boundary crosses the pair: binary visibility is noisy here, so refine.
        acc.cast(occ, e, t, ends, points, seed, first..adaptive_end);
    }
    if acc.total <= 0.0 {
        // Every sampled segment was grazing: fall back to one ray between the element's
        // centroid and that of the (nearest part of the) target, if that segment exchanges
        // light. If it does not either (the target's centroid behind the element, or the
        // element behind the target: a large target with only a sliver in front), a ray along
        // it says nothing about the pair and would pass through whatever wall both stand
        // against (the own-face rule skips coincident faces): the pair counts as hidden.
        // Before, such rays let a 2MSC bake leak 1e-5 of the light into a sealed room
        // behind a concave corner (`tests/tests/hard_cases.rs`).
        let t = t.nearest_part(e.centroid());
        let d = t.centroid() - e.centroid();
        if d.dot(e.normal) <= 0.0 || d.dot(t.normal) >= 0.0 {
            return (0.0, acc.rays);
        }
        let blocked = occ.occluded(e.centroid(), e.normal, t.centroid(), t.normal);
        return (if blocked { 0.0 } else { 1.0 }, acc.rays + 1);
    }
    (acc.visible / acc.total, acc.rays)
}

/// Rays per pair, as a multiple of `--samples`, where a pair is partly visible after the first
/// `--samples` rays. Only pairs crossed by a shadow boundary pay for it (measured on the
/// Cornell box: 16× there cut the surface-level reciprocity error from 0.5% to ~0.1% for
/// about twice the rays).
pub(crate) const ADAPTIVE_FACTOR: u32 = 16;

/// Where a target's pair points lie: one polygon ([`pair_point`]), or a union of parts
/// ([`Region::pair_point`], parts chosen by area).
#[derive(Clone, Copy)]
pub(crate) enum Shape<'a> {
    One(&'a Polygon),
    Union(&'a Region),
}

impl Shape<'_> {
    fn part(&self, j: usize) -> &Polygon {
        match self {
            Shape::One(t) => t,
            Shape::Union(t) => &t.parts()[j],
        }
    }

    /// The `i`-th pair point and the index of the part it lies on.
    fn pair_point(&self, i: u32, seed: u64) -> (usize, Sample) {
        match self {
            Shape::One(t) => (0, pair_point(t, i, seed)),
            Shape::Union(t) => t.pair_point(i, seed),
        }
    }

    fn nearest_part(&self, x: DVec3) -> &Polygon {
        match self {
            Shape::One(t) => t,
            Shape::Union(t) => t.nearest_part(x),
        }
    }
}

#[derive(Default)]
struct Visibility {
    total: f64,
    visible: f64,
    rays: u64,
}

impl Visibility {
    /// Casts rays `i` in `range`: from quadrature point `i mod S` to the `i`-th pair point,
    /// answered per part by one bundle each (parts in order, rays in order within a part).
    #[allow(clippy::too_many_arguments)]
    fn cast(
        &mut self,
        occ: &dyn Occluder,
        e: &Polygon,
        t: Shape<'_>,
        (e_end, t_ends): (Clear, &[Clear]),
        points: &[Sample],
        seed: u64,
        range: std::ops::Range<u32>,
    ) {
        let mut rays: Vec<(usize, Segment, f64)> = Vec::with_capacity(range.len());
        for i in range {
            let s = &points[i as usize % points.len()];
            let (j, far) = t.pair_point(i, seed);
            let d = far.point - s.point;
            let cos_x = d.dot(e.normal);
            let cos_y = -d.dot(t.part(j).normal);
            if cos_x <= 0.0 || cos_y <= 0.0 {
                continue; // this pair of points exchanges no light
            }
            let r2 = d.length_squared();
            let weight = s.weight * far.weight * cos_x * cos_y / (r2 * r2);
            if !weight.is_finite() {
                continue;
            }
            let segment = Segment {
                from: s.point,
                to: far.point,
            };
            rays.push((j, segment, weight));
        }
        rays.sort_by_key(|&(j, _, _)| j); // stable: ray order kept within a part
        let (mut segments, mut blocked) = (Vec::new(), Vec::new());
        for group in rays.chunk_by(|a, b| a.0 == b.0) {
            segments.clear();
            segments.extend(group.iter().map(|g| g.1));
            blocked.clear();
            blocked.resize(segments.len(), false);
            let j = group[0].0;
            let t_end = t_ends.get(j).copied().unwrap_or(Clear::NONE);
            occ.occluded_bundle(e, t.part(j), [e_end, t_end], &segments, &mut blocked);
            self.rays += segments.len() as u64;
            for ((_, _, w), b) in group.iter().zip(&blocked) {
                self.total += w;
                if !b {
                    self.visible += w;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::rectangle;

    /// An element lit on two parallel parts at two heights (the tops of two boxes), its proxy
    /// on the higher: a face between them, turned to the lower part, exchanges light with it
    /// and is not culled; a face below both is. Against the proxy's plane alone (the rule
    /// before) the first was culled.
    #[test]
    fn parts_below_the_proxy_see_what_lies_between() {
        let low = rectangle(0.0, 1.0, 0.0, 1.0, 0.0, false);
        let high = rectangle(2.0, 3.0, 0.0, 1.0, 1.0, false);
        let proxy = rectangle(0.5, 2.5, 0.0, 1.0, 1.0, false);
        let parts = [(0, low), (1, high)];
        assert!(std::ptr::eq(base(&proxy, &parts), &parts[0].1));
        let between = rectangle(0.0, 1.0, 0.0, 1.0, 0.5, true);
        assert!(!faces_away_from(&proxy, &parts, &between));
        assert!(
            faces_away(&proxy, &between),
            "the proxy's own plane culls it"
        );
        let below = rectangle(0.0, 1.0, 0.0, 1.0, -0.5, false);
        assert!(faces_away_from(&proxy, &parts, &below));
        // Parts in the element's plane: the element's own plane, as before.
        let flat = [(0, low), (1, rectangle(2.0, 3.0, 0.0, 1.0, 0.0, false))];
        let flat_proxy = rectangle(0.5, 2.5, 0.0, 1.0, 0.0, false);
        assert!(std::ptr::eq(base(&flat_proxy, &flat), &flat_proxy));
    }
}
