//! `lrr solve`: radiosity without writing a file, low-rank or `--exact`.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use serde::Serialize;

use crate::{MeshArgs, load_scene_within};
use lrr_precompute::bake::{Prepared, bake};
use lrr_precompute::exact::solve_exact;
use lrr_precompute::mesh::MeshSizes;
use lrr_precompute::patches::PatchMethod;
use lrr_precompute::pool::with_threads;
use lrr_precompute::radiosity::ElementData;
use lrr_precompute::scene::Scene;

#[derive(Debug, Args)]
pub struct SolveArgs {
    /// Scene: an OBJ file or an lrr scene description (.toml).
    pub scene: PathBuf,
    /// Solve the full fine-mesh system (n×n form factors, dense LU) instead of the low-rank one.
    #[arg(long)]
    pub exact: bool,
    #[command(flatten)]
    pub mesh: MeshArgs,
    /// Print JSON (per element and per surface) instead of the per-surface table.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Clone, Serialize)]
pub struct ElementRadiosity {
    pub id: u32,
    pub surface: String,
    pub centroid: [f64; 3],
    pub area: f64,
    pub radiosity: [f64; 3],
}

#[derive(Debug, Clone, Serialize)]
pub struct SurfaceRadiosity {
    pub name: String,
    pub area: f64,
    pub mean_radiosity: [f64; 3],
}

#[derive(Debug, Clone, Serialize)]
pub struct Solution {
    pub method: &'static str,
    pub n: usize,
    pub k: usize,
    pub surfaces: Vec<SurfaceRadiosity>,
    pub elements: Vec<ElementRadiosity>,
}

/// Solves the scene on its fine mesh, exactly or by the low-rank operator.
pub fn solve(scene: &Scene, a: &MeshArgs, exact: bool) -> Result<Solution> {
    let settings = a.settings_for(scene)?;
    let progress = a.progress();
    let sizes = MeshSizes::resolve(scene, settings.element_size, settings.patch_size)?;
    let (mesh, radiosity, method) = if exact {
        with_threads(settings.threads, || -> Result<_> {
            // The exact solve needs only the fine mesh, which does not depend on the patch method.
            let prepared = Prepared::new(
                scene,
                sizes,
                PatchMethod::TwoFixed,
                settings.visibility,
                &progress,
            )?;
            let ff = prepared.form_factors(settings.samples);
            let (rho, emission) = prepared.element_materials();
            let stage = progress.stage("exact matrix", prepared.mesh.n() as u64);
            let data = ElementData {
                reflectance: &rho,
                emission: &emission,
            };
            let sol = solve_exact(&prepared.mesh, &data, &ff, settings.max_memory, &|i| {
                stage.inc(i)
            })?;
            stage.finish();
            Ok((prepared.mesh, sol.radiosity, "exact"))
        })??
    } else {
        let baked = bake(scene, &settings, &progress)?;
        let op = lrr_runtime::Operator::from_file(lrr_precompute::write::operator_file(&baked)?)?;
        let b = op.evaluate_baked();
        let b = b.iter().map(|x| x.map(f64::from)).collect();
        (baked.mesh, b, "low-rank")
    };
    let mut surfaces: Vec<SurfaceRadiosity> = scene
        .surfaces
        .iter()
        .map(|s| SurfaceRadiosity {
            name: s.clone(),
            area: 0.0,
            mean_radiosity: [0.0; 3],
        })
        .collect();
    let mut elements = Vec::with_capacity(mesh.n());
    for (id, (e, b)) in mesh.elements.iter().zip(&radiosity).enumerate() {
        let area = e.polygon.area();
        let s = &mut surfaces[e.surface as usize];
        s.area += area;
        for c in 0..3 {
            s.mean_radiosity[c] += area * b[c];
        }
        elements.push(ElementRadiosity {
            id: id as u32,
            surface: scene.surfaces[e.surface as usize].clone(),
            centroid: e.polygon.centroid().to_array(),
            area,
            radiosity: *b,
        });
    }
    for s in &mut surfaces {
        if s.area > 0.0 {
            s.mean_radiosity = s.mean_radiosity.map(|x| x / s.area);
        }
    }
    Ok(Solution {
        method,
        n: mesh.n(),
        k: mesh.k(),
        surfaces,
        elements,
    })
}

pub fn run(a: &SolveArgs, out: &mut dyn Write) -> Result<()> {
    let (scene, _) = load_scene_within(&a.scene, a.mesh.verbose, a.mesh.max_memory)?;
    lights_left_out(&scene, "lrr solve");
    let sol = solve(&scene, &a.mesh, a.exact)?;
    if a.json {
        writeln!(out, "{}", serde_json::to_string(&sol)?)?;
        return Ok(());
    }
    writeln!(
        out,
        "{} solution: n = {} elements (k = {} patches)",
        sol.method, sol.n, sol.k
    )?;
    writeln!(
        out,
        "{:<24} {:>12}   mean radiosity (R, G, B)",
        "surface", "area"
    )?;
    for s in &sol.surfaces {
        let [r, g, b] = s.mean_radiosity;
        writeln!(
            out,
            "{:<24} {:>12.4e}   {r:>10.4} {g:>10.4} {b:>10.4}",
            s.name, s.area
        )?;
    }
    Ok(())
}

/// A note on stderr when `scene` has lights that are not surfaces: `what` solves the baked
/// emission alone (their light comes from the runtime's direct pass: `lrr probe`, `render`,
/// `export`, `relight`).
pub(crate) fn lights_left_out(scene: &lrr_precompute::scene::Scene, what: &str) {
    let count = scene
        .point_lights
        .iter()
        .filter(|l| l.group.is_none())
        .count()
        + scene.direct_lights.len();
    if count > 0 {
        eprintln!(
            "lrr: note: {what} solves the emitting surfaces alone: the scene's {count} light(s) \
             that are not surfaces (point lights of no group, spots, suns, a sky) light frames \
             of lrr probe, render, export and relight, not this"
        );
    }
}
