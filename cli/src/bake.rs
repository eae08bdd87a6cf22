//! `lrr bake`.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use lrr_precompute::refine::DEFAULT_BUDGET;
use serde::Serialize;

use crate::{MeshArgs, load_scene_within, summary};
use lrr_precompute::bake::bake;
use lrr_precompute::checkpoint;
use lrr_precompute::checkpoint::CheckpointSettings;
use lrr_precompute::scene::BakeDefaults;
use lrr_precompute::write;

#[derive(Debug, Args)]
pub struct BakeArgs {
    /// Scene: an OBJ file, a glTF 2.0 file (.gltf, .glb) or an lrr scene description (.toml).
    pub scene: PathBuf,
    /// Operator file to write (replaced atomically) [default: the scene description's
    /// `[bake] output`].
    #[arg(short, long, value_name = "OUT.lrr")]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub mesh: MeshArgs,
    /// Also write a JSON report (sizes, condition number, seconds per stage).
    #[arg(long, value_name = "R.json")]
    pub report: Option<PathBuf>,
    /// Continue an interrupted bake from its checkpoint (OUT.lrr.ckpt); the result is the same
    /// file an uninterrupted bake writes.
    #[arg(long)]
    pub resume: bool,
    /// Rows of form factors per checkpoint block [default: about 10⁶ pair samples per block].
    #[arg(long, value_name = "ROWS")]
    pub checkpoint_rows: Option<usize>,
    /// Storage of the n×k matrix: f32, or f16 (half the bytes a frame reads; see
    /// docs/PERFORMANCE.md for the error it costs) [default: `[bake] precision`, else f32].
    #[arg(long, value_enum)]
    pub precision: Option<PrecisionArg>,
    /// Operator layout: factored (shared F_k + k×k cores, a third of the bytes) or plain
    /// (the papers' per-channel Y_k) [default: `[bake] layout`, else factored].
    #[arg(long, value_enum)]
    pub layout: Option<LayoutArg>,
    /// Bake only shard I of N (I from 0; `env/N` takes I from SLURM_ARRAY_TASK_ID or
    /// JOB_COMPLETION_INDEX) into the part file OUT (`{i}` in it becomes I); `lrr merge`
    /// joins the parts. Resumes its own checkpoint by itself. docs/DISTRIBUTED.md.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<String>,
    /// With --shard: take the meshes from this plan (`lrr plan`) instead of meshing again.
    #[arg(long, value_name = "PLAN", requires = "shard")]
    pub plan: Option<PathBuf>,
    /// Refine where light changes: solve once on the mesh (a cheap first pass), split the
    /// elements whose radiosity jumps most against their neighbours (shadow edges, contact
    /// lines), adding at most B·n elements (`--refine` alone: 0.5; `--refine 0`: none);
    /// `--element-size` stays the largest element. docs/MESHING.md.
    #[arg(long, value_name = "B", num_args = 0..=1, default_value_t = DEFAULT_BUDGET,
          default_missing_value = "0.5")]
    pub refine: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PrecisionArg {
    F32,
    F16,
}

impl From<PrecisionArg> for lrr_formats::Precision {
    fn from(p: PrecisionArg) -> Self {
        match p {
            PrecisionArg::F32 => lrr_formats::Precision::F32,
            PrecisionArg::F16 => lrr_formats::Precision::F16,
        }
    }
}

impl From<LayoutArg> for lrr_formats::Layout {
    fn from(l: LayoutArg) -> Self {
        match l {
            LayoutArg::Factored => lrr_formats::Layout::Factored,
            LayoutArg::Plain => lrr_formats::Layout::PlainYk,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum LayoutArg {
    Factored,
    Plain,
}

impl BakeArgs {
    /// Flags given explicitly win over the scene description's `[bake]`, which wins over the
    /// built-in defaults (f32, factored).
    fn storage(&self, d: &BakeDefaults) -> write::Storage {
        let precision = self.precision.unwrap_or(match d.precision.as_deref() {
            Some("f16") => PrecisionArg::F16,
            _ => PrecisionArg::F32,
        });
        let layout = self.layout.unwrap_or(match d.layout.as_deref() {
            Some("plain") => LayoutArg::Plain,
            _ => LayoutArg::Factored,
        });
        write::Storage {
            precision: precision.into(),
            layout: layout.into(),
        }
    }
}

/// The operator file to write: `-o`, else the description's `[bake] output`.
fn output_path(a: &BakeArgs, d: &BakeDefaults) -> Result<PathBuf> {
    a.output.clone().or_else(|| d.output.clone()).ok_or_else(|| {
        anyhow::anyhow!(
            "no output file: give -o OUT.lrr, or output = \"OUT.lrr\" in the scene description's [bake] table"
        )
    })
}

#[derive(Serialize)]
struct Report<'a> {
    scene: &'a str,
    output: String,
    n: usize,
    k: usize,
    channels: usize,
    condition: f64,
    conditions: &'a [f64],
    element_size: f64,
    patch_size: f64,
    samples: u32,
    visibility: &'a str,
    rays: u64,
    culled_pairs: u64,
    enclosure: Option<lrr_precompute::bake::EnclosureSummary>,
    file_bytes: u64,
    stages: BTreeMap<String, f64>,
    /// Per stage, the process's peak resident bytes so far when it ended (Linux): the stage
    /// that set the peak is the first with the final figure.
    stage_peak_bytes: BTreeMap<String, u64>,
    /// Per stage, the process's resident and peak resident bytes when it began (Linux).
    stage_start_resident_bytes: BTreeMap<String, u64>,
    stage_start_peak_bytes: BTreeMap<String, u64>,
    /// Per stage that planned its buffers before allocating them (the matrices), the bytes
    /// planned: its peak stays within what was resident when it began plus this (with room for
    /// the threads' scratch; `tests/tests/e2e/real_scenes.rs`).
    stage_estimate_bytes: BTreeMap<String, u64>,
    /// The process's peak resident bytes over the whole bake (Linux).
    peak_resident_bytes: Option<u64>,
    meshing: summary::MeshingSummary,
    /// Every import warning, in order.
    warnings: &'a [String],
    /// With `--resume`: rows of `F_k` and of `--refine`'s first pass taken from the
    /// checkpoints instead of integrated again.
    resumed_rows: u64,
    resumed_first_pass_rows: u64,
    total_seconds: f64,
}

pub fn run(a: &BakeArgs, out: &mut dyn Write) -> Result<()> {
    if let Some(spec) = &a.shard {
        let output = a.output.as_ref().ok_or_else(|| {
            anyhow::anyhow!("--shard needs -o PART (with {{i}} for the shard index)")
        })?;
        let shard = crate::shard::ShardArgs {
            scene: &a.scene,
            output,
            mesh: &a.mesh,
            spec,
            checkpoint_rows: a.checkpoint_rows,
            report: a.report.as_deref(),
            plan: a.plan.as_deref(),
            refine: Some(a.refine),
        };
        return crate::shard::run(&shard, out);
    }
    let start = Instant::now();
    let progress = a.mesh.progress();
    let stage = progress.stage("import", 0);
    let (mut scene, planned) = load_scene_within(&a.scene, a.mesh.verbose, a.mesh.max_memory)?;
    progress.estimate("import", planned);
    a.mesh.apply_lightmap(&mut scene)?;
    stage.finish();
    let output = output_path(a, &scene.bake)?;
    let mut settings = a.mesh.settings_for(&scene)?;
    settings.refine = Some(a.refine);
    settings.storage = a.storage(&scene.bake);
    let checkpoint_path = checkpoint::path_for(&output);
    let first_pass_path = checkpoint::first_pass_path(&checkpoint_path);
    if !a.resume
        && let Some(p) = [&checkpoint_path, &first_pass_path]
            .iter()
            .find(|p| p.exists())
    {
        eprintln!(
            "lrr: note: starting over; {} holds an interrupted bake (add --resume to continue \
             it)",
            p.display()
        );
    }
    if a.resume && !checkpoint_path.exists() && !first_pass_path.exists() {
        bail!(
            "--resume: neither {} nor {} exists: no interrupted bake of {} to continue (bake \
             without --resume)",
            checkpoint_path.display(),
            first_pass_path.display(),
            output.display()
        );
    }
    // A bake cut off in its first pass (`--refine`) has no form-factor checkpoint yet: its
    // rows start afresh, the first pass resumes (`checkpoint::element_patch_matrix`).
    settings.checkpoint = Some(CheckpointSettings {
        resume: a.resume,
        path: checkpoint_path,
        block_rows: a.checkpoint_rows,
    });
    let mut baked = bake(&scene, &settings, &progress)?;
    let stage = progress.stage("write", 0);
    let file = write::write(&mut baked, &output, settings.storage)
        .with_context(|| format!("writing the operator file {}", output.display()))?;
    let resumed_rows = baked.checkpoint.as_ref().map_or(0, |c| c.resumed_rows());
    let (resumed_first_pass_rows, first_pass_rows) = baked
        .first_pass_checkpoint
        .as_ref()
        .map_or((0, 0), |c| (c.resumed_rows(), c.rows()));
    if let Some(c) = baked.checkpoint.take() {
        c.remove()?;
    }
    match baked.first_pass_checkpoint.take() {
        Some(c) => c.remove()?,
        // No first pass ran (`--refine 0`): an interrupted refined bake's is stale now.
        None if first_pass_path.exists() => std::fs::remove_file(&first_pass_path)
            .with_context(|| format!("removing {}", first_pass_path.display()))?,
        None => {}
    }
    stage.finish();
    let file_bytes = std::fs::metadata(&output).map(|m| m.len()).unwrap_or(0);
    let stages: BTreeMap<String, f64> = progress.timings().into_iter().collect();
    let starts = progress.starts();
    let report = Report {
        scene: &baked.scene_name,
        output: output.display().to_string(),
        n: baked.n(),
        k: baked.k(),
        channels: baked.cores.channels,
        condition: baked.condition(),
        conditions: &baked.cores.condition,
        element_size: baked.sizes.element_size,
        patch_size: baked.sizes.patch_size,
        samples: baked.samples,
        visibility: baked.visibility,
        rays: baked.rays,
        culled_pairs: baked.culled_pairs,
        enclosure: baked.enclosure,
        file_bytes,
        stages,
        stage_peak_bytes: progress.peaks().into_iter().collect(),
        stage_start_resident_bytes: (starts.iter())
            .filter_map(|(s, m)| Some((s.clone(), m.resident?)))
            .collect(),
        stage_start_peak_bytes: (starts.iter())
            .filter_map(|(s, m)| Some((s.clone(), m.peak?)))
            .collect(),
        stage_estimate_bytes: progress.estimates().into_iter().collect(),
        peak_resident_bytes: lrr_precompute::progress::peak_resident(),
        meshing: summary::MeshingSummary::new(&scene.repairs, &baked.mesh.meshing),
        warnings: &scene.warnings,
        resumed_rows,
        resumed_first_pass_rows,
        total_seconds: start.elapsed().as_secs_f64(),
    };
    if let Some(path) = &a.report {
        let text = serde_json::to_string_pretty(&report)?;
        lrr_formats::write_atomic(path, text.as_bytes())
            .with_context(|| format!("writing the report {}", path.display()))?;
    }
    writeln!(
        out,
        "baked {} → {}: n = {} elements, k = {} patches, {} channel(s), condition {:.3e}, {:.1} MB",
        report.scene,
        report.output,
        report.n,
        report.k,
        report.channels,
        report.condition,
        file_bytes as f64 / 1e6
    )?;
    writeln!(
        out,
        "element size {:.4}, patch size {:.4}, {} samples/pair, visibility: {}, {} rays",
        report.element_size, report.patch_size, report.samples, report.visibility, report.rays
    )?;
    if let Some(e) = &report.enclosure {
        writeln!(out, "{}", e.line())?;
    }
    if a.resume {
        writeln!(
            out,
            "resumed: {} of {} form-factor rows and {} of {} first-pass rows taken from the \
             checkpoints",
            report.resumed_rows, report.n, report.resumed_first_pass_rows, first_pass_rows
        )?;
    }
    crate::summary::print_times(out, &progress, report.total_seconds)?;
    report.meshing.print(out)?;
    let op = lrr_runtime::Operator::from_file(file)?;
    summary::print_surfaces(&op, out)?;
    Ok(())
}
