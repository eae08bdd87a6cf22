//! # lrr-cli: the `lrr` command line
//!
//! A thin binary over the bake library ([`lrr_precompute`]) and the runtime ([`lrr_runtime`]):
//! one file per command, parsed with clap. [`run`] takes the arguments and an output stream so
//! tests can call every command in-process; `main.rs` only prints the error chain and sets the
//! exit code. What only the command line needs lives here, not in the library: the accuracy
//! sweep and its plots ([`sweep`], plotters), the benchmarks, and the recorder of bake rays
//! ([`record`]).

// Indexed loops over RGB channels read like the maths they implement.
#![allow(clippy::needless_range_loop)]

mod accuracy;
mod bake;
mod bench;
mod bench_gpu;
mod bench_lightmap;
mod bench_lights;
mod bench_operators;
mod bench_render;
#[cfg(feature = "embree")]
mod bench_render_embree;
mod bench_visibility;
mod emission;
pub mod export;
mod exr_image;
mod info;
mod merge;
mod picture;
mod plan;
mod probe;
pub mod record;
pub mod relight;
mod render;
mod scene;
mod shard;
mod solve;
mod summary;
pub mod sweep;
#[cfg(feature = "view")]
mod view;
mod view_factors;

use std::ffi::OsString;
use std::io::Write;

use anyhow::Result;
use clap::{Args, Parser, Subcommand};

use lrr_precompute::bake::{BakeSettings, DEFAULT_SAMPLES};
use lrr_precompute::patches::CoherenceRule;
use lrr_precompute::patches::PatchMethod;
use lrr_precompute::patches::coherence::DEFAULT_THRESHOLD as DEFAULT_SPLIT_THRESHOLD;
use lrr_precompute::patches::coherence::merge::DEFAULT_THRESHOLD as DEFAULT_MERGE_THRESHOLD;
use lrr_precompute::scene::BakeDefaults;
use lrr_precompute::visibility::Backend;

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
    /// Mesh a scene once for the shards of a sharded bake (`lrr bake --shard I/N --plan PLAN`).
    Plan(plan::PlanArgs),
    /// Join the parts of a sharded bake (`lrr bake --shard I/N`) into the operator file a
    /// single bake writes.
    Merge(merge::MergeArgs),
    /// Describe an operator file: sizes, bake settings, radiosity per surface.
    Info(info::InfoArgs),
    /// Radiosity at surface points, from an operator file.
    Probe(probe::ProbeArgs),
    /// A frame as files other tools read: an EXR lightmap atlas, or the scene as glTF with the
    /// radiosity per vertex (the format from the extension of -o).
    Export(export::ExportArgs),
    /// Light groups animated by keyframes (intensity, colour): an EXR lightmap and/or a ray
    /// traced image (PNG or EXR) per frame, with the achieved frame rates.
    Relight(relight::RelightArgs),
    /// The relit scene in a window, the way an engine draws it: the GPU evaluator's frame, the
    /// runtime's lightmap filled on the GPU, the display triangles rasterised with it; a slider
    /// per light group, the exposure, the file's cameras, orbit/fly, timings, screenshots
    /// (`--headless --screenshot F` draws offscreen).
    #[cfg(feature = "view")]
    View(view::ViewArgs),
    /// Ray trace a frame of an operator file (B/π, highlights, mirrors, glass) into a PNG or EXR.
    Render(render::RenderArgs),
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
    /// How patches are built: `2mf` (uniform cut at the patch size), `2msc` (adaptive: touching
    /// elements merged while the estimated error stays under --threshold; `k` is an output) or
    /// `2msc-split` (the papers' adaptive rule: the subdivision split while a patch lacks
    /// spatial coherence) [default: the scene description's `[bake] method`, else 2msc].
    #[arg(long, value_name = "METHOD", value_enum)]
    pub method: Option<MethodArg>,
    /// 2MSC: the estimated relative error of the patches (2msc; e.g. 7e-5), or the largest
    /// estimated error share of a patch (2msc-split) (docs/MESHING.md); smaller gives more
    /// patches [default: `[bake] threshold`, else 7e-5 (2msc) or 3e-5 (2msc-split)].
    #[arg(long, value_name = "T")]
    pub threshold: Option<f64>,
    /// 2msc-split: patches of at most this area (scene units²) are not split further
    /// [default: `[bake] min_patch_area`, else chosen by the method].
    #[arg(long, value_name = "A")]
    pub min_patch_area: Option<f64>,
    /// Quadrature points and visibility rays per element-patch pair (a square gives a midpoint
    /// rule) [default: `[bake] samples`, else 16].
    #[arg(long, value_name = "S")]
    pub samples: Option<u32>,
    /// Occlusion backend: `obvhs` (pure Rust, exact f64 triangle test) or `embree` (Embree 4,
    /// builds with the cargo feature `embree` only; see scripts/setup-embree.sh).
    #[arg(long, value_name = "BACKEND", value_enum, default_value_t = VisibilityArg::Obvhs)]
    pub visibility: VisibilityArg,
    /// Worker threads [default: all cores]. Results do not depend on it.
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Refuse jobs whose working memory would exceed this (bytes, or with a K/M/G/T suffix)
    /// [default: 80% of the memory available].
    #[arg(long, value_name = "BYTES", value_parser = parse_bytes)]
    pub max_memory: Option<u64>,
    /// Texels per scene unit of the lightmap charts a bake packs when the scene has no
    /// TEXCOORD_1 on every mesh [default: `[bake] lightmap_texel_density`, else the largest
    /// density that fits a 1024² atlas].
    #[arg(long, value_name = "T")]
    pub lightmap_texel_density: Option<f64>,
    /// Texels dilated around the lightmap's charts [default: `[bake] lightmap_padding`, else 2].
    #[arg(long, value_name = "P")]
    pub lightmap_padding: Option<u32>,
    /// Write no lightmap coordinates (a file for evaluation only, 32 bytes per display face
    /// smaller) [default: `[bake] lightmap`, else write them].
    #[arg(long)]
    pub no_lightmap: bool,
    /// No progress bars.
    #[arg(long, short)]
    pub quiet: bool,
    /// Print every import warning (by default: the first few of each kind and a count).
    #[arg(long)]
    pub verbose: bool,
}

/// `--method`: how patches are built.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MethodArg {
    /// Two fixed meshes: the uniform cut at the patch size.
    #[value(name = "2mf")]
    TwoFixed,
    /// Two meshes with spatial coherence: adaptive patches merged bottom-up, `k` is an output.
    #[value(name = "2msc")]
    SpatialCoherence,
    /// Two meshes with spatial coherence by the papers' rule: the subdivision split top-down.
    #[value(name = "2msc-split")]
    SpatialCoherenceSplit,
}

/// `--visibility`: which occlusion backend a bake builds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum VisibilityArg {
    /// The pure-Rust BVH (obvhs) with the exact f64 triangle test.
    Obvhs,
    /// Embree 4 (cargo feature `embree`).
    Embree,
}

impl From<VisibilityArg> for Backend {
    fn from(v: VisibilityArg) -> Self {
        match v {
            VisibilityArg::Obvhs => Backend::Obvhs,
            VisibilityArg::Embree => Backend::Embree,
        }
    }
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
    /// The settings the flags name, with the built-in defaults for those not given.
    pub fn settings(&self) -> BakeSettings {
        self.settings_over(&BakeDefaults::default())
            .expect("built-in defaults are valid")
    }

    /// The settings for `scene`: flags given explicitly win over its description's `[bake]`
    /// table, which wins over the built-in defaults (sizes: flags, then the scene's hints,
    /// then fractions of its extent, as before).
    pub fn settings_for(&self, scene: &lrr_precompute::scene::Scene) -> Result<BakeSettings> {
        self.settings_over(&scene.bake)
    }

    fn settings_over(&self, d: &BakeDefaults) -> Result<BakeSettings> {
        let method = match (self.method, d.method.as_deref()) {
            (Some(m), _) => m,
            (None, Some("2msc") | None) => MethodArg::SpatialCoherence,
            (None, Some("2msc-split")) => MethodArg::SpatialCoherenceSplit,
            (None, Some("2mf")) => MethodArg::TwoFixed,
            (None, Some(other)) => {
                anyhow::bail!("[bake] method '{other}' is not 2mf, 2msc or 2msc-split")
            }
        };
        let coherence = |rule: CoherenceRule, default: f64| PatchMethod::SpatialCoherence {
            threshold: self.threshold.or(d.threshold).unwrap_or(default),
            min_patch_area: self.min_patch_area.or(d.min_patch_area),
            rule,
        };
        let method = match method {
            MethodArg::SpatialCoherence => coherence(CoherenceRule::Merge, DEFAULT_MERGE_THRESHOLD),
            MethodArg::SpatialCoherenceSplit => {
                coherence(CoherenceRule::Split, DEFAULT_SPLIT_THRESHOLD)
            }
            MethodArg::TwoFixed => PatchMethod::TwoFixed,
        };
        Ok(BakeSettings {
            element_size: self.element_size,
            patch_size: self.patch_size,
            method,
            samples: self.samples.or(d.samples).unwrap_or(DEFAULT_SAMPLES),
            visibility: self.visibility.into(),
            threads: self.threads,
            max_memory: self.max_memory,
            checkpoint: None,
            refine: None,
            storage: Default::default(),
        })
    }

    /// Bars on a terminal, plain lines when stderr is a file or a pipe, nothing with `-q`.
    pub fn progress(&self) -> lrr_precompute::progress::Progress {
        use lrr_precompute::progress::{Mode, Progress};
        use std::io::IsTerminal;
        Progress::with_mode(if self.quiet {
            Mode::Hidden
        } else if std::io::stderr().is_terminal() {
            Mode::Bars
        } else {
            Mode::Lines
        })
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
        Command::Plan(a) => plan::run(&a, out),
        Command::Merge(a) => merge::run(&a, out),
        Command::Info(a) => info::run(&a, out),
        Command::Probe(a) => probe::run(&a, out),
        Command::Export(a) => export::run(&a, out),
        Command::Relight(a) => relight::run(&a, out),
        #[cfg(feature = "view")]
        Command::View(a) => view::run(&a, out),
        Command::Render(a) => render::run(&a, out),
        Command::ViewFactors(a) => view_factors::run(&a, out),
        Command::Solve(a) => solve::run(&a, out),
        Command::Scene(a) => scene::run(&a, out),
        Command::Bench(a) => bench::run(&a, out),
        Command::Accuracy(a) => accuracy::run(&a, out),
    }
}

/// Loads a scene, printing a summary of its import warnings to stderr ([`warning_lines`]).
pub fn load_scene(path: &std::path::Path) -> Result<lrr_precompute::scene::Scene> {
    load_scene_with(path, false)
}

/// Loads a scene, printing its import warnings to stderr: every one with `verbose`, else a
/// summary per kind ([`warning_lines`]).
impl MeshArgs {
    /// The lightmap flags over the scene's `[bake]` defaults, checked.
    pub fn apply_lightmap(&self, scene: &mut lrr_precompute::scene::Scene) -> Result<()> {
        if let Some(t) = self.lightmap_texel_density {
            if !(t.is_finite() && t > 0.0) {
                anyhow::bail!(
                    "--lightmap-texel-density {t}: must be a finite number > 0 (texels per \
                     scene unit)"
                );
            }
            scene.bake.lightmap_texel_density = Some(t);
        }
        if let Some(p) = self.lightmap_padding {
            if p > lrr_formats::MAX_ATLAS_PADDING {
                anyhow::bail!(
                    "--lightmap-padding {p}: at most {} texels",
                    lrr_formats::MAX_ATLAS_PADDING
                );
            }
            scene.bake.lightmap_padding = Some(p);
        }
        if self.no_lightmap {
            scene.bake.lightmap = Some(false);
        }
        Ok(())
    }
}

pub fn load_scene_with(
    path: &std::path::Path,
    verbose: bool,
) -> Result<lrr_precompute::scene::Scene> {
    load_scene_within(path, verbose, None).map(|(scene, _)| scene)
}

/// [`load_scene_with`] planned against `max_memory` (`--max-memory`;
/// [`lrr_precompute::scene::load_within`]); also answers the bytes the import planned.
pub fn load_scene_within(
    path: &std::path::Path,
    verbose: bool,
    max_memory: Option<u64>,
) -> Result<(lrr_precompute::scene::Scene, u128)> {
    let (scene, planned) = lrr_precompute::scene::load_within(path, max_memory)?;
    for line in warning_lines(&scene.warnings, verbose) {
        eprintln!("lrr: warning: {line}");
    }
    Ok((scene, planned))
}

/// Warnings of one kind printed before the rest are counted.
pub const WARNINGS_PER_KIND: usize = 3;

/// The warning lines to print: all of them with `verbose`; else, per kind of warning (the text
/// with its numbers and quoted names left out: "a degenerate face dropped" at any location is
/// one kind), the first [`WARNINGS_PER_KIND`] and a line counting the rest. Kinds in order of
/// their first warning.
pub fn warning_lines(warnings: &[String], verbose: bool) -> Vec<String> {
    if verbose {
        return warnings.to_vec();
    }
    let mut kinds: Vec<(String, Vec<&String>)> = Vec::new();
    for w in warnings {
        let kind = warning_kind(w);
        match kinds.iter_mut().find(|(k, _)| *k == kind) {
            Some((_, list)) => list.push(w),
            None => kinds.push((kind, vec![w])),
        }
    }
    let mut out = Vec::new();
    for (_, list) in kinds {
        out.extend(list.iter().take(WARNINGS_PER_KIND).map(|w| w.to_string()));
        if list.len() > WARNINGS_PER_KIND {
            let first = list[0];
            let short: String = first.chars().take(100).collect();
            let ellipsis = if short.len() < first.len() { "…" } else { "" };
            out.push(format!(
                "{} more like \"{short}{ellipsis}\" ({} in all; --verbose or --report lists \
                 every one)",
                list.len() - WARNINGS_PER_KIND,
                list.len()
            ));
        }
    }
    out
}

/// A warning's kind: its text with runs of digits and quoted names ('…', "…") replaced.
fn warning_kind(w: &str) -> String {
    let mut out = String::with_capacity(w.len());
    let mut quote: Option<char> = None;
    let mut last_digit = false;
    for c in w.chars() {
        if let Some(q) = quote {
            if c == q {
                quote = None;
            }
            continue;
        }
        if c == '\'' || c == '"' {
            quote = Some(c);
            out.push_str("'…'");
            last_digit = false;
        } else if c.is_ascii_digit() {
            if !last_digit {
                out.push('#');
            }
            last_digit = true;
        } else {
            out.push(c);
            last_digit = false;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    /// clap's checks of the command's definition (unique argument ids among them), which it
    /// runs by itself only in debug builds: the tests run in release, where two arguments of
    /// one id (`lrr probe`'s `--points` and `--point-light`) went unnoticed.
    #[test]
    fn the_command_line_passes_clap_checks() {
        use clap::CommandFactory;
        super::Cli::command().debug_assert();
    }
}
