//! `lrr render`: a frame of an operator file ray traced on the CPU (`lrr_runtime::trace`) or
//! the GPU (`lrr_runtime::gpu::GpuTracer`, shading the evaluator's radiosity where it lies),
//! written as PNG (tone-mapped, exposure printed) or EXR (linear RGB) by the extension of `-o`.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use lrr_formats::Camera;
use lrr_runtime::gpu::{Gpu, GpuError, GpuEvaluator, GpuOptions, GpuTracer};
use lrr_runtime::trace::{
    Decision, Image, Lighting as TraceLighting, MAX_DEPTH_LIMIT, RayCounts, Tracer, View,
};
use lrr_runtime::{Operator, Rgb};

use crate::emission::{self, EmissionArgs, Lighting, Reconstruct};
use crate::exr_image::{ExrSamples, RgbLayer, write_rgb};

#[derive(Debug, Args)]
pub struct RenderArgs {
    /// Operator file (with a BVH: baked by this version of lrr).
    pub file: PathBuf,
    /// Eye position X,Y,Z [default: the file's camera].
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<[f32; 3]>,
    /// Point looked at X,Y,Z [default: the file's camera].
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub target: Option<[f32; 3]>,
    /// Up direction X,Y,Z [default: the file's camera, else 0,1,0].
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub up: Option<[f32; 3]>,
    /// Vertical field of view in degrees [default: the file's camera, else 60].
    #[arg(long, value_name = "DEG")]
    pub fov_y: Option<f32>,
    /// The file's camera of this name [default: its first camera]; the flags above override
    /// its fields.
    #[arg(long, value_name = "NAME")]
    pub camera: Option<String>,
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

/// Parses `X,Y,Z`.
pub(crate) fn parse_vec3(text: &str) -> std::result::Result<[f32; 3], String> {
    let parts: Vec<f32> = text
        .split(',')
        .map(|p| p.trim().parse::<f32>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| format!("'{text}' is not three numbers X,Y,Z"))?;
    match parts[..] {
        [x, y, z] if parts.iter().all(|c| c.is_finite()) => Ok([x, y, z]),
        _ => Err(format!("'{text}' is not three finite numbers X,Y,Z")),
    }
}

/// Parses `WxH`.
fn parse_size(text: &str) -> std::result::Result<(u32, u32), String> {
    let err = || format!("'{text}' is not a size WxH like 1920x1080");
    let (w, h) = text.split_once(['x', 'X']).ok_or_else(err)?;
    let (w, h): (u32, u32) = (
        w.trim().parse().map_err(|_| err())?,
        h.trim().parse().map_err(|_| err())?,
    );
    if w == 0 || h == 0 || w as u64 * h as u64 > 1 << 28 {
        return Err(format!("'{text}': need 1 to 2^28 pixels"));
    }
    Ok((w, h))
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Format {
    Png,
    Exr,
}

fn format_of(path: &Path) -> Result<Format> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("png") => Ok(Format::Png),
        Some("exr") => Ok(Format::Exr),
        _ => bail!(
            "-o {}: the image format comes from the extension: .png (tone-mapped) or .exr \
             (linear)",
            path.display()
        ),
    }
}

/// The camera the flags and the file's cameras make.
fn camera(a: &RenderArgs, tracer: &Tracer) -> Result<Camera> {
    let cameras = tracer.cameras();
    let base = match &a.camera {
        Some(name) => Some(cameras.iter().find(|c| &c.name == name).with_context(|| {
            let names: Vec<String> = cameras.iter().map(|c| format!("'{}'", c.name)).collect();
            format!(
                "--camera {name}: the file has no such camera (it has: {})",
                if names.is_empty() {
                    "none".into()
                } else {
                    names.join(", ")
                }
            )
        })?),
        None => cameras.first(),
    };
    let eye = a.eye.or(base.map(|c| c.eye));
    let target = a.target.or(base.map(|c| c.target));
    let (Some(eye), Some(target)) = (eye, target) else {
        bail!(
            "{}: the file has no camera; give one with --eye X,Y,Z --target X,Y,Z \
             (and --up, --fov-y)",
            a.file.display()
        );
    };
    Ok(Camera {
        name: base.map_or(String::new(), |c| c.name.clone()),
        eye,
        target,
        up: a.up.or(base.map(|c| c.up)).unwrap_or([0.0, 1.0, 0.0]),
        fov_y_deg: a.fov_y.or(base.map(|c| c.fov_y_deg)).unwrap_or(60.0),
    })
}

pub fn run(a: &RenderArgs, out: &mut dyn Write) -> Result<()> {
    let format = format_of(&a.output)?;
    if a.max_depth > MAX_DEPTH_LIMIT {
        bail!("--max-depth {}: at most {MAX_DEPTH_LIMIT}", a.max_depth);
    }
    let op = Operator::load(&a.file).map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?;
    let mut tracer =
        Tracer::new(op.file()).map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?;
    tracer.set_max_depth(a.max_depth)?;
    let smooth = emission::reconstruction(&op, a.reconstruct, &a.file)?.is_some();
    tracer.set_smooth(smooth)?;
    let cam = camera(a, &tracer)?;
    let (w, h) = a.size;
    let view = View::new(&cam, w, h)?;
    let lighting = a.emission.lighting(&op)?;
    let groups = match &lighting {
        Lighting::Groups(g) => g.clone(),
        _ => vec![1.0; op.light_groups().len()],
    };
    let (image, decision, rays, seconds) = match a.device {
        TraceDevice::Cpu => {
            let radiosity = emission::radiosity(&op, &lighting, emission::Device::Cpu)?;
            let frame = TraceLighting {
                radiosity: &radiosity,
                group_intensities: &groups,
            };
            let start = Instant::now();
            let (image, report) = tracer.render(&view, &frame, w, h, a.threads.unwrap_or(0))?;
            let seconds = start.elapsed().as_secs_f64();
            (image, report.decision, report.rays, seconds)
        }
        TraceDevice::Gpu => render_gpu(&op, &tracer, &view, &lighting, &groups, (w, h))
            .map_err(|e| anyhow::anyhow!("--device gpu: {}", emission::one_line(&e)))?,
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
    match format {
        Format::Png => {
            let (scale, how) = exposure(&image, a.exposure);
            writeln!(
                out,
                "exposure: {:+.2} EV (x{scale:.4}, {how})",
                scale.log2()
            )?;
            let bytes = encode_png(&image, scale)?;
            lrr_formats::write_atomic(&a.output, &bytes)
                .with_context(|| format!("writing {}", a.output.display()))?;
        }
        Format::Exr => {
            let layer = RgbLayer {
                name: None,
                pixels: &image.pixels,
            };
            let note = "linear RGB radiance (W sr^-1 m^-2 in the scene's units), lrr render";
            write_rgb(
                &a.output,
                w as usize,
                h as usize,
                &[layer],
                a.exr_samples,
                note,
            )?;
        }
    }
    writeln!(out, "wrote {}", a.output.display())?;
    Ok(())
}

/// A frame relit by the wgpu evaluator and traced by the WGSL tracer, the radiosity left on
/// the GPU between the two; the seconds cover both, the image's readback included.
fn render_gpu(
    op: &Operator,
    tracer: &Tracer,
    view: &View,
    lighting: &Lighting,
    groups: &[f32],
    (w, h): (u32, u32),
) -> std::result::Result<(Image, Decision, RayCounts, f64), GpuError> {
    let gpu = Gpu::new(&GpuOptions::default())?;
    eprintln!("lrr: note: relighting and tracing on {}", gpu.describe());
    let mut eval = GpuEvaluator::new(&gpu, op)?;
    let mut gpu_tracer = GpuTracer::new(&gpu, tracer)?;
    let start = Instant::now();
    match lighting {
        Lighting::Baked => eval.submit(Rgb::triples(&op.baked_emission()))?,
        Lighting::Groups(g) => eval.submit_groups(g)?,
        Lighting::Emission(e) => eval.submit(Rgb::triples(e))?,
    }
    let (image, report) = gpu_tracer.render(view, eval.radiosity_buffer(), groups, w, h)?;
    let seconds = start.elapsed().as_secs_f64();
    let rays = report.rays.unwrap_or_default();
    Ok((image, report.decision, rays, seconds))
}

/// The scale applied before the sRGB curve: `2^ev`, or the one mapping the 99th percentile of
/// the luminance of lit pixels to 1.
fn exposure(image: &Image, ev: Option<f32>) -> (f32, &'static str) {
    if let Some(ev) = ev {
        return (2f32.powf(ev), "--exposure");
    }
    let mut lum: Vec<f32> = image
        .pixels
        .iter()
        .map(|p| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2])
        .filter(|l| *l > 0.0)
        .collect();
    if lum.is_empty() {
        return (1.0, "auto: the image is black");
    }
    let at = (lum.len() - 1) * 99 / 100;
    let (_, p99, _) = lum.select_nth_unstable_by(at, f32::total_cmp);
    (
        1.0 / *p99,
        "auto: the 99th percentile of the luminance maps to white",
    )
}

/// The sRGB transfer function of a linear value in [0, 1].
fn srgb(v: f32) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let s = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// The image as an 8-bit sRGB PNG, values scaled by `scale` and clipped.
fn encode_png(image: &Image, scale: f32) -> Result<Vec<u8>> {
    let mut bytes = Vec::new();
    let mut enc = png::Encoder::new(&mut bytes, image.width, image.height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let data: Vec<u8> = image
        .pixels
        .iter()
        .flat_map(|p| p.map(|c| srgb(c * scale)))
        .collect();
    let mut writer = enc.write_header().context("encoding the PNG")?;
    writer.write_image_data(&data).context("encoding the PNG")?;
    writer.finish().context("encoding the PNG")?;
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vectors_sizes_and_srgb_parse_and_map() {
        assert_eq!(parse_vec3("1,-2.5, 3").unwrap(), [1.0, -2.5, 3.0]);
        assert!(parse_vec3("1,2").unwrap_err().contains("X,Y,Z"));
        assert!(parse_vec3("1,2,nan").is_err());
        assert_eq!(parse_size("1920x1080").unwrap(), (1920, 1080));
        assert!(parse_size("0x5").is_err());
        assert!(parse_size("big").unwrap_err().contains("WxH"));
        assert_eq!(srgb(0.0), 0);
        assert_eq!(srgb(1.0), 255);
        assert_eq!(srgb(2.0), 255);
        // Mid-grey 0.18 linear is 118 in sRGB (IEC 61966-2-1).
        assert_eq!(srgb(0.18), 118);
    }
}
