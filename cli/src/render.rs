//! `lrr render`: a frame of an operator file ray traced on the CPU (`lrr_runtime::trace`) or
//! the GPU (`lrr_runtime::gpu::GpuTracer`, shading the evaluator's radiosity where it lies),
//! written as PNG (tone-mapped, exposure printed) or EXR (linear RGB) by the extension of `-o`.

use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use lrr_runtime::gpu::{Gpu, GpuError, GpuEvaluator, GpuOptions, GpuTracer};
use lrr_runtime::trace::{Decision, Image, MAX_DEPTH_LIMIT, RayCounts, Tracer, View};
use lrr_runtime::{Operator, Rgb, RgbMut};

use crate::emission::{self, EmissionArgs, Lighting, Reconstruct};
use crate::exr_image::ExrSamples;
use crate::picture::{self, CameraArgs, ImageFormat, parse_size};

#[derive(Debug, Args)]
pub struct RenderArgs {
    /// Operator file (with a BVH: baked by this version of lrr).
    pub file: PathBuf,
    #[command(flatten)]
    pub view: CameraArgs,
    /// Image size in pixels.
    #[arg(long, value_name = "WxH", default_value = "800x600", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Where the frame is relit and traced: `cpu`, or `gpu` (the wgpu evaluator and the WGSL
    /// tracer; the radiosity stays on the GPU between the two).
    #[arg(long, value_enum, default_value_t = TraceDevice::Cpu)]
    pub device: TraceDevice,
    #[command(flatten)]
    pub emission: EmissionArgs,
    /// Print which effects the frame simulates, and why.
    #[arg(long)]
    pub explain: bool,
    /// The radiosity at a hit point: `smooth` (the default when the file has smooth weights:
    /// smooth-vertex values interpolated by mean value coordinates) or `flat` (the element's
    /// value; the default otherwise, saying so). On either device.
    #[arg(long, value_enum, value_name = "HOW")]
    pub reconstruct: Option<Reconstruct>,
    /// Bounces of reflection and refraction below a camera ray.
    #[arg(long, value_name = "N", default_value_t = lrr_runtime::trace::DEFAULT_MAX_DEPTH)]
    pub max_depth: u32,
    /// PNG exposure in stops (pixel values × 2^EV before the sRGB curve) [default: the 99th
    /// percentile of the luminance maps to white].
    #[arg(long, value_name = "EV", allow_hyphen_values = true)]
    pub exposure: Option<f32>,
    /// EXR samples: `half` or `float`.
    #[arg(long, value_enum, default_value_t = ExrSamples::Half)]
    pub exr_samples: ExrSamples,
    /// Threads [default: all cores]. The image does not depend on it.
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Output image: .png (tone-mapped 8-bit sRGB) or .exr (linear RGB radiance).
    #[arg(short = 'o', long, value_name = "IMG")]
    pub output: PathBuf,
}

/// `lrr render --device`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum TraceDevice {
    /// The CPU tracer (std threads).
    Cpu,
    /// The wgpu evaluator and the WGSL tracer on the best usable adapter.
    Gpu,
}

pub fn run(a: &RenderArgs, out: &mut dyn Write) -> Result<()> {
    let format = ImageFormat::of(&a.output, "-o")?;
    if a.max_depth > MAX_DEPTH_LIMIT {
        bail!("--max-depth {}: at most {MAX_DEPTH_LIMIT}", a.max_depth);
    }
    let op = Operator::load(&a.file).map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?;
    let mut tracer =
        Tracer::new(op.file()).map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?;
    tracer.set_max_depth(a.max_depth)?;
    let smooth = emission::reconstruction(&op, a.reconstruct, &a.file)?.is_some();
    tracer.set_smooth(smooth)?;
    let cam = a.view.camera(&tracer, &a.file)?;
    let (w, h) = a.size;
    let view = View::new(&cam, w, h)?;
    let lighting = a.emission.lighting(&op)?;
    let groups = match &lighting {
        Lighting::Groups(g) => g.clone(),
        _ => vec![1.0; op.light_groups().len()],
    };
    let lights = a.emission.lights.lights(&op)?;
    // Lights that are not surfaces: their direct pass on the CPU (either device), the frame's
    // emission plus rho * H; the tracer adds their direct light at each hit.
    let mut lit = emission::Frame::new(&op);
    let lit_emission = if lights.is_empty() {
        None
    } else {
        Some(lit.light(&op, emission::emission_of(&op, &lighting)?, &lights)?)
    };
    if a.explain {
        if lights.is_empty() {
            writeln!(
                out,
                "direct pass: none (no point light of no group, spot, sun or sky): no shadow \
                 rays for it"
            )?;
        } else {
            writeln!(
                out,
                "direct pass: {} and {}, {} samples per element: {} shadow rays",
                plural(lights.lights.len(), "light"),
                if lights.sky.is_some() {
                    "a sky"
                } else {
                    "no sky"
                },
                lights.samples,
                lit.report.rays
            )?;
        }
    }
    let (image, decision, rays, seconds) = match a.device {
        TraceDevice::Cpu => {
            let b = match &lit_emission {
                None => emission::radiosity(&op, &lighting, emission::Device::Cpu)?,
                Some(e) => {
                    emission::radiosity(&op, &Lighting::Emission(e.clone()), emission::Device::Cpu)?
                }
            };
            lit.set_radiosity(b);
            let frame = lit.trace_lighting(&groups);
            let start = Instant::now();
            let (image, report) = tracer.render(&view, &frame, w, h, a.threads.unwrap_or(0))?;
            let seconds = start.elapsed().as_secs_f64();
            (image, report.decision, report.rays, seconds)
        }
        TraceDevice::Gpu => {
            let lit = lit_emission.map(|e| (e, &mut lit));
            render_gpu(&op, &tracer, &view, &lighting, &groups, (w, h), lit)
                .map_err(|e| anyhow::anyhow!("--device gpu: {}", emission::one_line(&e)))?
        }
    };
    if a.explain {
        write!(out, "{}", decision.text())?;
    }
    let r = rays;
    writeln!(
        out,
        "rendered {w}x{h} in {seconds:.3} s: {} primary, {} shadow, {} secondary rays",
        r.primary, r.shadow, r.secondary
    )?;
    let bytes = match format {
        ImageFormat::Png => {
            let (scale, how) = picture::exposure(&image, a.exposure);
            writeln!(
                out,
                "exposure: {:+.2} EV (x{scale:.4}, {how})",
                scale.log2()
            )?;
            picture::encode_png(&image, scale)?
        }
        ImageFormat::Exr => picture::encode_exr(&image, a.exr_samples, "lrr render")?,
    };
    lrr_formats::write_atomic(&a.output, &bytes)
        .with_context(|| format!("writing {}", a.output.display()))?;
    writeln!(out, "wrote {}", a.output.display())?;
    Ok(())
}

/// A frame relit by the wgpu evaluator and traced by the WGSL tracer, the radiosity left on
/// the GPU between the two; the seconds cover both, the image's readback included. With lights
/// that are not surfaces (`lit`: the emission with their `ρ H` and the frame that made it), the
/// radiosity is read back once to take their part out (`Frame::set_radiosity`) and the tracer
/// shades them per hit.
fn render_gpu(
    op: &Operator,
    tracer: &Tracer,
    view: &View,
    lighting: &Lighting,
    groups: &[f32],
    (w, h): (u32, u32),
    lit: Option<(Vec<[f32; 3]>, &mut emission::Frame)>,
) -> std::result::Result<(Image, Decision, RayCounts, f64), GpuError> {
    let gpu = Gpu::new(&GpuOptions::default())?;
    eprintln!("lrr: note: relighting and tracing on {}", gpu.describe());
    let mut eval = GpuEvaluator::new(&gpu, op)?;
    let mut gpu_tracer = GpuTracer::new(&gpu, tracer)?;
    let start = Instant::now();
    let (image, report) = match lit {
        Some((e, frame)) => {
            let mut b = vec![[0.0f32; 3]; op.n()];
            eval.evaluate(Rgb::triples(&e), RgbMut::triples(&mut b))?;
            frame.set_radiosity(b);
            gpu_tracer.render_lighting(view, &frame.trace_lighting(groups), w, h)?
        }
        None => {
            match lighting {
                Lighting::Baked => eval.submit(Rgb::triples(&op.baked_emission()))?,
                Lighting::Groups(g) => eval.submit_groups(g)?,
                Lighting::Emission(e) => eval.submit(Rgb::triples(e))?,
            }
            gpu_tracer.render(view, eval.radiosity_buffer(), groups, w, h)?
        }
    };
    let seconds = start.elapsed().as_secs_f64();
    let rays = report.rays.unwrap_or_default();
    Ok((image, report.decision, rays, seconds))
}

/// `n thing(s)`.
fn plural(n: usize, thing: &str) -> String {
    if n == 1 {
        format!("1 {thing}")
    } else {
        format!("{n} {thing}s")
    }
}
