//! `lrr bench visibility`: occlusion throughput of the visibility backends on the same
//! form-factor rays, measured side by side in one run.
//!
//! Per scene (the bundled Cornell box; the generated cluttered room), the rays a default bake
//! casts are recorded once ([`crate::record`]), then answered by
//! - `embree`: Embree 4, one `rtcOccluded1` per ray (only in builds with the feature `embree`);
//! - `obvhs`: the project's obvhs BVH, one [`Occluder::occluded`] per ray;
//! - `default`: the occluder a plain bake builds, through [`Occluder::occluded_bundle`] per
//!   element-target pair, exactly as the form-factor integration calls it;
//!
//! on one thread and on all cores (rayon over the pairs), backends interleaved within each
//! round. Reported: median rays/s over rounds, median per-round ratio to Embree, BVH build
//! times (median of the rounds), and how many answers differ from obvhs.

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
use lrr_precompute::visibility::{Backend, Occluder, obvhs::ObvhsOccluder};

#[derive(Debug, Args)]
pub struct VisibilityBench {
    /// Scenes: `cornell` (the bundled Cornell box), `cluttered` (`lrr scene cluttered`
    /// defaults), or paths to scene files.
    #[arg(long, value_delimiter = ',', default_value = "cornell,cluttered")]
    pub scenes: Vec<String>,
    /// Form-factor rays recorded per scene (at least; whole element rows are kept).
    #[arg(long, default_value_t = 1_000_000)]
    pub rays: usize,
    /// Rounds; each round times every backend on one thread, then on all cores.
    #[arg(long, default_value_t = 5)]
    pub rounds: usize,
    /// Threads of the "all cores" runs [default: all cores].
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
    /// `embree`, `obvhs` or `default` (the path a plain bake uses).
    pub backend: &'static str,
    pub threads: usize,
    /// Median over rounds.
    pub rays_per_s: f64,
    /// Median over rounds of this backend's rays/s over Embree's in the same round (absent
    /// without Embree).
    pub ratio_vs_embree: Option<f64>,
    pub rays: usize,
    /// Median seconds to build the backend's acceleration structure.
    pub build_s: f64,
    /// Rays answered "blocked".
    pub blocked: usize,
    /// Rays whose answer differs from obvhs' single-ray answer.
    pub differs_from_obvhs: usize,
}

struct Contender {
    name: &'static str,
    occ: Box<dyn Occluder>,
    bundles: bool,
    build_s: Vec<f64>,
}

pub fn run(b: &VisibilityBench, out: &mut dyn Write) -> Result<()> {
    let all = b
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    if all == 0 {
        bail!("--threads must be at least 1");
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

/// Answers every ray of `set` with `threads` threads, pair by pair; returns (seconds, answers).
fn answer(set: &RaySet, c: &Contender, threads: usize) -> Result<(f64, Vec<bool>)> {
    let mut blocked = vec![false; set.rays()];
    let occ = &*c.occ;
    let seconds = with_threads(Some(threads), || {
        // Split the answers along the bundles so that each task owns its slice.
        let mut slices = Vec::with_capacity(set.bundles.len());
        let mut rest = &mut blocked[..];
        for bundle in &set.bundles {
            let (head, tail) = rest.split_at_mut(bundle.end - bundle.start);
            slices.push((bundle, head));
            rest = tail;
        }
        let start = Instant::now();
        slices.into_par_iter().for_each(|(bundle, out)| {
            let segments = &set.segments[bundle.start..bundle.end];
            if c.bundles {
                occ.occluded_bundle(&bundle.element, &bundle.target, segments, out);
            } else {
                for (s, o) in segments.iter().zip(out.iter_mut()) {
                    *o = occ.occluded(s.from, bundle.element.normal, s.to, bundle.target.normal);
                }
            }
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
    if Backend::Embree.available() {
        let (t, occ) = timed_build(Backend::Embree)?;
        contenders.push(Contender {
            name: "embree",
            occ,
            bundles: false,
            build_s: vec![t],
        });
    }
    let start = Instant::now();
    let obvhs = ObvhsOccluder::build(scene);
    contenders.push(Contender {
        name: "obvhs",
        occ: Box::new(obvhs),
        bundles: false,
        build_s: vec![start.elapsed().as_secs_f64()],
    });
    let (t, occ) = timed_build(Backend::default())?;
    contenders.push(Contender {
        name: "default",
        occ,
        bundles: true,
        build_s: vec![t],
    });
    let threads = if all > 1 { vec![1, all] } else { vec![1] };
    // rates[contender][thread setting] per round; ratios likewise.
    let mut rates = vec![vec![Vec::new(); threads.len()]; contenders.len()];
    let mut ratios = vec![vec![Vec::new(); threads.len()]; contenders.len()];
    let mut answers: Vec<Vec<bool>> = vec![Vec::new(); contenders.len()];
    for round in 0..b.rounds.max(1) {
        if round > 0 {
            // Build times too are medians of the rounds.
            for c in contenders.iter_mut() {
                let start = Instant::now();
                let occ = match c.name {
                    "obvhs" => Box::new(ObvhsOccluder::build(scene)) as Box<dyn Occluder>,
                    "embree" => Backend::Embree.build(scene)?,
                    _ => Backend::default().build(scene)?,
                };
                c.build_s.push(start.elapsed().as_secs_f64());
                c.occ = occ;
            }
        }
        for (ti, &t) in threads.iter().enumerate() {
            let mut this_round = Vec::with_capacity(contenders.len());
            for (ci, c) in contenders.iter().enumerate() {
                let (seconds, blocked) = answer(&set, c, t)?;
                let rate = set.rays() as f64 / seconds;
                rates[ci][ti].push(rate);
                this_round.push(rate);
                answers[ci] = blocked;
            }
            if contenders[0].name == "embree" {
                for (ci, r) in this_round.iter().enumerate() {
                    ratios[ci][ti].push(r / this_round[0]);
                }
            }
        }
        eprintln!(
            "lrr bench: {name}: round {} of {} done",
            round + 1,
            b.rounds.max(1)
        );
    }
    let obvhs_answers = &answers[contenders
        .iter()
        .position(|c| c.name == "obvhs")
        .expect("obvhs is always measured")];
    let mut rows = Vec::new();
    for (ti, &t) in threads.iter().enumerate() {
        for (ci, c) in contenders.iter().enumerate() {
            rows.push(Row {
                scene: name.to_string(),
                backend: c.name,
                threads: t,
                rays_per_s: median(rates[ci][ti].clone()),
                ratio_vs_embree: (!ratios[ci][ti].is_empty())
                    .then(|| median(ratios[ci][ti].clone())),
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
        "{:<10} {:<8} {:>4} {:>9} {:>12} {:>9} {:>9} {:>9} {:>8}",
        "scene", "backend", "thr", "rays", "rays/s", "÷embree", "build ms", "blocked", "≠obvhs"
    )?;
    for r in rows {
        let ratio = r
            .ratio_vs_embree
            .map_or_else(|| "-".to_string(), |x| format!("{x:.2}"));
        writeln!(
            out,
            "{:<10} {:<8} {:>4} {:>9} {:>12.0} {:>9} {:>9.1} {:>9} {:>8}",
            r.scene,
            r.backend,
            r.threads,
            r.rays,
            r.rays_per_s,
            ratio,
            r.build_s * 1e3,
            r.blocked,
            r.differs_from_obvhs
        )?;
    }
    Ok(())
}
