//! `lrr probe`: radiosity at surface points, smooth (interpolated from the file's per-vertex
//! weights, `lrr_runtime::Reconstruction`) or flat (the value of the element the point falls in),
//! plus the direct light of the frame's lights that are not surfaces at the point itself
//! (`emission::Frame::at`: `ρ H(x)`, each light behind its own shadow ray).

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use lrr_runtime::Operator;
use serde::{Deserialize, Serialize};

use crate::emission::{Device, EmissionArgs, Reconstruct, frame, reconstruction};

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
    #[command(flatten)]
    pub emission: EmissionArgs,
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
    let lighting = a.emission.lighting(&op)?;
    let lights = a.emission.lights.lights(&op)?;
    let frame = frame(&op, &lighting, &lights, a.device)?;
    let smooth = reconstruction(&op, a.reconstruct, &a.file)?;
    let mut vertices = Vec::new();
    if let Some(r) = &smooth {
        vertices = vec![[0.0f32; 3]; r.vertex_count()];
        r.vertex_values(&frame.shown, &mut vertices)?;
    }
    let faces = op.file().faces();
    let normals = &faces.geometry.normals;
    let probes: Vec<Probe> = points
        .iter()
        .map(|p| {
            // The display face under the point (section FACES, else its element's polygon).
            let face = op
                .locate_face(p.position, p.normal)
                .expect("an operator has at least one element");
            let element = op.file().order[faces.element(face)];
            // The bounced light over the surface, plus the lights' direct light at the point
            // (its own shadow rays, on the face's front).
            let bounced = match &smooth {
                Some(r) => r.at(&vertices, face, p.position),
                None => frame.shown[element as usize],
            };
            let normal = [
                normals[3 * face],
                normals[3 * face + 1],
                normals[3 * face + 2],
            ];
            let direct = frame.at(element as usize, p.position, normal);
            Probe {
                position: p.position,
                radiosity: std::array::from_fn(|c| bounced[c] + direct[c]),
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
