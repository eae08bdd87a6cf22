//! Element-to-target form factors (DESIGN.md §4): the bulk of a bake.
//!
//! `F(e → t) = F_unoccluded(e → t) · visibility(e, t)` where
//! - `F_unoccluded = Σ_s w_s F(x_s → t)`: quadrature over `S` points `x_s` of the element of
//!   the closed-form point-to-polygon kernel ([`kernel`]), exact for touching polygons;
//! - `visibility` is the kernel-weighted fraction of `S` segments `x_s → y_s` (with `y_s` on
//!   the target, [`sampling::pair_point`]) that nothing blocks. Segments whose ends cannot
//!   exchange light (one behind the other's tangent plane) are not counted. Pairs found
//!   partly visible get [`ADAPTIVE_FACTOR`] times more rays: only they carry sampling noise.
//!
//! Pairs that face away from each other cost neither kernel evaluations nor rays; when no
//! occluder exists ([`crate::visibility::nothing_occludes`]) no rays are cast at all.
//! Rows are independent and computed in parallel (rayon); every value depends only on the
//! pair, never on the thread count or scheduling, so bakes are reproducible byte for byte.

pub mod contour;
pub mod point;
pub mod union;

use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;
use rayon::prelude::*;

use crate::geometry::Polygon;
use crate::geometry::Region;
use crate::geometry::sampling::{Sample, pair_point, quadrature};
use crate::visibility::{Occluder, Segment};
use contour::point_to_polygon;

/// Counters of one form-factor pass.
#[derive(Debug, Default)]
pub struct Stats {
    pub pairs: AtomicU64,
    pub culled_pairs: AtomicU64,
    pub rays: AtomicU64,
}

impl Stats {
    pub fn get(&self) -> (u64, u64, u64) {
        (
            self.pairs.load(Ordering::Relaxed),
            self.culled_pairs.load(Ordering::Relaxed),
            self.rays.load(Ordering::Relaxed),
        )
    }
}

/// What a form-factor pass needs.
pub struct FormFactors<'a> {
    /// Quadrature points (and visibility samples) per pair.
    pub samples: u32,
    /// `None` when nothing can occlude.
    pub occluder: Option<&'a dyn Occluder>,
    pub stats: Stats,
}

impl<'a> FormFactors<'a> {
    pub fn new(samples: u32, occluder: Option<&'a dyn Occluder>) -> Self {
        Self {
            samples: samples.max(1),
            occluder,
            stats: Stats::default(),
        }
    }

    /// Fills `out` (rows × targets, row-major) with `F(rows[i] → targets[j])` (a target is one
    /// polygon or a union of several, [`Region`]).
    /// `row_ids` seed the per-pair sampling (use the element ids). `progress` is called with
    /// the number of rows finished, from worker threads.
    pub fn matrix(
        &self,
        rows: &[Polygon],
        row_ids: &[u32],
        targets: &[Region],
        out: &mut [f64],
        progress: &(dyn Fn(u64) + Sync),
    ) {
        let k = targets.len();
        assert_eq!(out.len(), rows.len() * k, "output must be rows × targets");
        if k == 0 {
            return;
        }
        out.par_chunks_mut(k)
            .enumerate()
            .for_each_init(Vec::new, |points, (i, row)| {
                quadrature(&rows[i], self.samples, points);
                self.row(&rows[i], row_ids[i], points, targets, row);
                progress(1);
            });
    }

    /// One row: the element `e` (with its quadrature points) against every target.
    pub fn row(
        &self,
        e: &Polygon,
        e_id: u32,
        points: &[Sample],
        targets: &[Region],
        row: &mut [f64],
    ) {
        let mut culled = 0u64;
        let mut rays = 0u64;
        for (t_id, (target, out)) in targets.iter().zip(row.iter_mut()).enumerate() {
            *out = 0.0;
            let Some(t) = target.as_single() else {
                let seed = (u64::from(e_id) << 32) | t_id as u64;
                match union::multi_part(self.occluder, e, points, target, seed) {
                    None => culled += 1,
                    Some((f, r)) => {
                        *out = f;
                        rays += r;
                    }
                }
                continue;
            };
            if faces_away(e, t) {
                culled += 1;
                continue;
            }
            let unoccluded: f64 = points
                .iter()
                .map(|s| s.weight * point_to_polygon(s.point, e.normal, t))
                .sum();
            if unoccluded <= 0.0 {
                continue;
            }
            let visible = match self.occluder {
                None => 1.0,
                Some(occ) => {
                    let seed = (u64::from(e_id) << 32) | t_id as u64;
                    let (v, r) = visible_fraction(occ, e, Shape::One(t), points, seed);
                    rays += r;
                    v
                }
            };
            *out = unoccluded * visible;
        }
        self.stats
            .pairs
            .fetch_add(targets.len() as u64, Ordering::Relaxed);
        self.stats.culled_pairs.fetch_add(culled, Ordering::Relaxed);
        self.stats.rays.fetch_add(rays, Ordering::Relaxed);
    }
}

/// True when the pair cannot exchange light: the target lies entirely behind (or in) the
/// element's plane, or the element entirely behind (or in) the target's plane.
pub(crate) fn faces_away(e: &Polygon, t: &Polygon) -> bool {
    let eps_t = 1e-12 * t.scale;
    let eps_e = 1e-12 * e.scale;
    t.vertices().iter().all(|v| e.height(*v) <= eps_e)
        || e.vertices().iter().all(|v| t.height(*v) <= eps_t)
}

/// Kernel-weighted fraction of unblocked segments between the element's points and
/// pair-specific points on the target, and the number of rays cast.
///
/// Each segment is weighted by the point-to-point kernel `cos θx cos θy / r²`, so the ratio
/// converges to `∫∫ K V / ∫∫ K`, the visibility that multiplies the exact unoccluded factor.
/// An unweighted fraction (tried first) converges to the *area*-weighted visibility instead:
/// biased by ~1% on Cornell-box surface pairs at any sample count, which broke reciprocity.
pub(crate) fn visible_fraction(
    occ: &dyn Occluder,
    e: &Polygon,
    t: Shape<'_>,
    points: &[Sample],
    seed: u64,
) -> (f64, u64) {
    let mut acc = Visibility::default();
    let first = points.len() as u32;
    acc.cast(occ, e, t, points, seed, 0..first);
    if acc.visible > 0.0 && acc.visible < acc.total {
        // A shadow boundary crosses the pair: binary visibility is noisy here, so refine.
        acc.cast(occ, e, t, points, seed, first..first * ADAPTIVE_FACTOR);
    }
    if acc.total <= 0.0 {
        // Every sampled segment was grazing: fall back to one ray between the element's
        // centroid and that of the (nearest part of the) target.
        let t = t.nearest_part(e.centroid());
        let blocked = occ.occluded(e.centroid(), e.normal, t.centroid(), t.normal);
        return (if blocked { 0.0 } else { 1.0 }, acc.rays + 1);
    }
    (acc.visible / acc.total, acc.rays)
}

/// Rays per pair, as a multiple of `--samples`, where a pair is partly visible after the first
/// `--samples` rays. Only pairs crossed by a shadow boundary pay for it (measured on the
/// Cornell box: 16× there cut the surface-level reciprocity error from 0.5% to ~0.1% for
/// about twice the rays).
pub const ADAPTIVE_FACTOR: u32 = 16;

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
    fn cast(
        &mut self,
        occ: &dyn Occluder,
        e: &Polygon,
        t: Shape<'_>,
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
            occ.occluded_bundle(e, t.part(group[0].0), &segments, &mut blocked);
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

    fn unit_square(z: f64, down: bool) -> Polygon {
        let mut v = vec![
            DVec3::new(0.0, 0.0, z),
            DVec3::new(1.0, 0.0, z),
            DVec3::new(1.0, 1.0, z),
            DVec3::new(0.0, 1.0, z),
        ];
        if down {
            v.reverse();
        }
        Polygon::new(&v).unwrap()
    }

    #[test]
    fn parallel_unit_squares_whole_polygon() {
        // One element, 20×20 midpoint rule on the smooth kernel: O(h²) error ≈ 8e-5.
        let ff = FormFactors::new(400, None);
        let mut out = [0.0];
        ff.matrix(
            &[unit_square(0.0, false)],
            &[0],
            &[Region::single(unit_square(1.0, true))],
            &mut out,
            &|_| {},
        );
        assert!((out[0] - 0.199825).abs() < 1e-4, "{}", out[0]);
    }

    #[test]
    fn back_to_back_pairs_are_culled() {
        let ff = FormFactors::new(4, None);
        let mut out = [1.0];
        ff.matrix(
            &[unit_square(0.0, true)],
            &[0],
            &[Region::single(unit_square(1.0, false))],
            &mut out,
            &|_| {},
        );
        assert_eq!(out[0], 0.0);
        assert_eq!(ff.stats.get().1, 1);
    }
}
