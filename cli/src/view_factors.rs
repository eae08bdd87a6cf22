//! `lrr view-factors`: surface-to-surface form factors.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use serde::Serialize;

use crate::{MeshArgs, load_scene_within};
use lrr_precompute::bake::Prepared;
use lrr_precompute::mesh::MeshSizes;
use lrr_precompute::pool::with_threads;
use lrr_precompute::scene::Scene;

#[derive(Debug, Args)]
pub struct ViewFactorsArgs {
    /// Scene: an OBJ file or an lrr scene description (.toml).
    pub scene: PathBuf,
    #[command(flatten)]
    pub mesh: MeshArgs,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// `matrix[i][j]`: fraction of the energy leaving surface i that reaches surface j.
#[derive(Debug, Clone, Serialize)]
pub struct ViewFactors {
    pub surfaces: Vec<String>,
    pub areas: Vec<f64>,
    pub matrix: Vec<Vec<f64>>,
    /// Occlusion rays cast (0 when nothing can occlude).
    pub rays: u64,
}

/// Surface-to-surface form factors: `F_ij = Σ_{e∈i} A_e Σ_{p⊂j} F_ep / A_i`, from the same
/// element-to-patch form factors a bake computes (patches never straddle surfaces).
pub fn view_factors(scene: &Scene, a: &MeshArgs) -> Result<ViewFactors> {
    let settings = a.settings_for(scene)?;
    let sizes = MeshSizes::resolve(scene, settings.element_size, settings.patch_size)?;
    let progress = a.progress();
    let result = with_threads(settings.threads, || -> Result<ViewFactors> {
        let prepared = Prepared::new(
            scene,
            sizes,
            settings.method,
            settings.visibility,
            &progress,
        )?;
        let ff = prepared.form_factors(settings.samples);
        let (fk, _) = prepared.element_patch_matrix(&ff, &progress, settings.max_memory, None)?;
        let m = scene.surfaces.len();
        let k = prepared.mesh.k();
        let mut flux = vec![vec![0.0; m]; m];
        let mut areas = vec![0.0; m];
        for s in 0..prepared.mesh.n() {
            let e = prepared.mesh.element_at(s);
            let area = e.polygon.area();
            let i = e.surface as usize;
            areas[i] += area;
            for (p, f) in fk[s * k..(s + 1) * k].iter().enumerate() {
                flux[i][prepared.mesh.patches[p].surface as usize] += area * f;
            }
        }
        let matrix = flux
            .iter()
            .zip(&areas)
            .map(|(row, a)| row.iter().map(|x| x / a).collect())
            .collect();
        Ok(ViewFactors {
            surfaces: scene.surfaces.clone(),
            areas,
            matrix,
            rays: ff.rays(),
        })
    })??;
    Ok(result)
}

pub fn run(a: &ViewFactorsArgs, out: &mut dyn Write) -> Result<()> {
    let (scene, _) = load_scene_within(&a.scene, a.mesh.verbose, a.mesh.max_memory)?;
    let vf = view_factors(&scene, &a.mesh)?;
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&vf)?)?;
        return Ok(());
    }
    write!(out, "{:<20}", "from \\ to")?;
    for s in &vf.surfaces {
        write!(out, " {:>12.12}", s)?;
    }
    writeln!(out, " {:>10}", "sum")?;
    for (name, row) in vf.surfaces.iter().zip(&vf.matrix) {
        write!(out, "{:<20.20}", name)?;
        for f in row {
            write!(out, " {f:>12.6}")?;
        }
        writeln!(out, " {:>10.6}", row.iter().sum::<f64>())?;
    }
    Ok(())
}
