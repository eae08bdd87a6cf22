//! The frame a command evaluates: the baked emission, light-group intensities (`--group`) or a
//! per-element emission (`--emission`), on the CPU or a GPU. Shared by `lrr probe` and
//! `lrr export` (and any command that shows one frame), so the flags mean the same everywhere.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use lrr_runtime::gpu::{Gpu, GpuError, GpuEvaluator, GpuOptions};
use lrr_runtime::{Operator, Reconstruction, Rgb, RgbMut};

/// The emission flags.
#[derive(Debug, Clone, Default, Args)]
pub struct EmissionArgs {
    /// Light-group intensity `NAME=A` (repeatable; `lrr info` lists the groups): the group's
    /// baked emission times A >= 0. Groups not named keep intensity 1 (as baked).
    #[arg(long = "group", value_name = "NAME=A")]
    pub groups: Vec<String>,
    /// Per-element emission instead of the baked one: a JSON array of n [r, g, b] exitances
    /// (finite, >= 0), in original element ids.
    #[arg(long, value_name = "E.json", conflicts_with = "groups")]
    pub emission: Option<PathBuf>,
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

/// `--reconstruct`: the value at a point from the element values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Reconstruct {
    /// The constant value of the element the point falls in.
    Flat,
    /// Smooth-vertex values interpolated by mean value coordinates (section SMOOTH).
    Smooth,
}

/// The smooth reconstruction `choice` asks for (`None`: flat): by default smooth when the file
/// (`path`) has the weights, else flat with a note on stderr.
pub fn reconstruction<'f>(
    op: &'f Operator,
    choice: Option<Reconstruct>,
    path: &std::path::Path,
) -> Result<Option<Reconstruction<'f>>> {
    let has_smooth = op.file().display.smooth.is_some();
    match choice {
        Some(Reconstruct::Flat) => Ok(None),
        Some(Reconstruct::Smooth) if !has_smooth => bail!(
            "{}: --reconstruct smooth needs the smooth weights (section SMOOTH) that bakes of \
             format 1.2 carry; re-bake the file with this lrr, or use --reconstruct flat",
            path.display()
        ),
        None if !has_smooth => {
            eprintln!(
                "lrr: note: {} has no smooth weights (section SMOOTH; re-bake to get them): \
                 using the flat reconstruction",
                path.display()
            );
            Ok(None)
        }
        _ => Ok(Some(Reconstruction::new(op.file())?)),
    }
}

/// What a frame is lit by.
#[derive(Debug, Clone, PartialEq)]
pub enum Lighting {
    /// The emission the scene was baked with.
    Baked,
    /// One intensity per light group, in [`Operator::light_groups`] order.
    Groups(Vec<f32>),
    /// An RGB emission per element, original ids.
    Emission(Vec<[f32; 3]>),
}

impl EmissionArgs {
    /// The lighting the flags ask for, checked against `op` (unknown group names, bad values
    /// and emission files are errors that say which).
    pub fn lighting(&self, op: &Operator) -> Result<Lighting> {
        if let Some(path) = &self.emission {
            return read_emission(path, op.n()).map(Lighting::Emission);
        }
        if self.groups.is_empty() {
            return Ok(Lighting::Baked);
        }
        let mut a = vec![1.0f32; op.light_groups().len()];
        for spec in &self.groups {
            let (name, value) = spec
                .rsplit_once('=')
                .with_context(|| format!("--group {spec}: expected NAME=A, e.g. light=2.5"))?;
            let g = op.light_group(name).with_context(|| {
                let names: Vec<&str> = op.light_groups().collect();
                format!(
                    "--group {spec}: the file has no light group '{name}' (it has: {})",
                    if names.is_empty() {
                        "none".to_string()
                    } else {
                        names.join(", ")
                    }
                )
            })?;
            a[g] = value
                .trim()
                .parse::<f32>()
                .ok()
                .filter(|v| v.is_finite() && *v >= 0.0)
                .with_context(|| {
                    format!("--group {spec}: the intensity must be a finite number >= 0")
                })?;
        }
        Ok(Lighting::Groups(a))
    }
}

/// Reads `--emission`: n RGB triples, finite and non-negative.
fn read_emission(path: &std::path::Path, n: usize) -> Result<Vec<[f32; 3]>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let e: Vec<[f32; 3]> = serde_json::from_str(&text).with_context(|| {
        format!(
            "{}: expected a JSON array of [r, g, b] per element",
            path.display()
        )
    })?;
    if e.len() != n {
        bail!(
            "{}: {} emission values for an operator of {n} elements (one [r, g, b] per element, original ids)",
            path.display(),
            e.len()
        );
    }
    if let Some(i) = e
        .iter()
        .position(|v| v.iter().any(|c| !(c.is_finite() && *c >= 0.0)))
    {
        bail!(
            "{}: element {i}: emission must be finite and >= 0, got {:?}",
            path.display(),
            e[i]
        );
    }
    Ok(e)
}

/// An error's message on one line (the command line's errors are one line each).
pub(crate) fn one_line(e: &GpuError) -> String {
    e.to_string()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

/// The radiosity per element (original ids) of `lighting`, on the CPU.
pub fn radiosity_cpu(op: &Operator, lighting: &Lighting) -> Result<Vec<[f32; 3]>> {
    let mut b = vec![[0.0f32; 3]; op.n()];
    match lighting {
        Lighting::Baked => return Ok(op.evaluate_baked()),
        Lighting::Groups(a) => op.evaluate_groups(a, RgbMut::triples(&mut b))?,
        Lighting::Emission(e) => op.evaluate(e, &mut b)?,
    }
    Ok(b)
}

/// The radiosity per element (original ids) of `lighting`, on `device`.
pub fn radiosity(op: &Operator, lighting: &Lighting, device: Device) -> Result<Vec<[f32; 3]>> {
    match device {
        Device::Cpu => radiosity_cpu(op, lighting),
        Device::Gpu => gpu_radiosity(op, lighting)
            .map_err(|e| anyhow::anyhow!("--device gpu: {}", one_line(&e))),
        Device::Auto => match gpu_radiosity(op, lighting) {
            Ok(b) => Ok(b),
            Err(e) => {
                eprintln!(
                    "lrr: note: --device auto: evaluating on the CPU ({})",
                    one_line(&e)
                );
                radiosity_cpu(op, lighting)
            }
        },
    }
}

fn gpu_radiosity(op: &Operator, lighting: &Lighting) -> Result<Vec<[f32; 3]>, GpuError> {
    let gpu = Gpu::new(&GpuOptions::default())?;
    eprintln!("lrr: note: evaluating on {}", gpu.describe());
    let mut eval = GpuEvaluator::new(&gpu, op)?;
    let mut b = vec![[0.0f32; 3]; op.n()];
    match lighting {
        Lighting::Baked => {
            eval.evaluate(Rgb::triples(&op.baked_emission()), RgbMut::triples(&mut b))?
        }
        Lighting::Groups(a) => eval.evaluate_groups(a, RgbMut::triples(&mut b))?,
        Lighting::Emission(e) => eval.evaluate(Rgb::triples(e), RgbMut::triples(&mut b))?,
    }
    Ok(b)
}
