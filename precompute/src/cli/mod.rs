//! The `lrr` command line (clap). [`run`] takes the arguments and an output stream so tests
//! can call every command in-process; `main.rs` only prints the error chain and sets the exit code.

mod accuracy;
mod bake;
mod bench;
mod bench_visibility;
mod info;
mod probe;
mod scene;
mod solve;
mod summary;
mod view_factors;

use std::ffi::OsString;
use std::io::Write;

use anyhow::Result;
use clap::{Args, Parser, Subcommand};

use crate::bake::{BakeSettings, DEFAULT_SAMPLES};
use crate::patches::PatchMethod;

/// Default 2MSC threshold (`--threshold`): the largest estimated share of the scene's
/// reflected power a patch may get wrong. On the Cornell box it gives k = 154 at a relative
/// L2 error of 0.0015 against the exact solve, where 2MF's default gives k = 242 at 0.0018
/// (docs/MESHING.md).
pub const DEFAULT_COHERENCE_THRESHOLD: f64 = 1e-4;

/// lrr: low-rank radiosity. Bake a lighting operator from a scene, inspect it, probe it.
#[derive(Debug, Parser)]
#[command(
    name = "lrr",
    version,
    about = "lrr: low-rank radiosity. Bake a lighting operator from a scene, inspect it, probe it."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Bake a scene (OBJ or .toml scene description) into an operator file.
    Bake(bake::BakeArgs),
    /// Describe an operator file: sizes, bake settings, radiosity per surface.
    Info(info::InfoArgs),
    /// Radiosity at surface points, from an operator file.
    Probe(probe::ProbeArgs),
    /// Form factors between the scene's named surfaces (visibility included).
    ViewFactors(view_factors::ViewFactorsArgs),
    /// Solve the radiosity of a scene without writing a file (low-rank, or --exact).
    Solve(solve::SolveArgs),
    /// Write a generated scene description (furnace, analytic pairs).
    Scene(scene::SceneArgs),
    /// What accuracy costs in time: sweep 2MF/2MSC over k, n, samples, f32/f16; CSV, markdown, plots.
    Accuracy(accuracy::AccuracyArgs),
    /// Benchmarks: `lrr bench runtime` (frame rates against the dense baseline and a memory
    /// read), `lrr bench visibility` (occlusion rays/s of the visibility backends).
    Bench(bench::BenchArgs),
}

/// Settings that change the fine mesh or the form factors; shared by bake, solve, view-factors.
#[derive(Debug, Clone, Args)]
pub struct MeshArgs {
    /// Longest edge of a fine element, in scene units [default: scene hint, else 1/20 of the
    /// scene's bounding-box diagonal].
    #[arg(long, value_name = "L")]
    pub element_size: Option<f64>,
    /// Longest edge of a coarse patch, in scene units [default: scene hint, else 1/6 of the
    /// bounding-box diagonal].
    #[arg(long, value_name = "L")]
    pub patch_size: Option<f64>,
    /// How patches are built: `2mf` (uniform cut at the patch size) or `2msc` (adaptive:
    /// split while a patch lacks spatial coherence; `k` is an output).
    #[arg(long, value_name = "METHOD", default_value = "2mf", value_parser = ["2mf", "2msc"])]
    pub method: String,
    /// 2MSC: largest estimated error share of a patch (docs/MESHING.md); smaller gives more
    /// patches.
    #[arg(long, value_name = "T", default_value_t = DEFAULT_COHERENCE_THRESHOLD)]
    pub threshold: f64,
    /// 2MSC: patches of at most this area (scene units²) are not split further
    /// [default: chosen by the method].
    #[arg(long, value_name = "A")]
    pub min_patch_area: Option<f64>,
    /// Quadrature points and visibility rays per element-patch pair (a square gives a midpoint rule).
    #[arg(long, value_name = "S", default_value_t = DEFAULT_SAMPLES)]
    pub samples: u32,
    /// Occlusion backend: `obvhs` (pure Rust, exact f64 triangle test) or `embree` (Embree 4,
    /// builds with the cargo feature `embree` only; see scripts/setup-embree.sh).
    #[arg(long, value_name = "BACKEND", default_value = "obvhs", value_parser = ["obvhs", "embree"])]
    pub visibility: String,
    /// Worker threads [default: all cores]. Results do not depend on it.
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Refuse jobs whose working memory would exceed this (bytes, or with a K/M/G/T suffix)
    /// [default: 80% of the memory available].
    #[arg(long, value_name = "BYTES", value_parser = parse_bytes)]
    pub max_memory: Option<u64>,
    /// No progress bars.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Parses "1000", "512M", "2G" (binary multiples).
fn parse_bytes(text: &str) -> std::result::Result<u64, String> {
    let t = text.trim();
    let (digits, shift) = match t.chars().last().map(|c| c.to_ascii_uppercase()) {
        Some('K') => (&t[..t.len() - 1], 10),
        Some('M') => (&t[..t.len() - 1], 20),
        Some('G') => (&t[..t.len() - 1], 30),
        Some('T') => (&t[..t.len() - 1], 40),
        _ => (t, 0),
    };
    let v: f64 = digits
        .trim()
        .parse()
        .map_err(|_| format!("'{text}' is not a size like 4096, 512M or 2G"))?;
    if !(v.is_finite() && v >= 0.0) {
        return Err(format!("'{text}' is not a size like 4096, 512M or 2G"));
    }
    Ok((v * (1u64 << shift) as f64) as u64)
}

impl MeshArgs {
    pub fn settings(&self) -> BakeSettings {
        BakeSettings {
            element_size: self.element_size,
            patch_size: self.patch_size,
            method: self.method(),
            samples: self.samples,
            visibility: crate::visibility::Backend::parse(&self.visibility).unwrap_or_default(),
            threads: self.threads,
            max_memory: self.max_memory,
            checkpoint: None,
        }
    }

    /// The patch method the flags name.
    pub fn method(&self) -> PatchMethod {
        match self.method.as_str() {
            "2msc" => PatchMethod::SpatialCoherence {
                threshold: self.threshold,
                min_patch_area: self.min_patch_area,
            },
            _ => PatchMethod::TwoFixed,
        }
    }

    pub fn progress(&self) -> crate::progress::Progress {
        use std::io::IsTerminal;
        crate::progress::Progress::new(!self.quiet && std::io::stderr().is_terminal())
    }
}

/// Runs the command line with `args` (the first is the program name), writing to `out`.
pub fn run<I, T>(args: I, out: &mut dyn Write) -> Result<()>
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e)
            if matches!(
                e.kind(),
                clap::error::ErrorKind::DisplayHelp | clap::error::ErrorKind::DisplayVersion
            ) =>
        {
            write!(out, "{e}")?;
            return Ok(());
        }
        Err(e) => return Err(anyhow::anyhow!(e.render().to_string().trim().to_string())),
    };
    match cli.command {
        Command::Bake(a) => bake::run(&a, out),
        Command::Info(a) => info::run(&a, out),
        Command::Probe(a) => probe::run(&a, out),
        Command::ViewFactors(a) => view_factors::run(&a, out),
        Command::Solve(a) => solve::run(&a, out),
        Command::Scene(a) => scene::run(&a, out),
        Command::Bench(a) => bench::run(&a, out),
        Command::Accuracy(a) => accuracy::run(&a, out),
    }
}

/// Loads a scene, printing its import warnings to stderr.
pub fn load_scene(path: &std::path::Path) -> Result<crate::scene::Scene> {
    let scene = crate::scene::load(path)?;
    for w in &scene.warnings {
        eprintln!("lrr: warning: {w}");
    }
    Ok(scene)
}
