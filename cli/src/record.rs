//! The form-factor rays of a bake, recorded to put several backends to the same queries
//! (`lrr bench visibility`, the backend agreement tests).
//!
//! [`record`] runs the form-factor rows of a prepared scene exactly as a bake does
//! ([`FormFactors::row`](lrr_precompute::formfactor::FormFactors::row): same quadrature, same pair points, same adaptive refinement), with a
//! wrapping [`Occluder`] that forwards every bundle to the scene's own occluder and keeps a copy
//! of it. Rows are visited in a fixed scrambled order until enough rays are kept, so a subset
//! samples the whole scene and the same inputs always give the same rays.

use std::sync::Mutex;

use glam::DVec3;
use rayon::prelude::*;

use lrr_precompute::bake::Prepared;
use lrr_precompute::geometry::Polygon;
use lrr_precompute::geometry::Region;
use lrr_precompute::visibility::{Clear, Occluder, Segment};

/// The rays of one element-target pair, as one `occluded_bundle` call received them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bundle {
    pub element: Polygon,
    pub target: Polygon,
    /// `segments[start..end]` of the [`RaySet`].
    pub start: usize,
    pub end: usize,
}

/// Recorded rays: bundles in the order a sequential bake casts them.
#[derive(Debug, Clone, Default)]
pub struct RaySet {
    pub bundles: Vec<Bundle>,
    pub segments: Vec<Segment>,
}

impl RaySet {
    pub fn rays(&self) -> usize {
        self.segments.len()
    }

    /// The single queries of the set: `(from, from_normal, to, to_normal)` per ray.
    pub fn queries(&self) -> impl Iterator<Item = (DVec3, DVec3, DVec3, DVec3)> + '_ {
        self.bundles.iter().flat_map(move |b| {
            self.segments[b.start..b.end]
                .iter()
                .map(move |s| (s.from, b.element.normal, s.to, b.target.normal))
        })
    }

    /// `blocked[i]` for every ray, asked one at a time through [`Occluder::occluded`]
    /// (in parallel over the bundles, in the current rayon pool).
    pub fn answer_single(&self, occ: &dyn Occluder) -> Vec<bool> {
        let per_bundle: Vec<Vec<bool>> = self
            .bundles
            .par_iter()
            .map(|b| {
                self.segments[b.start..b.end]
                    .iter()
                    .map(|s| occ.occluded(s.from, b.element.normal, s.to, b.target.normal))
                    .collect()
            })
            .collect();
        per_bundle.concat()
    }

    /// `blocked[i]` for every ray, asked bundle by bundle through [`Occluder::occluded_bundle`]
    /// (what a bake does).
    pub fn answer_bundles(&self, occ: &dyn Occluder) -> Vec<bool> {
        let mut blocked = vec![false; self.segments.len()];
        for b in &self.bundles {
            occ.occluded_bundle(
                &b.element,
                &b.target,
                [occ.clear_of(&b.element), occ.clear_of(&b.target)],
                &self.segments[b.start..b.end],
                &mut blocked[b.start..b.end],
            );
        }
        blocked
    }
}

/// Forwards to `inner` and keeps a copy of every bundle.
struct Recorder<'a> {
    inner: &'a dyn Occluder,
    set: Mutex<RaySet>,
}

impl Occluder for Recorder<'_> {
    fn clear_of(&self, p: &Polygon) -> Clear {
        self.inner.clear_of(p)
    }

    fn occluded(&self, from: DVec3, from_normal: DVec3, to: DVec3, to_normal: DVec3) -> bool {
        // Only the fallback of fully grazing pairs asks single rays; they are not recorded
        // (a bundle needs the polygons) but answered like the bake answers them.
        self.inner.occluded(from, from_normal, to, to_normal)
    }

    fn occluded_bundle(
        &self,
        e: &Polygon,
        t: &Polygon,
        ends: [Clear; 2],
        segments: &[Segment],
        blocked: &mut [bool],
    ) {
        self.inner.occluded_bundle(e, t, ends, segments, blocked);
        if segments.is_empty() {
            return;
        }
        let mut set = self.set.lock().unwrap_or_else(|p| p.into_inner());
        let start = set.segments.len();
        set.segments.extend_from_slice(segments);
        let end = set.segments.len();
        set.bundles.push(Bundle {
            element: *e,
            target: *t,
            start,
            end,
        });
    }
}

/// Records at least `min_rays` form-factor rays of `prepared` with `samples` samples per pair
/// (all of them when the scene casts fewer), row by row in a fixed scrambled order of the
/// elements. Returns an empty set when the scene needs no rays (nothing occludes).
pub fn record(prepared: &Prepared, samples: u32, min_rays: usize) -> RaySet {
    let Some(occ) = prepared.occluder.as_deref() else {
        return RaySet::default();
    };
    let recorder = Recorder {
        inner: occ,
        set: Mutex::new(RaySet::default()),
    };
    let ff = lrr_precompute::formfactor::FormFactors::new(samples, Some(&recorder))
        .with_elements(&prepared.mesh.elements);
    let n = prepared.mesh.n();
    let targets: Vec<Region> = prepared
        .mesh
        .patches
        .iter()
        .map(|p| p.shape.clone())
        .collect();
    let mut row = vec![0.0; targets.len()];
    let mut points = Vec::new();
    // A prime stride coprime with n visits every row once, spread over the scene.
    let stride = [7919, 7927, 7933]
        .into_iter()
        .find(|&p| gcd(p, n) == 1)
        .unwrap_or(1);
    for j in 0..n {
        let s = (j * stride) % n;
        let e = prepared.mesh.element_at(s);
        ff.row_points(&e.polygon, prepared.mesh.order[s], &mut points);
        ff.row(
            &e.polygon,
            prepared.mesh.order[s],
            &points,
            &targets,
            &mut row,
        );
        if recorder.set.lock().map_or(0, |s| s.segments.len()) >= min_rays {
            break;
        }
    }
    recorder.set.into_inner().unwrap_or_else(|p| p.into_inner())
}

fn gcd(a: usize, b: usize) -> usize {
    if b == 0 { a } else { gcd(b, a % b) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lrr_precompute::mesh::MeshSizes;
    use lrr_precompute::patches::PatchMethod;
    use lrr_precompute::progress::Progress;
    use lrr_precompute::visibility::Backend;

    #[test]
    fn recorded_rays_are_the_bakes_and_answers_replay() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../scenes/cornell-box/cornell-box.toml");
        let scene = lrr_precompute::scene::load(&path).unwrap();
        let sizes = MeshSizes::resolve(&scene, None, None).unwrap();
        let p = Prepared::new(
            &scene,
            sizes,
            PatchMethod::TwoFixed,
            Backend::Obvhs,
            &Progress::hidden(),
        )
        .unwrap();
        let set = record(&p, 4, 20_000);
        assert!(set.rays() >= 20_000, "{}", set.rays());
        let again = record(&p, 4, 20_000);
        assert_eq!(set.segments, again.segments, "recording is deterministic");
        let occ = p.occluder.as_deref().unwrap();
        let single = set.answer_single(occ);
        assert_eq!(single, set.answer_bundles(occ));
        // The Cornell box has two blocks: some rays are blocked, most are not.
        let blocked = single.iter().filter(|&&b| b).count();
        assert!(blocked > 0 && blocked < set.rays() / 2, "{blocked}");
    }
}
