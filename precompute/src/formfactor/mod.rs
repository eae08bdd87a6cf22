//! Element-to-target form factors (DESIGN.md §4): the bulk of a bake.
//!
//! `F(e → t) = F_unoccluded(e → t) · visibility(e, t)` where
//! - `F_unoccluded = Σ_s w_s F(x_s → t)`: quadrature over `S` points `x_s` of the element of
//!   the closed-form point-to-polygon kernel (`contour`), exact for touching polygons;
//! - `visibility` is the kernel-weighted fraction of `S` segments `x_s → y_s` (with `y_s` on
//!   the target, `geometry::sampling::pair_point`) that nothing blocks. Segments whose ends cannot
//!   exchange light (one behind the other's tangent plane) are not counted. Pairs found
//!   partly visible get `ADAPTIVE_FACTOR` (16) times more rays: only they carry sampling noise.
//!
//! Pairs that face away from each other cost neither kernel evaluations nor rays; when no
//! occluder exists ([`crate::visibility::nothing_occludes`]) no rays are cast at all.
//! Rows are independent and computed in parallel (rayon); every value depends only on the
//! pair, never on the thread count or scheduling, so bakes are reproducible byte for byte.

mod contour;
pub mod enclosure;
pub(crate) mod point;
mod union;
mod visible;

use std::sync::atomic::{AtomicU64, Ordering};

use rayon::prelude::*;

use crate::geometry::Polygon;
use crate::geometry::Region;
use crate::geometry::sampling::{Sample, quadrature, quadrature_parts};
use crate::mesh::Element;
use crate::visibility::{Clear, Occluder};
use contour::point_to_polygon;
use visible::{Shape, faces_away, faces_away_from, visible_fraction};

/// Counters of one form-factor pass.
#[derive(Debug, Default)]
pub(crate) struct Stats {
    pub pairs: AtomicU64,
    pub culled_pairs: AtomicU64,
    pub rays: AtomicU64,
    /// Rows rescaled to sum to one ([`enclosure`]).
    pub conserved_rows: AtomicU64,
}

impl Stats {
    pub(crate) fn get(&self) -> (u64, u64, u64) {
        (
            self.pairs.load(Ordering::Relaxed),
            self.culled_pairs.load(Ordering::Relaxed),
            self.rays.load(Ordering::Relaxed),
        )
    }

    /// Rows rescaled to sum to one.
    pub(crate) fn conserved_rows(&self) -> u64 {
        self.conserved_rows.load(Ordering::Relaxed)
    }
}

/// The most a split element's samples per pair are divided by for each of its pieces
/// (`crate::refine`): 2, so a 2×2 split's children take 8 of 16 samples each. Dividing by
/// all 4 (the unrefined mesh's samples per unit area) was faster still (Cornell box: 1.7× the
/// former default's bake time, against 1.8× at 2 and 2.1× at 1) but 4 samples were too few
/// to see a box hide part of a wall-sized patch: in the occluded furnace
/// (`tests/tests/e2e/furnace.rs`) the worst element went from 5.5e-3 to 9.4e-2.
pub(crate) const MAX_SAMPLE_SHARE: u8 = 2;

/// What a form-factor pass needs.
pub struct FormFactors<'a> {
    /// Quadrature points (and visibility samples) per pair.
    pub samples: u32,
    /// `None` when nothing can occlude.
    pub occluder: Option<&'a dyn Occluder>,
    /// Per element id: whether its row must sum to one ([`enclosure::Enclosure::closed`]);
    /// `None` rescales no row.
    pub closed: Option<&'a [bool]>,
    /// Rays of a partly visible pair, as a multiple of `samples` (`visible::ADAPTIVE_FACTOR`;
    /// 1 for the cheap first pass of `crate::refine`).
    pub(crate) adaptive: u32,
    /// Per element id: the pieces its parent was split into (`Mesh::siblings`); its row takes
    /// `samples` divided among them. `None`: every row takes `samples`.
    pub(crate) siblings: Option<&'a [u8]>,
    /// The mesh's elements by id, for the rows of elements lit on their parts
    /// ([`Element::on_parts`]: points and vertex tests on the parts). `None`: every row is
    /// its polygon.
    pub(crate) elements: Option<&'a [Element]>,
    pub(crate) stats: Stats,
}

impl<'a> FormFactors<'a> {
    /// A pass with `samples` points per pair (at least 1) and an optional occluder.
    pub fn new(samples: u32, occluder: Option<&'a dyn Occluder>) -> Self {
        Self {
            samples: samples.max(1),
            occluder,
            closed: None,
            adaptive: visible::ADAPTIVE_FACTOR,
            siblings: None,
            elements: None,
            stats: Stats::default(),
        }
    }

    /// Samples per pair of the row of element `id`: `samples`, divided among the pieces of a
    /// split parent but by at most [`MAX_SAMPLE_SHARE`], at least 1.
    pub(crate) fn row_samples(&self, id: u32) -> u32 {
        let share = self
            .siblings
            .and_then(|s| s.get(id as usize).copied())
            .unwrap_or(1)
            .max(1);
        (self.samples / u32::from(share.min(MAX_SAMPLE_SHARE))).max(1)
    }

    /// The same pass, its rows looked up in `elements` (by id) for the ones lit on their
    /// parts ([`Element::on_parts`]), as a bake's pass does.
    pub fn with_elements(mut self, elements: &'a [Element]) -> Self {
        self.elements = Some(elements);
        self
    }

    /// The parts the row of element `id` is lit on ([`Element::on_parts`]); empty: its
    /// polygon.
    pub(crate) fn lit_parts(&self, id: u32) -> &'a [(u32, Polygon)] {
        match self.elements.and_then(|e| e.get(id as usize)) {
            Some(e) if e.on_parts => &e.parts,
            _ => &[],
        }
    }

    /// The quadrature points of the row of element `id` (polygon `e`) into `points`: on its
    /// polygon, or over its parts when it is lit on them.
    pub fn row_points(&self, e: &Polygon, id: u32, points: &mut Vec<Sample>) {
        let parts = self.lit_parts(id);
        if parts.is_empty() {
            quadrature(e, self.row_samples(id), points);
        } else {
            quadrature_parts(parts, self.row_samples(id), points);
        }
    }

    /// Occlusion rays cast so far by this pass.
    pub fn rays(&self) -> u64 {
        self.stats.rays.load(Ordering::Relaxed)
    }

    /// The same pass, rescaling the rows of the elements `closed` marks (indexed by element
    /// id, the `row_ids` of [`matrix`](Self::matrix)) so that they sum to one.
    pub fn with_enclosure(mut self, closed: Option<&'a [bool]>) -> Self {
        self.closed = closed;
        self
    }

    /// Fills `out` (rows × targets, row-major) with `F(rows[i] → targets[j])` (a target is one
    /// polygon or a union of several, [`Region`]).
    /// `row_ids` seed the per-pair sampling (use the element ids). `progress` is called with
    /// the number of rows finished, from worker threads.
    pub(crate) fn matrix(
        &self,
        rows: &[Polygon],
        row_ids: &[u32],
        targets: &[Region],
        out: &mut [f64],
        progress: &(dyn Fn(u64) + Sync),
    ) {
        self.matrix_with(
            rows,
            row_ids,
            targets,
            &Ends::of(self.occluder, targets),
            out,
            progress,
        );
    }

    /// [`matrix`](Self::matrix) with the targets' hints `ends` worked out beforehand
    /// ([`Ends::of`] of the same targets), for a caller that fills the matrix in blocks.
    pub(crate) fn matrix_with(
        &self,
        rows: &[Polygon],
        row_ids: &[u32],
        targets: &[Region],
        ends: &Ends,
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
                self.row_points(&rows[i], row_ids[i], points);
                self.row_with(&rows[i], row_ids[i], points, targets, ends, row);
                progress(1);
            });
    }

    /// Estimated cost of the row of `e`, in units of one part's closed-form kernel at every
    /// sample: per target [`row`](Self::row) integrates (not culled), its parts facing `e`
    /// plus `visibility` (the rays of its visible fraction). Culled targets cost a few dot
    /// products: counted 0. The sharded bake balances its shards by this (docs/DISTRIBUTED.md).
    pub(crate) fn row_cost(e: &Polygon, targets: &[Region], visibility: u64) -> u64 {
        targets
            .iter()
            .map(|t| {
                let parts = t.parts().iter().filter(|p| !faces_away(e, p)).count() as u64;
                if parts == 0 { 0 } else { parts + visibility }
            })
            .sum()
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
        self.row_with(e, e_id, points, targets, &Ends::default(), row);
    }

    /// [`row`](Self::row) with the occluder's hints for the targets' parts (`ends`; the
    /// element's are asked here). The values are the same with or without them.
    fn row_with(
        &self,
        e: &Polygon,
        e_id: u32,
        points: &[Sample],
        targets: &[Region],
        ends: &Ends,
        row: &mut [f64],
    ) {
        let e_parts = self.lit_parts(e_id);
        // The occluder's hint holds for rays from `e` and what stands on its plane: none for
        // an element lit on parts below it (`visible::base`), whose rays start under it.
        let e_end = match self.occluder {
            Some(o) if std::ptr::eq(visible::base(e, e_parts), e) => o.clear_of(e),
            _ => Clear::NONE,
        };
        let mut culled = 0u64;
        let mut rays = 0u64;
        let closed = self
            .closed
            .is_some_and(|c| c.get(e_id as usize).copied().unwrap_or(false));
        // The pairs whose visibility was partial (sampled, noisy): the ones a closed row
        // rescales. Kept for closed rows only (no allocation in open scenes).
        let mut partial = Vec::new();
        let mut note = |t_id: usize, visible: f64| {
            if closed && visible > 0.0 && visible < 1.0 {
                partial.push(t_id);
            }
        };
        for (t_id, (target, out)) in targets.iter().zip(row.iter_mut()).enumerate() {
            *out = 0.0;
            let seed = (u64::from(e_id) << 32) | t_id as u64;
            let hints = (e_end, ends.of_target(t_id));
            let Some(t) = target.as_single() else {
                match union::multi_part(
                    self.occluder,
                    (e, e_parts),
                    points,
                    target,
                    seed,
                    self.adaptive,
                    hints,
                ) {
                    None => culled += 1,
                    Some((f, r, v)) => {
                        *out = f;
                        rays += r;
                        note(t_id, v);
                    }
                }
                continue;
            };
            if faces_away_from(e, e_parts, t) {
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
                    let (v, r) = visible_fraction(
                        occ,
                        e,
                        Shape::One(t),
                        hints,
                        points,
                        seed,
                        self.adaptive,
                        1,
                    );
                    rays += r;
                    v
                }
            };
            *out = unoccluded * visible;
            note(t_id, visible);
        }
        if closed && conserve(row, &partial) {
            self.stats.conserved_rows.fetch_add(1, Ordering::Relaxed);
        }
        self.stats
            .pairs
            .fetch_add(targets.len() as u64, Ordering::Relaxed);
        self.stats.culled_pairs.fetch_add(culled, Ordering::Relaxed);
        self.stats.rays.fetch_add(rays, Ordering::Relaxed);
    }
}

/// The occluder's hints ([`Occluder::clear_of`]) for every part of every target of a pass,
/// asked once: the rows' rays that end on a part pass them on.
#[derive(Default)]
pub(crate) struct Ends {
    /// Target `t`'s parts' hints are `clears[start[t]..start[t + 1]]`; empty: none at all.
    start: Vec<usize>,
    clears: Vec<Clear>,
}

impl Ends {
    /// The hints of `targets`' parts (none without an occluder).
    pub(crate) fn of(occluder: Option<&dyn Occluder>, targets: &[Region]) -> Self {
        let Some(occ) = occluder else {
            return Self::default();
        };
        let per: Vec<Vec<Clear>> = targets
            .par_iter()
            .map(|t| t.parts().iter().map(|p| occ.clear_of(p)).collect())
            .collect();
        let mut start = Vec::with_capacity(targets.len() + 1);
        start.push(0);
        let mut clears = Vec::with_capacity(per.iter().map(Vec::len).sum());
        for c in per {
            clears.extend(c);
            start.push(clears.len());
        }
        Self { start, clears }
    }

    /// Target `t`'s parts' hints (empty: none).
    fn of_target(&self, t: usize) -> &[Clear] {
        match (self.start.get(t), self.start.get(t + 1)) {
            (Some(&a), Some(&b)) => &self.clears[a..b],
            _ => &[],
        }
    }
}

/// Most a closed row's pairs are scaled by (either way): beyond it the row is left as sampled
/// (an element that is not really enclosed, or a row too far off to trust either way).
const MAX_RESCALE: f64 = 2.0;

/// Rescales a closed element's `row` so that it sums to one. First through its partly visible
/// pairs `partial`, the ones that carry sampling noise; the other pairs (unoccluded: exact up
/// to quadrature; hidden) keep their values. When there are none, or they would have to
/// change by more than [`MAX_RESCALE`], the deficit is not theirs: a pair whose samples all
/// agreed (fully visible or fully hidden) is itself off, typically a large patch that a box
/// hides in part, missed by every sample. Then the whole row is scaled, so that the energy
/// the element sends is conserved, spread over its pairs in proportion. Returns whether the
/// row was rescaled: not when it is empty or needs a factor outside
/// `[1 / MAX_RESCALE, MAX_RESCALE]` either way.
fn conserve(row: &mut [f64], partial: &[usize]) -> bool {
    let in_range =
        |scale: f64| scale.is_finite() && (1.0 / MAX_RESCALE..=MAX_RESCALE).contains(&scale);
    let total: f64 = row.iter().sum();
    let noisy: f64 = partial.iter().map(|&j| row[j]).sum();
    if noisy > 0.0 {
        let scale = (1.0 - (total - noisy)) / noisy;
        if in_range(scale) {
            for &j in partial {
                row[j] *= scale;
            }
            return true;
        }
    }
    let scale = 1.0 / total;
    if total > 0.0 && in_range(scale) {
        for v in row.iter_mut() {
            *v *= scale;
        }
        return true;
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

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
    fn a_closed_row_is_rescaled_through_its_partly_visible_pairs_only() {
        // 0.5 unoccluded, 0.3 + 0.1 partly visible: the partial pairs carry the missing 0.1.
        let mut row = [0.5, 0.3, 0.0, 0.1];
        assert!(conserve(&mut row, &[1, 3]));
        assert_eq!(row[0], 0.5);
        assert_eq!(row[2], 0.0);
        assert!((row[1] - 0.375).abs() < 1e-15 && (row[3] - 0.125).abs() < 1e-15);
        assert!((row.iter().sum::<f64>() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn a_deficit_the_partial_pairs_cannot_carry_is_spread_over_the_row() {
        let sums_to_one = |row: &[f64]| (row.iter().sum::<f64>() - 1.0).abs() < 1e-15;
        // Nothing partly visible: the whole row is scaled (0.8 → 1).
        let mut row = [0.5, 0.3, 0.0];
        assert!(conserve(&mut row, &[]));
        assert!(sums_to_one(&row) && (row[0] - 0.625).abs() < 1e-15 && row[2] == 0.0);
        // The partial pairs would have to grow by 5 (0.1 → 0.5): the whole row instead.
        let mut row = [0.5, 0.1];
        assert!(conserve(&mut row, &[1]));
        assert!(sums_to_one(&row) && (row[1] / row[0] - 0.2).abs() < 1e-15);
        // Or shrink by more than half (0.3 → 0.1).
        let mut row = [0.9, 0.3];
        assert!(conserve(&mut row, &[1]));
        assert!(sums_to_one(&row) && (row[1] / row[0] - 1.0 / 3.0).abs() < 1e-15);
    }

    #[test]
    fn rows_that_would_need_a_large_factor_are_left_alone() {
        // Empty, or summing to less than a half or more than two: not an enclosed row's
        // sampling error; left as sampled.
        for row in [[0.0, 0.0], [0.3, 0.1], [1.5, 0.6]] {
            let mut r = row;
            assert!(!conserve(&mut r, &[1]));
            assert!(!conserve(&mut r, &[]));
            assert_eq!(r, row);
        }
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

#[cfg(test)]
mod stacked_tests {
    use super::*;
    use crate::geometry::rectangle;
    use crate::mesh::Element;
    use glam::DVec3;

    /// The triangles of the box `lo`..`hi`, each side a 2 × 2 grid of quads (48 triangles,
    /// shared corners bit for bit: one closed group of the occluder).
    fn tessellated_box(lo: DVec3, hi: DVec3) -> Vec<[DVec3; 3]> {
        let at = |f: [f64; 3]| lo + (hi - lo) * DVec3::from_array(f);
        let mut out = Vec::new();
        // Each side: its fixed axis and value, its two free axes ordered for an outward normal.
        for (axis, value, u, v) in [
            (0, 0.0, 2, 1),
            (0, 1.0, 1, 2),
            (1, 0.0, 0, 2),
            (1, 1.0, 2, 0),
            (2, 0.0, 1, 0),
            (2, 1.0, 0, 1),
        ] {
            for i in 0..2 {
                for j in 0..2 {
                    let corner = |a: usize, b: usize| {
                        let mut f = [0.0; 3];
                        f[axis] = value;
                        f[u] = 0.5 * (i + a) as f64;
                        f[v] = 0.5 * (j + b) as f64;
                        at(f)
                    };
                    let (p, q, r, s) = (corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1));
                    out.push([p, q, r]);
                    out.push([p, r, s]);
                }
            }
        }
        out
    }

    /// An element lit on the tops of a tall box and of a low one beside it (its proxy on the
    /// tall one's top) sees a square beyond the tall box as its two tops do, area-weighted: the
    /// low top's rays cross the tall box and are blocked. The occluder's hint for the proxy
    /// (rays leaving the tall box's top skip it) does not hold for them; taken, the element saw
    /// the square through the box.
    #[test]
    fn a_row_lit_on_stacked_parts_is_blocked_by_what_stands_on_the_highest() {
        let mut tris = tessellated_box(DVec3::ZERO, DVec3::new(1.0, 1.0, 3.0));
        tris.extend(tessellated_box(
            DVec3::new(-1.2, 0.0, 0.0),
            DVec3::new(-0.2, 1.0, 0.5),
        ));
        let scene = crate::mesh::tests::one_surface("boxes", &tris);
        let occ = crate::visibility::obvhs::ObvhsOccluder::build(&scene);
        let high = rectangle(0.0, 1.0, 0.0, 1.0, 3.0, false);
        let low = rectangle(-1.2, -0.2, 0.0, 1.0, 0.5, false);
        let proxy = rectangle(-0.8, 0.6, 0.0, 1.0, 3.0, false);
        let element = |polygon: Polygon, parts: Vec<(u32, Polygon)>| Element {
            polygon,
            face: 0,
            surface: 0,
            patch: 0,
            on_parts: !parts.is_empty(),
            parts,
        };
        let elements = [
            element(proxy, vec![(0, high), (1, low)]),
            element(high, vec![]),
            element(low, vec![]),
        ];
        let target = [Region::single(rectangle(2.0, 3.0, 0.0, 1.0, 4.0, true))];
        let ff = FormFactors::new(64, Some(&occ)).with_elements(&elements);
        let f = |id: u32| {
            let mut points = Vec::new();
            ff.row_points(&elements[id as usize].polygon, id, &mut points);
            let mut row = [0.0];
            ff.row(
                &elements[id as usize].polygon,
                id,
                &points,
                &target,
                &mut row,
            );
            row[0]
        };
        let (stacked, high, low) = (f(0), f(1), f(2));
        assert!(high > 0.01 && low == 0.0, "{high} {low}");
        let expected = 0.5 * (high + low);
        assert!(
            (stacked - expected).abs() <= 0.15 * expected,
            "lit on its parts {stacked}, its parts {expected}"
        );
    }
}
