//! `lrr probe`: radiosity at surface points.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use lrr_runtime::Operator;
use serde::{Deserialize, Serialize};

use crate::emission::{Device, EmissionArgs, radiosity};

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
    let radiosity = radiosity(&op, &lighting, a.device)?;
    let probes: Vec<Probe> = points
        .iter()
        .map(|p| {
            let element = op
                .locate(p.position, p.normal)
                .expect("an operator has at least one element");
            Probe {
                position: p.position,
                radiosity: radiosity[element as usize],
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
