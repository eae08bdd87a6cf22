//! `lrr accuracy`: what accuracy costs in time. A sweep over the settings that trade one for
//! the other (2MF patch size, 2MSC threshold, fine-mesh size `n`, samples per pair, f32/f16
//! storage of `F_k`); for each point, measured in one run:
//!
//! - `rel_error`: relative L2 error of the runtime's `B~` against the exact solve of
//!   `(I - R F) B = E` on the same fine mesh with the same samples per pair
//!   ([`lrr_precompute::exact`]). It isolates the low-rank error: at `k = n` (a 2MF bake whose
//!   patches are its elements) `F_k` is `F` pair for pair (same seeds) and only f32/f16
//!   rounding is left.
//! - `rel_error_ref`: the same against an exact solve with `ref_samples` samples per pair, so
//!   it includes the form-factor sampling error a user actually gets.
//! - `truth_median`, `truth_p90`, `truth_max` (with `--reference`): the total error at points
//!   where an independent path tracer measured the radiosity ([`truth`]): discretisation,
//!   sampling and low-rank error together, what a user sees.
//! - bake time, split by stage (mesh, visibility, form factors, operator), and the runtime's
//!   frame time (median over interleaved rounds, f32 and f16 side by side).
//!
//! Every point is a [`BakeSettings`] run through the ordinary [`bake`] pipeline, 2MF and 2MSC
//! alike. The exact solves depend only on the fine mesh and the samples, so each is computed
//! once per (element size, samples) and kept for the sweep.
//!
//! [`analysis`] finds the Pareto front and the `k` each method needs at equal error;
//! [`report`] writes the CSV and the markdown table; [`plot`] the PNG and SVG figures.

pub mod analysis;
pub mod plan;
pub mod plot;
pub mod report;
pub mod row;
pub mod truth;

use std::time::Instant;

use lrr_runtime::{Operator, Precision, Rgb, RgbMut};

use lrr_precompute::bake::{BakeSettings, Prepared, bake};
use lrr_precompute::error::{Error, Result};
use lrr_precompute::exact::solve_exact;
use lrr_precompute::geometry::Polygon;
use lrr_precompute::mesh::MeshSizes;
use lrr_precompute::patches::PatchMethod;
use lrr_precompute::pool::with_threads;
use lrr_precompute::progress::Progress;
use lrr_precompute::radiosity::{ElementData, relative_l2};
use lrr_precompute::scene::Scene;
use lrr_precompute::visibility::Backend;
use lrr_precompute::write::{operator_file, store_matrix_as};

pub use plan::{Plan, PlanOptions};
pub use row::Row;
pub use truth::Truth;

/// How frames are timed.
#[derive(Debug, Clone, Copy)]
pub struct FrameTiming {
    /// Rounds; each times f32 then f16 frames back to back.
    pub rounds: usize,
    /// Seconds of frames per precision and round (at least 3 frames).
    pub seconds: f64,
}

/// An exact solution kept for the sweep.
struct Exact {
    element_size: f64,
    samples: u32,
    polygons: Vec<Polygon>,
    radiosity: Vec<[f64; 3]>,
    seconds: f64,
}

/// Runs the sweep; `log` gets one line per finished step (for progress on stderr). With
/// `truth`, every row also gets its error against those reference points.
pub fn run(
    scene: &Scene,
    plan: &Plan,
    truth: Option<&Truth>,
    threads: Option<usize>,
    timing: FrameTiming,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<Row>> {
    let eval_threads = threads.unwrap_or(0);
    let mut cache: Vec<Exact> = Vec::new();
    let mut rows = Vec::new();
    for (i, settings) in plan.points.iter().enumerate() {
        let element_size = settings
            .element_size
            .ok_or_else(|| Error::Settings("a sweep point needs an element size".into()))?;
        let same = exact(
            scene,
            &mut cache,
            element_size,
            settings.samples,
            threads,
            log,
        )?;
        let reference = match plan.ref_samples {
            Some(s) => Some(exact(scene, &mut cache, element_size, s, threads, log)?),
            None => None,
        };
        let settings = BakeSettings {
            threads,
            ..settings.clone()
        };
        let against = Against {
            cache: &cache,
            same,
            reference,
            truth,
        };
        let point = measure(scene, &settings, &against, eval_threads, timing)?;
        for r in &point {
            log(&format!(
                "[{}/{}] {} n = {} k = {} samples = {} {}: error {:.3e}{}, bake {:.2} s, frame {:.1} µs",
                i + 1,
                plan.points.len(),
                r.method,
                r.n,
                r.k,
                r.samples,
                r.precision,
                r.rel_error,
                r.truth.map_or(String::new(), |t| format!(
                    " (path tracer: median {:.2}%, p90 {:.2}%{})",
                    100.0 * t.median,
                    100.0 * t.p90,
                    r.truth_smooth.map_or(String::new(), |s| format!(
                        "; smooth {:.2}%, {:.2}%",
                        100.0 * s.median,
                        100.0 * s.p90
                    ))
                )),
                r.bake_s,
                r.frame_s * 1e6
            ));
        }
        rows.extend(point);
    }
    Ok(rows)
}

/// Index of the exact solution for (element size, samples), solving it if not cached.
fn exact(
    scene: &Scene,
    cache: &mut Vec<Exact>,
    element_size: f64,
    samples: u32,
    threads: Option<usize>,
    log: &mut dyn FnMut(&str),
) -> Result<usize> {
    if let Some(i) = cache
        .iter()
        .position(|e| e.element_size == element_size && e.samples == samples)
    {
        return Ok(i);
    }
    let start = Instant::now();
    let sizes = MeshSizes::resolve(scene, Some(element_size), None)?;
    let progress = Progress::hidden();
    let (polygons, radiosity) = with_threads(threads, || -> Result<_> {
        // The fine mesh does not depend on the patch method.
        let prepared = Prepared::new(
            scene,
            sizes,
            PatchMethod::TwoFixed,
            Backend::default(),
            &progress,
        )?;
        let ff = prepared.form_factors(samples);
        let (rho, emission) = prepared.element_materials();
        let data = ElementData {
            reflectance: &rho,
            emission: &emission,
        };
        let sol = solve_exact(&prepared.mesh, &data, &ff, None, &|_| {})?;
        let polygons: Vec<Polygon> = prepared.mesh.elements.iter().map(|e| e.polygon).collect();
        Ok((polygons, sol.radiosity))
    })??;
    let seconds = start.elapsed().as_secs_f64();
    log(&format!(
        "exact solve: n = {} elements, {samples} samples per pair, {seconds:.2} s",
        polygons.len()
    ));
    cache.push(Exact {
        element_size,
        samples,
        polygons,
        radiosity,
        seconds,
    });
    Ok(cache.len() - 1)
}

/// What a bake is measured against: the exact solves (`cache`, the same-samples one at
/// `same`, the high-sample one at `reference`) and the path-traced points.
struct Against<'a> {
    cache: &'a [Exact],
    same: usize,
    reference: Option<usize>,
    truth: Option<&'a Truth>,
}

/// Bakes one point and measures it at f32 and f16.
fn measure(
    scene: &Scene,
    settings: &BakeSettings,
    against: &Against,
    eval_threads: usize,
    timing: FrameTiming,
) -> Result<Vec<Row>> {
    let progress = Progress::hidden();
    let start = Instant::now();
    let baked = bake(scene, settings, &progress)?;
    let bake_s = start.elapsed().as_secs_f64();
    let stage = |name: &str| -> f64 {
        progress
            .timings()
            .iter()
            .filter(|(s, _)| s == name)
            .map(|(_, t)| t)
            .sum()
    };
    let Against {
        cache,
        same,
        reference,
        truth,
    } = *against;
    let exact = &cache[same];
    let same_mesh = baked.mesh.elements.len() == exact.polygons.len()
        && baked
            .mesh
            .elements
            .iter()
            .zip(&exact.polygons)
            .all(|(e, p)| e.polygon == *p);
    if !same_mesh {
        return Err(Error::Settings(format!(
            "the {} bake's fine mesh ({} elements) differs from the exact solve's ({}) at \
             element size {}; the sweep compares on one fine mesh, so the patch method must \
             not change the elements",
            baked.method.name(),
            baked.n(),
            exact.polygons.len(),
            exact.element_size
        )));
    }
    let f32_file = operator_file(&baked)?;
    let mut f16_file = f32_file.clone();
    let f32_op = Operator::from_file(f32_file).map_err(runtime_error)?;
    store_matrix_as(&mut f16_file, Precision::F16);
    let f16_op = Operator::from_file(f16_file).map_err(runtime_error)?;
    let emission = f32_op.baked_emission();
    let ops = [(&f32_op, "f32"), (&f16_op, "f16")];
    let frames = time_frames(&ops, &emission, eval_threads, timing)?;
    let mut rows = Vec::new();
    for ((op, precision), frame_s) in ops.iter().zip(frames) {
        let b = radiosity(op, &emission, eval_threads)?;
        rows.push(Row {
            method: baked.method.name(),
            n: baked.n(),
            k: baked.k(),
            samples: settings.samples,
            precision,
            rel_error: relative_l2(&b, &exact.radiosity),
            rel_error_ref: reference.map(|r| relative_l2(&b, &cache[r].radiosity)),
            ref_samples: reference.map(|r| cache[r].samples),
            truth: truth.map(|t| t.error(op, &b)),
            truth_smooth: truth.and_then(|t| t.smooth_error(op, &b)),
            truth_noise: truth.map(|t| t.noise.median),
            bake_s,
            mesh_s: stage("mesh"),
            visibility_s: stage("visibility"),
            form_factors_s: stage("form factors"),
            operator_s: stage("operator"),
            frame_s,
            element_size: baked.sizes.element_size,
            patch_size: match baked.method {
                PatchMethod::TwoFixed => Some(baked.sizes.patch_size),
                PatchMethod::SpatialCoherence { .. } => None,
            },
            threshold: match baked.method {
                PatchMethod::TwoFixed => None,
                PatchMethod::SpatialCoherence { threshold, .. } => Some(threshold),
            },
            exact_s: exact.seconds,
            condition: baked.condition(),
        });
    }
    Ok(rows)
}

fn runtime_error(e: lrr_runtime::RuntimeError) -> Error {
    Error::Numerical(format!("the runtime refused the baked operator: {e}"))
}

/// One frame's radiosity (original element ids) as f64.
fn radiosity(op: &Operator, emission: &[[f32; 3]], threads: usize) -> Result<Vec<[f64; 3]>> {
    let mut eval = op.evaluator(threads).map_err(runtime_error)?;
    let mut b = vec![[0.0f32; 3]; op.n()];
    eval.evaluate(Rgb::triples(emission), RgbMut::triples(&mut b))
        .map_err(runtime_error)?;
    Ok(b.iter().map(|x| x.map(f64::from)).collect())
}

/// Median seconds per frame of each operator, timed in interleaved rounds so that a change of
/// machine load hits every variant alike.
fn time_frames(
    ops: &[(&Operator, &str)],
    emission: &[[f32; 3]],
    threads: usize,
    timing: FrameTiming,
) -> Result<Vec<f64>> {
    let mut evals = Vec::new();
    for (op, _) in ops {
        evals.push(op.evaluator(threads).map_err(runtime_error)?);
    }
    let mut out = vec![[0.0f32; 3]; emission.len()];
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); ops.len()];
    for _ in 0..timing.rounds.max(1) {
        for (eval, t) in evals.iter_mut().zip(&mut times) {
            let mut frame = || {
                eval.evaluate(Rgb::triples(emission), RgbMut::triples(&mut out))
                    .map_err(runtime_error)
            };
            frame()?; // warm caches
            let start = Instant::now();
            let mut frames = 0u32;
            while frames < 3 || start.elapsed().as_secs_f64() < timing.seconds {
                frame()?;
                frames += 1;
            }
            t.push(start.elapsed().as_secs_f64() / f64::from(frames));
        }
    }
    Ok(times.into_iter().map(analysis::median).collect())
}
