//! `lrr plan SCENE -o PLAN`: the meshes of a sharded bake, made once for every shard
//! (`lrr bake SCENE --shard I/N --plan PLAN`); worth it for 2MSC, whose probe solves would
//! otherwise run in every shard (docs/DISTRIBUTED.md).

use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::Result;
use clap::Args;
use lrr_precompute::refine::DEFAULT_BUDGET;

use crate::{MeshArgs, load_scene_within};
use lrr_precompute::shard::write_plan;

#[derive(Debug, Args)]
pub struct PlanArgs {
    /// Scene: an OBJ file or an lrr scene description (.toml).
    pub scene: PathBuf,
    /// Plan file to write (replaced atomically).
    #[arg(short, long, value_name = "PLAN")]
    pub output: PathBuf,
    /// The shards' mesh flags: a shard refuses a plan made with other flags.
    #[command(flatten)]
    pub mesh: MeshArgs,
    /// The shards' `--refine` (refinement where light changes is part of the plan's mesh)
    /// [default: as `lrr bake`'s].
    #[arg(long, value_name = "B", num_args = 0..=1, default_value_t = DEFAULT_BUDGET,
          default_missing_value = "0.5")]
    pub refine: f64,
}

pub fn run(a: &PlanArgs, out: &mut dyn Write) -> Result<()> {
    let start = Instant::now();
    let progress = a.mesh.progress();
    let (mut scene, _) = load_scene_within(&a.scene, a.mesh.verbose, a.mesh.max_memory)?;
    a.mesh.apply_lightmap(&mut scene)?;
    let mut settings = a.mesh.settings_for(&scene)?;
    settings.refine = Some(a.refine);
    let (n, k) = write_plan(&scene, &settings, &a.output, &progress)?;
    writeln!(
        out,
        "planned {} → {}: n = {n} elements, k = {k} patches ({:.2}s); bake the shards with \
         --plan {}",
        scene.name,
        a.output.display(),
        start.elapsed().as_secs_f64(),
        a.output.display()
    )?;
    Ok(())
}
