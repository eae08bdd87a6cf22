//! `lrr accuracy`: sweep the settings that trade accuracy for time, write CSV, markdown, plots.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;

use crate::load_scene;
use crate::sweep::{self, FrameTiming, PlanOptions, Truth, plot, report};

/// Default 2MSC thresholds of the full sweep (the merge rule's estimated relative error;
/// smaller: more patches).
pub const FULL_THRESHOLDS: [f64; 8] = [1e-2, 5e-3, 3e-3, 2e-3, 1e-3, 5e-4, 3e-4, 2e-4];
/// Default 2MSC thresholds of `--quick`.
pub const QUICK_THRESHOLDS: [f64; 5] = [1e-2, 3e-3, 1e-3, 5e-4, 3e-4];
/// Default thresholds of 2MSC by the split rule (`--methods …,2msc-split`), full sweep.
pub const FULL_SPLIT_THRESHOLDS: [f64; 7] = [3e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5];
/// Default split-rule thresholds of `--quick`.
pub const QUICK_SPLIT_THRESHOLDS: [f64; 5] = [3e-3, 1e-3, 5e-4, 2e-4, 1e-4];

#[derive(Debug, Args)]
pub struct AccuracyArgs {
    /// Scene: an OBJ file or an lrr scene description (.toml).
    pub scene: PathBuf,
    /// A small sweep for CI (one coarse fine mesh, 16 samples; about a minute on 2 cores).
    #[arg(long)]
    pub quick: bool,
    /// Write the rows as CSV (columns method,n,k,samples,precision,rel_error,bake_s,frame_s,…).
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Write the markdown report (table, Pareto fronts, k ratio) to FILE as well as stdout.
    #[arg(long, value_name = "FILE")]
    pub markdown: Option<PathBuf>,
    /// Write the plots PREFIX.png and PREFIX.svg (needs a TrueType font: see `LRR_FONT`).
    #[arg(long, value_name = "PREFIX")]
    pub plot: Option<PathBuf>,
    /// Worker threads of the bakes and the runtime [default: all cores].
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Methods to sweep (`2msc-split`: 2MSC by the papers' split rule, with --split-thresholds).
    #[arg(long, value_delimiter = ',', default_value = "2mf,2msc", value_parser = ["2mf", "2msc", "2msc-split"])]
    pub methods: Vec<String>,
    /// Fine element sizes in scene units, the first the main one [default: 1/12 and 1/8 of
    /// the scene's diagonal; --quick: 1/10].
    #[arg(long, value_delimiter = ',', value_name = "L,…")]
    pub element_sizes: Vec<f64>,
    /// 2MF patch sizes as multiples of the element size; 1 gives k = n
    /// [default: 1,1.5,2,3,4,6,8,12; --quick: 1,1.5,2,3,4,6].
    #[arg(long, value_delimiter = ',', value_name = "M,…")]
    pub patch_multiples: Vec<f64>,
    /// 2MSC thresholds, the estimated relative error of the patches
    /// [default: 1e-2,5e-3,3e-3,2e-3,1e-3,5e-4,3e-4,2e-4; --quick: 1e-2,3e-3,1e-3,5e-4,3e-4].
    #[arg(long, value_delimiter = ',', value_name = "T,…")]
    pub thresholds: Vec<f64>,
    /// 2msc-split's coherence thresholds [default: 3e-3,1e-3,5e-4,2e-4,1e-4,5e-5,2e-5;
    /// --quick: 3e-3,1e-3,5e-4,2e-4,1e-4].
    #[arg(long, value_delimiter = ',', value_name = "T,…")]
    pub split_thresholds: Vec<f64>,
    /// 2msc-split: patches of at most this area are not split [default: chosen by the method].
    #[arg(long, value_name = "A")]
    pub min_patch_area: Option<f64>,
    /// Samples per pair, the first the main one [default: 16,4,32; --quick: 16].
    #[arg(long, value_delimiter = ',', value_name = "S,…")]
    pub samples: Vec<u32>,
    /// Samples per pair of the reference exact solve (column rel_error_ref) [default: 32].
    #[arg(long, value_name = "S")]
    pub ref_samples: Option<u32>,
    /// No reference exact solve (drops rel_error_ref).
    #[arg(long, conflicts_with = "ref_samples")]
    pub no_ref: bool,
    /// Points where an independent path tracer measured this scene's radiosity
    /// (tests/data/reference/NAME.json): adds the total-error columns truth_median, truth_p90,
    /// truth_max and truth_noise (docs/ACCURACY.md, "Against an independent path tracer").
    #[arg(long, value_name = "FILE")]
    pub reference: Option<PathBuf>,
    /// Rounds of frame timing (each times f32 and f16 back to back).
    #[arg(long, default_value_t = 7)]
    pub rounds: usize,
    /// Seconds of frames per precision and round.
    #[arg(long, default_value_t = 0.03)]
    pub frame_seconds: f64,
    /// No progress lines on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

impl AccuracyArgs {
    fn options(&self, scene: &lrr_precompute::scene::Scene) -> PlanOptions {
        let mut o = if self.quick {
            PlanOptions::quick(scene, &QUICK_THRESHOLDS)
        } else {
            PlanOptions::full(scene, &FULL_THRESHOLDS)
        };
        if !self.element_sizes.is_empty() {
            o.element_sizes = self.element_sizes.clone();
        }
        if !self.patch_multiples.is_empty() {
            o.patch_multiples = self.patch_multiples.clone();
        }
        if !self.thresholds.is_empty() {
            o.thresholds = self.thresholds.clone();
        }
        if !self.samples.is_empty() {
            o.samples = self.samples.clone();
        }
        o.min_patch_area = self.min_patch_area;
        if !self.methods.iter().any(|m| m == "2mf") {
            o.patch_multiples.clear();
        }
        if !self.methods.iter().any(|m| m == "2msc") {
            o.thresholds.clear();
        }
        if self.methods.iter().any(|m| m == "2msc-split") {
            o.split_thresholds = if !self.split_thresholds.is_empty() {
                self.split_thresholds.clone()
            } else if self.quick {
                QUICK_SPLIT_THRESHOLDS.to_vec()
            } else {
                FULL_SPLIT_THRESHOLDS.to_vec()
            };
        }
        if self.no_ref {
            o.ref_samples = None;
        } else if let Some(s) = self.ref_samples {
            o.ref_samples = Some(s);
        }
        o
    }

    /// The command line that reproduces this sweep (for the report).
    fn command(&self) -> String {
        let mut c = format!("lrr accuracy {}", self.scene.display());
        if self.quick {
            c.push_str(" --quick");
        }
        let list = |v: &[f64]| v.iter().map(f64::to_string).collect::<Vec<_>>().join(",");
        for (flag, v) in [
            ("--element-sizes", &self.element_sizes),
            ("--patch-multiples", &self.patch_multiples),
            ("--thresholds", &self.thresholds),
            ("--split-thresholds", &self.split_thresholds),
        ] {
            if !v.is_empty() {
                c.push_str(&format!(" {flag} {}", list(v)));
            }
        }
        if !self.samples.is_empty() {
            let s: Vec<String> = self.samples.iter().map(u32::to_string).collect();
            c.push_str(&format!(" --samples {}", s.join(",")));
        }
        if self.methods != ["2mf", "2msc"] {
            c.push_str(&format!(" --methods {}", self.methods.join(",")));
        }
        if let Some(a) = self.min_patch_area {
            c.push_str(&format!(" --min-patch-area {a}"));
        }
        if let Some(s) = self.ref_samples {
            c.push_str(&format!(" --ref-samples {s}"));
        }
        if self.no_ref {
            c.push_str(" --no-ref");
        }
        if let Some(r) = &self.reference {
            c.push_str(&format!(" --reference {}", r.display()));
        }
        if let Some(t) = self.threads {
            c.push_str(&format!(" --threads {t}"));
        }
        c
    }
}

/// The CPU model (Linux /proc/cpuinfo) and the threads available, for the report.
pub fn machine() -> String {
    let model = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, m)| m.trim().to_string())
        })
        .unwrap_or_else(|| "an unknown CPU".into());
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    format!("{model} ({threads} hardware threads)")
}

pub fn run(a: &AccuracyArgs, out: &mut dyn Write) -> Result<()> {
    if a.rounds == 0 || !(a.frame_seconds.is_finite() && a.frame_seconds > 0.0) {
        bail!("--rounds must be at least 1 and --frame-seconds positive");
    }
    let scene = load_scene(&a.scene)?;
    crate::solve::lights_left_out(&scene, "lrr accuracy");
    let plan = a.options(&scene).plan()?;
    let truth = match &a.reference {
        Some(path) => Some(Truth::load(path, &scene)?),
        None => None,
    };
    let timing = FrameTiming {
        rounds: a.rounds,
        seconds: a.frame_seconds,
    };
    let quiet = a.quiet;
    let mut log = |line: &str| {
        if !quiet {
            eprintln!("lrr accuracy: {line}");
        }
    };
    log(&format!("{} bakes to run", plan.points.len()));
    let rows = sweep::run(&scene, &plan, truth.as_ref(), a.threads, timing, &mut log)?;
    if let Some(path) = &a.csv {
        lrr_formats::write_atomic(path, report::csv(&rows).as_bytes())
            .with_context(|| format!("writing the CSV {}", path.display()))?;
    }
    let text = report::markdown(&scene.name, &machine(), &a.command(), &rows);
    if let Some(path) = &a.markdown {
        lrr_formats::write_atomic(path, text.as_bytes())
            .with_context(|| format!("writing the markdown {}", path.display()))?;
    }
    write!(out, "{text}")?;
    if let Some(prefix) = &a.plot {
        let title = format!("{}: accuracy against cost", scene.name);
        let written = plot::write(prefix, &title, &rows)
            .with_context(|| format!("writing the plots {}.png/.svg", prefix.display()))?;
        for p in written {
            log(&format!("wrote {}", p.display()));
        }
    }
    Ok(())
}
