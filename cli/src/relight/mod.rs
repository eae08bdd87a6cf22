//! `lrr relight OUT.lrr --animation ANIM.toml -o DIR`: light groups, and lights that are not
//! surfaces, keyframed over time ([`animation`]), evaluated frame by frame with one persistent
//! evaluator (the lights, the file's and the animation's, through one direct pass that traces
//! again only the lights that moved). Each frame's
//! radiosity is written as an EXR lightmap (`DIR/lightmap-00000.exr`, …; the atlas of
//! `lrr export`, laid out once) and/or, with `--images png|exr`, ray traced from a camera
//! (`DIR/frame-00000.png`, …; the CPU tracer of `lrr render`, PNGs at one exposure for the
//! whole sequence). A progress bar shows frames per second; the end line gives the achieved
//! rates of the whole loop, the evaluation alone, the tracing and the writing.

pub mod animation;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use lrr_runtime::trace::{Image, Tracer, View};
use lrr_runtime::{Lightmap, Operator, Reconstruction, Rgb, RgbMut};

use crate::emission::{Frame, FrameLights, Reconstruct, reconstruction};
use crate::export::field::Field;
use crate::export::{LightmapArgs, LightmapLayout, lightmap_atlas};
use crate::exr_image::{self, ExrSamples, RgbLayer};
use crate::picture::{self, CameraArgs, ImageFormat, parse_size};
use animation::{Animation, Track};

#[derive(Debug, Args)]
pub struct RelightArgs {
    /// Operator file.
    pub file: PathBuf,
    /// The animation: keyframes of light-group intensities and colours (TOML).
    #[arg(long, value_name = "ANIM.toml")]
    pub animation: PathBuf,
    /// Output folder (created): `lightmap-00000.exr`, … and/or `frame-00000.png|exr`, ….
    #[arg(long, short, value_name = "DIR")]
    pub output: PathBuf,
    /// Ray trace every frame from a camera into `frame-NNNNN.png` (8-bit sRGB, one exposure
    /// for the whole sequence) or `.exr` (linear RGB radiance); lightmaps are then written
    /// only with --lightmaps.
    #[arg(long, value_enum, value_name = "FORMAT")]
    pub images: Option<ImageFormat>,
    /// Write the EXR lightmaps (the default without --images).
    #[arg(long)]
    pub lightmaps: bool,
    #[command(flatten)]
    pub view: CameraArgs,
    /// Images: size in pixels.
    #[arg(long, value_name = "WxH", default_value = "800x600", value_parser = parse_size)]
    pub image_size: (u32, u32),
    /// Images (PNG): exposure in stops (values × 2^EV before the sRGB curve) [default: the
    /// 99th percentile of the first lit frame's luminance maps to white], the same for every
    /// frame.
    #[arg(long, value_name = "EV", allow_hyphen_values = true)]
    pub exposure: Option<f32>,
    #[command(flatten)]
    pub lightmap: LightmapArgs,
    /// EXR sample type (lightmaps and EXR images): `half` or `float`.
    #[arg(long, value_enum, default_value_t = ExrSamples::Half)]
    pub samples: ExrSamples,
    /// Threads of the evaluator and the tracer [default: all cores].
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// How values inside elements come from the element values: `smooth` (the default when
    /// the file has smooth weights) or `flat`; for lightmaps and images alike.
    #[arg(long, value_enum)]
    pub reconstruct: Option<Reconstruct>,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Seconds spent per part of the loop.
#[derive(Default)]
struct Timings {
    evaluating: f64,
    tracing: f64,
    writing: f64,
}

pub fn run(a: &RelightArgs, out: &mut dyn Write) -> Result<()> {
    check_flags(a)?;
    let op = Operator::load(&a.file).map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?;
    let anim = Animation::read(&a.animation)?;
    let tracks = anim.tracks(&op, &a.animation)?;
    let smooth = reconstruction(&op, a.reconstruct, &a.file)?;
    let mut lightmaps = match a.images.is_none() || a.lightmaps {
        true => Some(Lightmaps::new(a, &op, smooth.is_some())?),
        false => None,
    };
    let mut images = match a.images {
        Some(format) => Some(Images::new(a, &op, format, smooth.is_some(), out)?),
        None => None,
    };
    std::fs::create_dir_all(&a.output)
        .with_context(|| format!("creating {}", a.output.display()))?;
    let threads = a.threads.unwrap_or(0);
    let mut eval = op.evaluator(threads)?;
    let groups = group_emission(&op);
    let (n, frames) = (op.n(), anim.frames());
    let (mut emission, mut b) = (vec![[0.0f32; 3]; n], vec![[0.0f32; 3]; n]);
    let progress = {
        use std::io::IsTerminal;
        lrr_precompute::progress::Progress::new(!a.quiet && std::io::stderr().is_terminal())
    };
    let stage = progress.stage("relight", frames as u64);
    let (start, mut time) = (Instant::now(), Timings::default());
    // The lights that are not surfaces: the file's, and the animation's tracks.
    let (file_lights, sky) = lrr_runtime::lights::file_lights(op.file());
    let mut lit = Frame::new(&op);
    for f in 0..frames {
        let t = f as f64 / anim.fps;
        let scales = frame_scales(&tracks, t);
        let timer = Instant::now();
        let lights = FrameLights {
            lights: file_lights
                .iter()
                .copied()
                .chain(anim.light.iter().map(|track| track.at(t)))
                .collect(),
            sky,
            samples: lrr_runtime::lights::DEFAULT_SAMPLES,
        };
        let intensities = match grey(&scales) {
            Some(intensities) if lights.is_empty() => {
                // Every group white: the groups' fast path, as `lrr render --group` evaluates.
                eval.evaluate_groups(&intensities, RgbMut::triples(&mut b))?;
                intensities
            }
            _ => {
                fill_emission(&mut emission, &groups, &scales);
                let e = lit.light(&op, emission.clone(), &lights)?;
                eval.evaluate(Rgb::triples(&e), RgbMut::triples(&mut b))?;
                scales.iter().map(|s| (s[0] + s[1] + s[2]) / 3.0).collect()
            }
        };
        if lights.is_empty() {
            lit.lights.clear();
        }
        lit.set_radiosity(b.clone());
        time.evaluating += timer.elapsed().as_secs_f64();
        let note = format!("frame {f} at t = {t:.6} s of {}", a.animation.display());
        if let Some(l) = lightmaps.as_mut() {
            let timer = Instant::now();
            let path = a.output.join(format!("lightmap-{f:05}.exr"));
            l.write(&op, &lit, smooth, &path, &note)?;
            time.writing += timer.elapsed().as_secs_f64();
        }
        if let Some(images) = images.as_mut() {
            let path = a
                .output
                .join(format!("frame-{f:05}.{}", images.format.extension()));
            images.frame(&lit, &intensities, &path, &note, &mut time, out)?;
        }
        stage.inc(1);
    }
    stage.finish();
    let mut what = Vec::new();
    if let Some(l) = &lightmaps {
        let (w, h) = l.layout.size();
        writeln!(out, "lightmaps: {}", l.layout.describe())?;
        what.push(format!("{w}x{h} lightmaps"));
    }
    if let Some(images) = &images {
        let ((w, h), format) = (images.size, images.format.extension().to_uppercase());
        what.push(format!("{w}x{h} {format} images"));
    }
    let what = what.join(" and ");
    report(a, &what, frames, start.elapsed().as_secs_f64(), &time, out)
}

/// Flag combinations that make no sense, refused before any work.
fn check_flags(a: &RelightArgs) -> Result<()> {
    let v = &a.view;
    let camera_given = v.eye.is_some()
        || v.target.is_some()
        || v.up.is_some()
        || v.fov_y.is_some()
        || v.camera.is_some();
    if a.images.is_none() && (camera_given || a.exposure.is_some()) {
        bail!("the camera flags and --exposure are for rendered frames: add --images png (or exr)");
    }
    if a.images.is_none() && a.lightmaps {
        bail!("--lightmaps is the default without --images; give --images png|exr with it");
    }
    Ok(())
}

/// Per light group of the file, its scale (intensity × colour) at time `t`.
fn frame_scales(tracks: &[Option<&Track>], t: f64) -> Vec<[f32; 3]> {
    tracks
        .iter()
        .map(|track| track.map_or([1.0; 3], |tr| tr.at(t)))
        .collect()
}

/// The groups' intensities when every scale is grey (the same in R, G and B).
fn grey(scales: &[[f32; 3]]) -> Option<Vec<f32>> {
    scales
        .iter()
        .map(|s| (s[0] == s[1] && s[1] == s[2]).then_some(s[0]))
        .collect()
}

/// `emission = Σ_g scale_g ⊙ E_g`.
fn fill_emission(
    emission: &mut [[f32; 3]],
    groups: &[Vec<(usize, [f32; 3])>],
    scales: &[[f32; 3]],
) {
    emission.iter_mut().for_each(|e| *e = [0.0; 3]);
    for (g, members) in groups.iter().enumerate() {
        for &(id, e) in members {
            for c in 0..3 {
                emission[id][c] += scales[g][c] * e[c];
            }
        }
    }
}

/// Each light group's members: (original id, emission at intensity 1).
fn group_emission(op: &Operator) -> Vec<Vec<(usize, [f32; 3])>> {
    let file = op.file();
    file.lights
        .iter()
        .map(|g| {
            g.positions
                .iter()
                .enumerate()
                .map(|(i, &s)| {
                    let e = &g.emission[3 * i..3 * i + 3];
                    (file.order[s as usize] as usize, [e[0], e[1], e[2]])
                })
                .collect()
        })
        .collect()
}

/// The lightmap output: the atlas laid out once (`lrr export`'s: the file's atlas unless the
/// flags reshape it) and the runtime's lightmap over it, filled every frame.
struct Lightmaps {
    layout: LightmapLayout,
    map: Lightmap,
    samples: ExrSamples,
}

impl Lightmaps {
    fn new(a: &RelightArgs, op: &Operator, smooth: bool) -> Result<Self> {
        let layout = a.lightmap.layout(op)?;
        let map = layout.lightmap(op, smooth)?;
        Ok(Self {
            layout,
            map,
            samples: a.samples,
        })
    }

    /// Fills the frame's `B/π` (its lights' direct light per sample) and writes it to `path`.
    fn write(
        &mut self,
        op: &Operator,
        frame: &Frame,
        smooth: Option<Reconstruction>,
        path: &Path,
        note: &str,
    ) -> Result<()> {
        let field = Field::new(op.file(), &frame.shown, smooth)?.with_direct(frame, op.file());
        let texels = lightmap_atlas(&mut self.map, &frame.shown, Some(&field))?;
        let layer = [RgbLayer {
            name: None,
            pixels: &texels,
        }];
        let (w, h) = self.layout.size();
        let note = format!("{note}: exitant radiance B/pi");
        exr_image::write_rgb(path, w, h, &layer, self.samples, &note)
    }
}

/// The rendered output: the tracer, the view and the sequence's exposure.
struct Images {
    tracer: Tracer,
    view: View,
    size: (u32, u32),
    threads: usize,
    format: ImageFormat,
    samples: ExrSamples,
    /// PNG: the scale before the sRGB curve, fixed by `--exposure` or the first lit frame.
    scale: Option<f32>,
}

impl Images {
    fn new(
        a: &RelightArgs,
        op: &Operator,
        format: ImageFormat,
        smooth: bool,
        out: &mut dyn Write,
    ) -> Result<Self> {
        let mut tracer =
            Tracer::new(op.file()).map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?;
        tracer.set_smooth(smooth)?;
        let camera = a.view.camera(&tracer, &a.file)?;
        let (w, h) = a.image_size;
        let view = View::new(&camera, w, h)?;
        if !camera.name.is_empty() {
            writeln!(out, "camera '{}'", camera.name)?;
        }
        let scale = match (format, a.exposure) {
            (ImageFormat::Png, Some(ev)) => Some(2f32.powf(ev)),
            _ => None,
        };
        if let Some(s) = scale {
            writeln!(out, "exposure: {:+.2} EV (x{s:.4}, --exposure)", s.log2())?;
        }
        Ok(Self {
            tracer,
            view,
            size: (w, h),
            threads: a.threads.unwrap_or(0),
            format,
            samples: a.samples,
            scale,
        })
    }

    /// Traces `frame` (its lights shaded per hit) with group intensities `groups` (their
    /// highlights), writes it to `path`.
    fn frame(
        &mut self,
        frame: &Frame,
        groups: &[f32],
        path: &Path,
        note: &str,
        time: &mut Timings,
        out: &mut dyn Write,
    ) -> Result<()> {
        let timer = Instant::now();
        let lighting = frame.trace_lighting(groups);
        let (w, h) = self.size;
        let (image, _) = self
            .tracer
            .render(&self.view, &lighting, w, h, self.threads)?;
        time.tracing += timer.elapsed().as_secs_f64();
        let timer = Instant::now();
        let bytes = match self.format {
            ImageFormat::Png => {
                let scale = self.exposure(&image, out)?;
                picture::encode_png(&image, scale)?
            }
            ImageFormat::Exr => picture::encode_exr(&image, self.samples, note)?,
        };
        lrr_formats::write_atomic(path, &bytes)
            .with_context(|| format!("writing {}", path.display()))?;
        time.writing += timer.elapsed().as_secs_f64();
        Ok(())
    }

    /// The sequence's PNG scale: fixed at the first frame that is not black (black frames
    /// before it are black at any exposure), printed once.
    fn exposure(&mut self, image: &Image, out: &mut dyn Write) -> Result<f32> {
        if let Some(s) = self.scale {
            return Ok(s);
        }
        let (s, how) = picture::exposure(image, None);
        if image.pixels.iter().any(|p| p.iter().any(|&c| c > 0.0)) {
            writeln!(
                out,
                "exposure: {:+.2} EV (x{s:.4}, {how} in the first lit frame; every frame)",
                s.log2()
            )?;
            self.scale = Some(s);
        }
        Ok(s)
    }
}

/// The end lines: frames, what, where, and the achieved rates.
fn report(
    a: &RelightArgs,
    what: &str,
    frames: usize,
    total: f64,
    time: &Timings,
    out: &mut dyn Write,
) -> Result<()> {
    let rate = |seconds: f64| frames as f64 / seconds.max(1e-12);
    let ms = |seconds: f64| 1e3 * seconds / frames as f64;
    writeln!(
        out,
        "wrote {frames} frames ({what}) to {}: {:.1} frames/s in all; evaluation alone {:.1} frames/s \
         ({:.3} ms a frame)",
        a.output.display(),
        rate(total),
        rate(time.evaluating),
        ms(time.evaluating)
    )?;
    if a.images.is_some() {
        write!(
            out,
            "tracing {:.2} frames/s ({:.1} ms a frame), ",
            rate(time.tracing),
            ms(time.tracing)
        )?;
    }
    writeln!(
        out,
        "writing {:.1} frames/s ({:.1} ms a frame)",
        rate(time.writing),
        ms(time.writing)
    )?;
    Ok(())
}
