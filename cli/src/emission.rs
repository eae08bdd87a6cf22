//! The frame a command evaluates: the baked emission, light-group intensities (`--group`) or a
//! per-element emission (`--emission`), on the CPU or a GPU. Shared by `lrr probe` and
//! `lrr export` (and any command that shows one frame), so the flags mean the same everywhere.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use lrr_runtime::gpu::{Gpu, GpuError, GpuEvaluator, GpuOptions};
use lrr_runtime::lights::{DirectLighting, DirectReport, Light, Sky, file_lights, reflected};
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
    #[command(flatten)]
    pub lights: LightArgs,
}

/// Lights that are not surfaces, added to the frame's emission by the direct pass (DESIGN.md
/// §9): the file's (point lights of no group, spot and directional lights, the sky) and these.
#[derive(Debug, Clone, Default, Args)]
pub struct LightArgs {
    /// A point light `X,Y,Z:R,G,B`: position and intensity per channel in W/sr (repeatable).
    // The id is not the field's name: `lrr probe` has a `points` of its own (`--points`), and
    // two arguments of one id made clap take `--point-light` for a second `--points` (found
    // by the `probe_points` fuzz target, whose debug assertions panic on it).
    #[arg(long = "point-light", id = "point_light", value_name = "X,Y,Z:R,G,B")]
    pub points: Vec<String>,
    /// A spot light `X,Y,Z:DX,DY,DZ:R,G,B:INNER,OUTER`: position, where it points, intensity on
    /// the axis (W/sr) and glTF's cone half-angles in degrees (repeatable).
    #[arg(long = "spot-light", value_name = "X,Y,Z:DX,DY,DZ:R,G,B:INNER,OUTER")]
    pub spots: Vec<String>,
    /// A directional light `DX,DY,DZ:R,G,B`: the direction its light travels and its irradiance
    /// per channel (W/m², scene units, facing it) (repeatable).
    #[arg(long = "sun", value_name = "DX,DY,DZ:R,G,B")]
    pub suns: Vec<String>,
    /// A uniform sky of radiance `R,G,B` (W/m²/sr), in place of the file's sky.
    #[arg(long, value_name = "R,G,B")]
    pub sky: Option<String>,
    /// Leave out the lights the file holds (its point lights of no group, spots, suns, sky).
    #[arg(long)]
    pub no_file_lights: bool,
    /// Sample points per element for the direct pass's irradiance (1 to 64).
    #[arg(long, value_name = "N", default_value_t = lrr_runtime::lights::DEFAULT_SAMPLES)]
    pub light_samples: u32,
}

/// A frame's lights that are not surfaces.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FrameLights {
    /// Point, spot and directional lights.
    pub lights: Vec<Light>,
    /// The sky.
    pub sky: Option<Sky>,
    /// Sample points per element.
    pub samples: u32,
}

impl FrameLights {
    /// No light to shade: no direct pass, no shadow ray.
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty() && self.sky.is_none()
    }
}

impl LightArgs {
    /// The frame's lights: the file's unless `--no-file-lights`, then the flags'. Errors name
    /// the flag and what is wrong with it.
    pub fn lights(&self, op: &Operator) -> Result<FrameLights> {
        let (mut lights, mut sky) = if self.no_file_lights {
            (Vec::new(), None)
        } else {
            file_lights(op.file())
        };
        for spec in &self.points {
            let flag = format!("--point-light {spec}");
            let [p, i] = fields(spec, &flag, "X,Y,Z:R,G,B")?;
            lights.push(Light::Point {
                position: triple(p, &flag)?,
                intensity: triple(i, &flag)?,
            });
        }
        for spec in &self.spots {
            let flag = format!("--spot-light {spec}");
            let [p, d, i, cones] = fields(spec, &flag, "X,Y,Z:DX,DY,DZ:R,G,B:INNER,OUTER")?;
            let cones = numbers(cones, &flag)?;
            let [inner, outer] = cones[..] else {
                bail!("{flag}: the cones are two angles in degrees, INNER,OUTER");
            };
            lights.push(Light::Spot {
                position: triple(p, &flag)?,
                direction: triple(d, &flag)?,
                intensity: triple(i, &flag)?,
                inner: inner.to_radians(),
                outer: outer.to_radians(),
            });
        }
        for spec in &self.suns {
            let flag = format!("--sun {spec}");
            let [d, e] = fields(spec, &flag, "DX,DY,DZ:R,G,B")?;
            lights.push(Light::Directional {
                direction: triple(d, &flag)?,
                irradiance: triple(e, &flag)?,
            });
        }
        if let Some(spec) = &self.sky {
            sky = Some(Sky::Uniform {
                radiance: triple(spec, &format!("--sky {spec}"))?,
            });
        }
        for (i, light) in lights.iter().enumerate() {
            light
                .check()
                .map_err(|p| anyhow::anyhow!("light {i} ({light:?}): {p}"))?;
        }
        if let Some(s) = &sky {
            s.check().map_err(|p| anyhow::anyhow!("the sky: {p}"))?;
        }
        if !(1..=64).contains(&self.light_samples) {
            bail!("--light-samples {}: use 1 to 64", self.light_samples);
        }
        Ok(FrameLights {
            lights,
            sky,
            samples: self.light_samples,
        })
    }
}

/// `spec` split at `:` into `N` fields, or an error showing the `shape`.
fn fields<'s, const N: usize>(spec: &'s str, flag: &str, shape: &str) -> Result<[&'s str; N]> {
    let parts: Vec<&str> = spec.split(':').collect();
    parts
        .try_into()
        .map_err(|_| anyhow::anyhow!("{flag}: expected {shape}"))
}

/// Comma-separated finite numbers.
fn numbers(text: &str, flag: &str) -> Result<Vec<f32>> {
    text.split(',')
        .map(|t| {
            t.trim()
                .parse::<f32>()
                .ok()
                .filter(|v| v.is_finite())
                .with_context(|| format!("{flag}: '{t}' is not a finite number"))
        })
        .collect()
}

/// Three comma-separated finite numbers.
fn triple(text: &str, flag: &str) -> Result<[f32; 3]> {
    let v = numbers(text, flag)?;
    <[f32; 3]>::try_from(v.as_slice())
        .map_err(|_| anyhow::anyhow!("{flag}: '{text}' is not three numbers X,Y,Z"))
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

/// A frame with its lights that are not surfaces: the radiosity `B` of the emission plus the
/// lights' reflected direct light, and what a display interpolates over the surface (`B` less
/// the point-shaded lights' part, `ρ ⊙ H` per element) before it adds the direct light at the
/// shaded point itself ([`Frame::at`]). One `Frame` can be lit again and again (`lrr relight`):
/// its direct pass, made on first use, keeps what it traced for lights that did not move.
pub struct Frame {
    /// `B` per element, original ids.
    pub radiosity: Vec<[f32; 3]>,
    /// `B − ρ ⊙ H_lights` per element (the sky's direct light stays in: it has no per-point
    /// value); the radiosity itself when the frame has no lights.
    pub shown: Vec<[f32; 3]>,
    /// The frame's point, spot and directional lights.
    pub lights: Vec<Light>,
    /// Reflectance per element, original ids.
    pub reflectance: Vec<[f32; 3]>,
    /// The direct pass, once a frame has had lights or a sky.
    pub pass: Option<DirectLighting>,
    /// What the direct pass traced for the last frame.
    pub report: DirectReport,
    /// `H` of the point-shaded lights per element (empty without lights).
    h: Vec<[f32; 3]>,
}

impl Frame {
    /// A frame of `op` not lit yet.
    pub fn new(op: &Operator) -> Self {
        Frame {
            radiosity: Vec::new(),
            shown: Vec::new(),
            lights: Vec::new(),
            reflectance: op.reflectance(),
            pass: None,
            report: DirectReport::default(),
            h: Vec::new(),
        }
    }

    /// The emission `base + ρ ⊙ H` of `lights` (the direct pass made on first use, its shadow
    /// rays through the file's BVH: an error when the file has none); `base` itself when there
    /// are no lights, and no ray.
    pub fn light(
        &mut self,
        op: &Operator,
        base: Vec<[f32; 3]>,
        lights: &FrameLights,
    ) -> Result<Vec<[f32; 3]>> {
        self.lights = lights.lights.clone();
        self.report = DirectReport::default();
        if lights.is_empty() {
            self.h.clear();
            return Ok(base);
        }
        let n = op.n();
        if self
            .pass
            .as_ref()
            .is_none_or(|p| p.samples_per_element() != lights.samples)
        {
            self.pass = Some(
                DirectLighting::new(op.file(), lights.samples, 0)
                    .map_err(|e| anyhow::anyhow!("the direct pass of the frame's lights: {e}"))?,
            );
        }
        let pass = self.pass.as_mut().expect("made above");
        self.h.resize(n, [0.0; 3]);
        self.report = pass.irradiance(&lights.lights, &mut self.h)?;
        let mut total = self.h.clone();
        if let Some(sky) = &lights.sky {
            let mut h_sky = vec![[0.0f32; 3]; n];
            let r = pass.sky_irradiance(sky, &mut h_sky)?;
            self.report.rays += r.rays;
            for (t, s) in total.iter_mut().zip(&h_sky) {
                *t = std::array::from_fn(|c| t[c] + s[c]);
            }
        }
        let mut e = vec![[0.0f32; 3]; n];
        reflected(&self.reflectance, &total, &base, &mut e)?;
        Ok(e)
    }

    /// Takes the frame's radiosity `b` (of the emission [`Frame::light`] gave): `shown` is `b`
    /// less the point-shaded lights' `ρ ⊙ H`.
    pub fn set_radiosity(&mut self, b: Vec<[f32; 3]>) {
        self.shown = if self.h.is_empty() {
            b.clone()
        } else {
            b.iter()
                .zip(&self.h)
                .zip(&self.reflectance)
                .map(|((b, h), r)| std::array::from_fn(|c| b[c] - r[c] * h[c]))
                .collect()
        };
        self.radiosity = b;
    }

    /// What the tracer shades: the bounced light (`shown`) and the lights per hit, with the
    /// light groups' intensities `groups` (their point lights' highlights).
    pub fn trace_lighting<'a>(&'a self, groups: &'a [f32]) -> lrr_runtime::trace::Lighting<'a> {
        lrr_runtime::trace::Lighting {
            radiosity: &self.shown,
            group_intensities: groups,
            direct: Some(lrr_runtime::trace::DirectShading {
                lights: &self.lights,
                reflectance: &self.reflectance,
            }),
        }
    }

    /// The direct irradiance times the reflectance of `element` at point `x` of a face with
    /// front normal `normal` (zero without point-shaded lights).
    pub fn at(&self, element: usize, x: [f32; 3], normal: [f32; 3]) -> [f32; 3] {
        match &self.pass {
            Some(pass) if !self.lights.is_empty() => {
                let h = pass.at(&self.lights, x, normal);
                let rho = self.reflectance[element];
                [rho[0] * h[0], rho[1] * h[1], rho[2] * h[2]]
            }
            _ => [0.0; 3],
        }
    }
}

/// The emission of `lighting` per element, original ids.
pub fn emission_of(op: &Operator, lighting: &Lighting) -> Result<Vec<[f32; 3]>> {
    Ok(match lighting {
        Lighting::Baked => op.baked_emission(),
        Lighting::Groups(a) => op.group_emission(a)?,
        Lighting::Emission(e) => e.clone(),
    })
}

/// The frame of `lighting` and `lights` on `device`. Without lights and sky: the evaluator's
/// frame alone (no direct pass, no ray). With them: the direct pass on the CPU, then the frame
/// of the emission plus `ρ ⊙ H`.
pub fn frame(
    op: &Operator,
    lighting: &Lighting,
    lights: &FrameLights,
    device: Device,
) -> Result<Frame> {
    let mut frame = Frame::new(op);
    let b = if lights.is_empty() {
        radiosity(op, lighting, device)?
    } else {
        let e = frame.light(op, emission_of(op, lighting)?, lights)?;
        radiosity(op, &Lighting::Emission(e), device)?
    };
    frame.set_radiosity(b);
    Ok(frame)
}
