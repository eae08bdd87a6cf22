//! `lrr probe`: radiosity at surface points, smooth (interpolated from the file's per-vertex
//! weights, `lrr_runtime::Reconstruction`) or flat (the value of the element the point falls in).

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use lrr_runtime::gpu::{Gpu, GpuError, GpuEvaluator, GpuOptions};
use lrr_runtime::{Operator, Reconstruction, Rgb, RgbMut};
use serde::{Deserialize, Serialize};

#[derive(Debug, Args)]
pub struct ProbeArgs {
    /// Operator file.
    pub file: PathBuf,
    /// JSON array of {"position":[x,y,z], "normal":[x,y,z]}.
    #[arg(long, value_name = "P.json")]
    pub points: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Where the radiosity is evaluated: `cpu`, `gpu` (an error naming the adapters found when
    /// none is usable) or `auto` (the GPU when there is one, else the CPU, saying so).
    #[arg(long, value_enum, default_value_t = Device::Cpu)]
    pub device: Device,
    /// How a point's value comes from the element values: `smooth` (per-vertex values
    /// interpolated inside the element; the default when the file has smooth weights) or
    /// `flat` (the value of the element the point falls in; the default otherwise, saying so).
    #[arg(long, value_enum)]
    pub reconstruct: Option<Reconstruct>,
}

/// `--reconstruct`: the value at a point from the element values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Reconstruct {
    /// The constant value of the element the point falls in.
    Flat,
    /// Smooth-vertex values interpolated by mean value coordinates (section SMOOTH).
    Smooth,
}

/// `--device`: which evaluator computes the frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Device {
    /// The CPU evaluator (std threads, AVX2 where the CPU has it).
    Cpu,
    /// The wgpu evaluator on the best usable adapter.
    Gpu,
    /// The GPU when one is usable, else the CPU (with a note on stderr).
    Auto,
}

/// An error's message on one line (the command line's errors are one line each).
pub(crate) fn one_line(e: &GpuError) -> String {
    e.to_string()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

/// The radiosity of the baked emission per element (original ids), on `device`.
fn radiosity(op: &Operator, device: Device) -> Result<Vec<[f32; 3]>> {
    match device {
        Device::Cpu => Ok(op.evaluate_baked()),
        Device::Gpu => {
            gpu_radiosity(op).map_err(|e| anyhow::anyhow!("--device gpu: {}", one_line(&e)))
        }
        Device::Auto => gpu_radiosity(op).or_else(|e| {
            eprintln!(
                "lrr: note: --device auto: evaluating on the CPU ({})",
                one_line(&e)
            );
            Ok(op.evaluate_baked())
        }),
    }
}

fn gpu_radiosity(op: &Operator) -> Result<Vec<[f32; 3]>, GpuError> {
    let gpu = Gpu::new(&GpuOptions::default())?;
    eprintln!("lrr: note: evaluating on {}", gpu.describe());
    let mut eval = GpuEvaluator::new(&gpu, op)?;
    let mut b = vec![[0.0f32; 3]; op.n()];
    eval.evaluate(Rgb::triples(&op.baked_emission()), RgbMut::triples(&mut b))?;
    Ok(b)
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Point {
    position: [f32; 3],
    normal: [f32; 3],
}

#[derive(Debug, Serialize)]
struct Probe {
    position: [f32; 3],
    radiosity: [f32; 3],
    element: u32,
}

/// The smooth reconstruction `--reconstruct` asks for (`None`: flat).
fn reconstruction<'f>(op: &'f Operator, a: &ProbeArgs) -> Result<Option<Reconstruction<'f>>> {
    let has_smooth = op.file().display.smooth.is_some();
    match a.reconstruct {
        Some(Reconstruct::Flat) => Ok(None),
        Some(Reconstruct::Smooth) if !has_smooth => bail!(
            "{}: --reconstruct smooth needs the smooth weights (section SMOOTH) that bakes of \
             format 1.2 carry; re-bake the file with this lrr, or use --reconstruct flat",
            a.file.display()
        ),
        None if !has_smooth => {
            eprintln!(
                "lrr: note: {} has no smooth weights (section SMOOTH; re-bake to get them): \
                 probing the flat reconstruction",
                a.file.display()
            );
            Ok(None)
        }
        _ => Ok(Some(Reconstruction::new(op.file())?)),
    }
}

pub fn run(a: &ProbeArgs, out: &mut dyn Write) -> Result<()> {
    let op = Operator::load(&a.file).map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?;
    let text = std::fs::read_to_string(&a.points)
        .with_context(|| format!("reading {}", a.points.display()))?;
    let points: Vec<Point> = serde_json::from_str(&text).with_context(|| {
        format!(
            "{}: expected a JSON array of {{\"position\":[x,y,z], \"normal\":[x,y,z]}}",
            a.points.display()
        )
    })?;
    for (i, p) in points.iter().enumerate() {
        if p.position.iter().chain(&p.normal).any(|c| !c.is_finite()) {
            bail!(
                "{}: point {i} has a non-finite coordinate",
                a.points.display()
            );
        }
    }
    let radiosity = radiosity(&op, a.device)?;
    let smooth = reconstruction(&op, a)?;
    let mut vertices = Vec::new();
    if let Some(r) = &smooth {
        vertices = vec![[0.0f32; 3]; r.vertex_count()];
        r.vertex_values(&radiosity, &mut vertices)?;
    }
    let probes: Vec<Probe> = points
        .iter()
        .map(|p| {
            let position = op
                .locate_position(p.position, p.normal)
                .expect("an operator has at least one element");
            let element = op.file().order[position];
            Probe {
                position: p.position,
                radiosity: match &smooth {
                    Some(r) => r.at(&vertices, position, p.position),
                    None => radiosity[element as usize],
                },
                element,
            }
        })
        .collect();
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&probes)?)?;
    } else {
        for p in &probes {
            let [x, y, z] = p.position;
            let [r, g, b] = p.radiosity;
            writeln!(
                out,
                "({x}, {y}, {z}) element {}: {r:.5} {g:.5} {b:.5}",
                p.element
            )?;
        }
    }
    Ok(())
}
