//! `lrr plan SCENE -o PLAN`: the meshes of a sharded bake, made once for every shard
//! (`lrr bake SCENE --shard I/N --plan PLAN`); worth it for 2MSC, whose probe solves would
//! otherwise run in every shard (docs/DISTRIBUTED.md).

use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::Result;
use clap::Args;

use crate::{MeshArgs, load_scene};
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
}

pub fn run(a: &PlanArgs, out: &mut dyn Write) -> Result<()> {
    let start = Instant::now();
    let progress = a.mesh.progress();
    let scene = load_scene(&a.scene)?;
    let (n, k) = write_plan(&scene, &a.mesh.settings_for(&scene)?, &a.output, &progress)?;
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
