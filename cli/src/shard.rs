//! `lrr bake SCENE --shard I/N -o PART`: one shard of a sharded bake (docs/DISTRIBUTED.md).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use serde::Serialize;

use crate::{MeshArgs, load_scene_within};
use lrr_precompute::checkpoint::CheckpointSettings;
use lrr_precompute::shard::{ShardSpec, bake_shard};

/// What `lrr bake --shard` needs of the bake's arguments.
pub struct ShardArgs<'a> {
    pub scene: &'a Path,
    /// The part to write; `{i}` in it is replaced by the shard index.
    pub output: &'a Path,
    pub mesh: &'a MeshArgs,
    /// `I/N` or `env/N`.
    pub spec: &'a str,
    pub checkpoint_rows: Option<usize>,
    pub report: Option<&'a Path>,
    /// Meshes from `lrr plan`.
    pub plan: Option<&'a Path>,
    /// `--refine`'s budget.
    pub refine: Option<f64>,
}

#[derive(Serialize)]
struct Report<'a> {
    scene: &'a str,
    output: String,
    shard: usize,
    shards: usize,
    n: usize,
    k: usize,
    rows: [usize; 2],
    estimated_cost: u64,
    estimated_total_cost: u64,
    resumed_rows: u64,
    rays: u64,
    stages: std::collections::BTreeMap<String, f64>,
    total_seconds: f64,
}

/// The part path with `{i}` replaced by the shard index.
fn part_path(output: &Path, index: usize) -> PathBuf {
    PathBuf::from(output.to_string_lossy().replace("{i}", &index.to_string()))
}

pub fn run(a: &ShardArgs, out: &mut dyn Write) -> Result<()> {
    let start = Instant::now();
    let spec = ShardSpec::parse(a.spec, &|v| std::env::var(v).ok())?;
    let output = part_path(a.output, spec.index);
    let progress = a.mesh.progress();
    let stage = progress.stage("import", 0);
    let (mut scene, planned) = load_scene_within(a.scene, a.mesh.verbose, a.mesh.max_memory)?;
    progress.estimate("import", planned);
    a.mesh.apply_lightmap(&mut scene)?;
    stage.finish();
    let mut settings = a.mesh.settings_for(&scene)?;
    settings.refine = a.refine;
    settings.checkpoint = Some(CheckpointSettings {
        path: lrr_precompute::checkpoint::path_for(&output),
        resume: true,
        block_rows: a.checkpoint_rows,
    });
    let baked = bake_shard(&scene, &settings, spec, &output, a.plan, &progress)
        .with_context(|| format!("baking shard {}/{}", spec.index, spec.count))?;
    let mean = baked.total_cost as f64 / spec.count as f64;
    let report = Report {
        scene: &scene.name,
        output: output.display().to_string(),
        shard: spec.index,
        shards: spec.count,
        n: baked.n,
        k: baked.k,
        rows: [baked.rows.start, baked.rows.end],
        estimated_cost: baked.cost,
        estimated_total_cost: baked.total_cost,
        resumed_rows: baked.resumed_rows,
        rays: baked.rays,
        stages: progress.timings().into_iter().collect(),
        total_seconds: start.elapsed().as_secs_f64(),
    };
    if let Some(path) = a.report {
        let text = serde_json::to_string_pretty(&report)?;
        lrr_formats::write_atomic(path, text.as_bytes())
            .with_context(|| format!("writing the report {}", path.display()))?;
    }
    writeln!(
        out,
        "baked shard {}/{} of {} → {}: rows {}..{} of n = {} (k = {}), estimated cost {:.3} of the mean{}",
        spec.index,
        spec.count,
        scene.name,
        report.output,
        baked.rows.start,
        baked.rows.end,
        baked.n,
        baked.k,
        baked.cost as f64 / mean.max(1.0),
        if baked.resumed_rows > 0 {
            format!(", {} rows resumed from the checkpoint", baked.resumed_rows)
        } else {
            String::new()
        }
    )?;
    crate::summary::print_times(out, &progress, report.total_seconds)?;
    Ok(())
}
