//! `lrr bench visibility`: occlusion throughput of the visibility backends on the same
//! form-factor rays, measured side by side in one run.
//!
//! Per scene (the bundled Cornell box; the generated cluttered room), the rays a default bake
//! casts are recorded once ([`crate::record`]), then answered by every backend the build has,
//! each exactly as a bake calls it: [`Occluder::occluded_bundle`] per element-target pair
//! (rayon over the pairs):
//! - `embree`: Embree 4 (only in builds with the feature `embree`), one `rtcOccluded1` per ray;
//! - `obvhs`: the default backend, the project's BVH with the exact f64 triangle test, its
//!   groups' balls and the bundles' hints ([`Occluder::clear_of`], asked before the clock, as
//!   a bake asks them once per row and target part).
//!
//! Each row is its own measurement: one backend on one thread count. (An earlier `default` row
//! timed the default backend's `occluded_bundle` under a second name beside the `obvhs` row,
//! when both were the same per-ray loop.)
//!
//! Protocol: `--runs` runs; in each, every thread count (one thread, then `--threads`) times
//! every backend once, in alternating order (forward in even runs, reversed in odd ones, so
//! that neither backend always goes first on a warming or cooling machine). Reported: the
//! median rays/s over runs, the median and range of the per-run ratio to Embree (both timed
//! within the same run, back to back), the median BVH build time, and how many answers differ
//! from obvhs'.

use std::io::Write;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use rayon::prelude::*;
use serde::Serialize;

use crate::record::{RaySet, record};
use lrr_precompute::bake::{DEFAULT_SAMPLES, Prepared};
use lrr_precompute::mesh::MeshSizes;
use lrr_precompute::patches::PatchMethod;
use lrr_precompute::pool::with_threads;
use lrr_precompute::progress::Progress;
use lrr_precompute::scene::{Scene, procedural};
use lrr_precompute::visibility::{Backend, Clear, Occluder};

#[derive(Debug, Args)]
pub struct VisibilityBench {
    /// Scenes: `cornell` (the bundled Cornell box), `cluttered` (`lrr scene cluttered`
    /// defaults), or paths to scene files.
    #[arg(long, value_delimiter = ',', default_value = "cornell,cluttered")]
    pub scenes: Vec<String>,
    /// Form-factor rays recorded per scene (at least; whole element rows are kept).
    #[arg(long, default_value_t = 1_000_000)]
    pub rays: usize,
    /// Runs; each times every backend on one thread, then on `--threads`, backends in
    /// alternating order. Rates and ratios are medians over runs.
    #[arg(long, alias = "rounds", default_value_t = 5)]
    pub runs: usize,
    /// Threads of the multi-threaded runs [default: all cores].
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print JSON rows instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// One scene × backend × thread count.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    pub scene: String,
    /// `embree` or `obvhs` (the default backend).
    pub backend: &'static str,
    pub threads: usize,
    /// Median over runs.
    pub rays_per_s: f64,
    /// Median over runs of this backend's rays/s over Embree's in the same run (absent
    /// without Embree).
    pub ratio_vs_embree: Option<f64>,
    /// Every run's ratio, in run order (empty without Embree).
    pub ratios_vs_embree: Vec<f64>,
    pub runs: usize,
    pub rays: usize,
    /// Median seconds to build the backend's acceleration structure.
    pub build_s: f64,
    /// Rays answered "blocked".
    pub blocked: usize,
    /// Rays whose answer differs from obvhs'.
    pub differs_from_obvhs: usize,
}

struct Contender {
    backend: Backend,
    occ: Box<dyn Occluder>,
    build_s: Vec<f64>,
}

pub fn run(b: &VisibilityBench, out: &mut dyn Write) -> Result<()> {
    let all = b
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    if all == 0 {
        bail!("--threads must be at least 1");
    }
    if b.runs == 0 {
        bail!("--runs must be at least 1");
    }
    let mut rows = Vec::new();
    for name in &b.scenes {
        let scene = load(name)?;
        rows.extend(measure(name, &scene, b, all)?);
    }
    if b.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&rows)?)?;
    } else {
        print_table(&rows, out)?;
        if !Backend::Embree.available() {
            writeln!(
                out,
                "embree: not in this build (run scripts/setup-embree.sh, then build with \
                 --features embree)"
            )?;
        }
    }
    Ok(())
}

fn load(name: &str) -> Result<Scene> {
    Ok(match name {
        "cornell" => {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../scenes/cornell-box/cornell-box.toml");
            lrr_precompute::scene::load(&path)?
        }
        "cluttered" => procedural::cluttered(4, 1).build("cluttered", std::path::Path::new("."))?,
        path => lrr_precompute::scene::load(std::path::Path::new(path)).with_context(|| {
            format!("--scenes: '{path}' is neither cornell, cluttered nor a scene file")
        })?,
    })
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Answers every ray of `set` with `threads` threads, pair by pair through
/// [`Occluder::occluded_bundle`] as a bake does; returns (seconds, answers).
fn answer(set: &RaySet, occ: &dyn Occluder, threads: usize) -> Result<(f64, Vec<bool>)> {
    let mut blocked = vec![false; set.rays()];
    let seconds = with_threads(Some(threads), || {
        // Split the answers along the bundles so that each task owns its slice.
        let mut slices = Vec::with_capacity(set.bundles.len());
        let mut rest = &mut blocked[..];
        for bundle in &set.bundles {
            let (head, tail) = rest.split_at_mut(bundle.end - bundle.start);
            slices.push((bundle, head));
            rest = tail;
        }
        // The hints a bake asks once per row and per target part, asked before the clock.
        let ends: Vec<[Clear; 2]> = (set.bundles.par_iter())
            .map(|b| [occ.clear_of(&b.element), occ.clear_of(&b.target)])
            .collect();
        let start = Instant::now();
        slices
            .into_par_iter()
            .zip(ends)
            .for_each(|((bundle, out), ends)| {
                let segments = &set.segments[bundle.start..bundle.end];
                occ.occluded_bundle(&bundle.element, &bundle.target, ends, segments, out);
            });
        start.elapsed().as_secs_f64()
    })?;
    Ok((seconds, blocked))
}

fn measure(name: &str, scene: &Scene, b: &VisibilityBench, all: usize) -> Result<Vec<Row>> {
    let sizes = MeshSizes::resolve(scene, None, None)?;
    let progress = Progress::hidden();
    let prepared = Prepared::new(
        scene,
        sizes,
        PatchMethod::TwoFixed,
        Backend::default(),
        &progress,
    )?;
    let set = with_threads(Some(1), || record(&prepared, DEFAULT_SAMPLES, b.rays))?;
    if set.rays() == 0 {
        bail!("scene '{name}': nothing occludes, a bake casts no rays to measure");
    }
    eprintln!(
        "lrr bench: {name}: {} rays in {} pairs recorded",
        set.rays(),
        set.bundles.len()
    );
    let timed_build = |backend: Backend| -> Result<(f64, Box<dyn Occluder>)> {
        let start = Instant::now();
        let occ = backend.build(scene)?;
        Ok((start.elapsed().as_secs_f64(), occ))
    };
    let mut contenders = Vec::new();
    for backend in [Backend::Embree, Backend::Obvhs] {
        if backend.available() {
            let (t, occ) = timed_build(backend)?;
            contenders.push(Contender {
                backend,
                occ,
                build_s: vec![t],
            });
        }
    }
    let threads = if all > 1 { vec![1, all] } else { vec![1] };
    // rates[contender][thread setting] per run; ratios likewise.
    let mut rates = vec![vec![Vec::new(); threads.len()]; contenders.len()];
    let mut ratios = vec![vec![Vec::new(); threads.len()]; contenders.len()];
    let mut answers: Vec<Vec<bool>> = vec![Vec::new(); contenders.len()];
    for run in 0..b.runs {
        if run > 0 {
            // Build times too are medians of the runs.
            for c in contenders.iter_mut() {
                let (t, occ) = timed_build(c.backend)?;
                c.build_s.push(t);
                c.occ = occ;
            }
        }
        // Forward in even runs, reversed in odd ones.
        let mut order: Vec<usize> = (0..contenders.len()).collect();
        if run % 2 == 1 {
            order.reverse();
        }
        for (ti, &t) in threads.iter().enumerate() {
            let mut this_run = vec![0.0; contenders.len()];
            for &ci in &order {
                let (seconds, blocked) = answer(&set, &*contenders[ci].occ, t)?;
                let rate = set.rays() as f64 / seconds;
                rates[ci][ti].push(rate);
                this_run[ci] = rate;
                answers[ci] = blocked;
            }
            if contenders[0].backend == Backend::Embree {
                for (ci, r) in this_run.iter().enumerate() {
                    ratios[ci][ti].push(r / this_run[0]);
                }
            }
        }
        eprintln!("lrr bench: {name}: run {} of {} done", run + 1, b.runs);
    }
    let obvhs_answers = &answers[contenders
        .iter()
        .position(|c| c.backend == Backend::Obvhs)
        .expect("obvhs is always available")];
    let mut rows = Vec::new();
    for (ti, &t) in threads.iter().enumerate() {
        for (ci, c) in contenders.iter().enumerate() {
            rows.push(Row {
                scene: name.to_string(),
                backend: c.backend.name(),
                threads: t,
                rays_per_s: median(rates[ci][ti].clone()),
                ratio_vs_embree: (!ratios[ci][ti].is_empty())
                    .then(|| median(ratios[ci][ti].clone())),
                ratios_vs_embree: ratios[ci][ti].clone(),
                runs: b.runs,
                rays: set.rays(),
                build_s: median(c.build_s.clone()),
                blocked: answers[ci].iter().filter(|&&x| x).count(),
                differs_from_obvhs: answers[ci]
                    .iter()
                    .zip(obvhs_answers)
                    .filter(|(a, b)| a != b)
                    .count(),
            });
        }
    }
    Ok(rows)
}

fn print_table(rows: &[Row], out: &mut dyn Write) -> Result<()> {
    writeln!(
        out,
        "{:<10} {:<8} {:>4} {:>9} {:>12} {:>9} {:>11} {:>9} {:>9} {:>8}",
        "scene",
        "backend",
        "thr",
        "rays",
        "rays/s",
        "÷embree",
        "range",
        "build ms",
        "blocked",
        "≠obvhs"
    )?;
    for r in rows {
        let ratio = r
            .ratio_vs_embree
            .map_or_else(|| "-".to_string(), |x| format!("{x:.2}"));
        let (lo, hi) = r
            .ratios_vs_embree
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
                (lo.min(x), hi.max(x))
            });
        let range = if r.ratios_vs_embree.is_empty() {
            "-".to_string()
        } else {
            format!("{lo:.2}–{hi:.2}")
        };
        writeln!(
            out,
            "{:<10} {:<8} {:>4} {:>9} {:>12.0} {:>9} {:>11} {:>9.1} {:>9} {:>8}",
            r.scene,
            r.backend,
            r.threads,
            r.rays,
            r.rays_per_s,
            ratio,
            range,
            r.build_s * 1e3,
            r.blocked,
            r.differs_from_obvhs
        )?;
    }
    writeln!(
        out,
        "(medians over {} runs, backends alternated; ÷embree: median and range of the per-run \
         ratios)",
        rows.first().map_or(0, |r| r.runs)
    )?;
    Ok(())
}
