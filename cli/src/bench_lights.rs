//! `lrr bench lights`: relit frames per second with moving point lights (issue #32): each frame
//! the direct pass traces every light again (they all move), then the operator bounces
//! `E = ρ ⊙ H`; shadow rays per second beside frames per second, the parts timed apart, and
//! the same frames with the lights standing still (only their intensity changing: the cache
//! traces nothing) for comparison, alternated over rounds.
//!
//! `--device gpu`: the same frames through the GPU direct pass (`lrr_runtime::gpu::GpuDirect`:
//! the shadow rays on the GPU, `E = ρ ⊙ H` written where the GPU evaluator reads it, no readback)
//! and the GPU evaluator's frame, each frame waited for; like the CPU's, the pass traces only
//! the lights that moved (still ones read their stored terms). The evaluator's frame alone is timed
//! beside it, alternated, and the pass's share is the difference. On a CPU adapter (lavapipe)
//! these numbers say nothing about a GPU.

use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Result, bail};
use clap::Args;
use lrr_runtime::lights::{DirectLighting, Light, reflected};
use lrr_runtime::{Operator, Rgb, RgbMut};
use serde::Serialize;

use crate::emission::Device;

#[derive(Debug, Args)]
pub struct LightsBench {
    /// Operator file (with a BVH: baked by this version).
    pub file: PathBuf,
    /// Point lights, each circling its own place (near the light groups' emitters, else the
    /// scene's centre).
    #[arg(long, default_value_t = 4)]
    pub lights: usize,
    /// Sample points per element of the direct pass.
    #[arg(long, default_value_t = lrr_runtime::lights::DEFAULT_SAMPLES)]
    pub samples: u32,
    /// Frames per variant and round.
    #[arg(long, default_value_t = 30)]
    pub frames: usize,
    /// Rounds (moving, still, moving, … alternated).
    #[arg(long, default_value_t = 3)]
    pub rounds: usize,
    /// Threads of the direct pass and the evaluator [default: all cores].
    #[arg(long)]
    pub threads: Option<usize>,
    /// Where the direct pass and the frame run: the CPU (the pass on std threads, its cache of
    /// still lights), or the GPU (the pass and the evaluator's frame in WGSL, no readback; on a
    /// CPU adapter such as lavapipe the numbers mean nothing); auto: the GPU when one is usable.
    #[arg(long, value_enum, default_value_t = Device::Cpu)]
    pub device: Device,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// What one run measured (medians over rounds).
#[derive(Debug, Clone, Serialize)]
pub struct LightsRow {
    pub n: usize,
    pub k: usize,
    pub lights: usize,
    pub samples: u32,
    pub threads: usize,
    /// `cpu`, or `gpu: ` and the adapter.
    pub device: String,
    /// Frames per second with every light moving: direct pass and operator together.
    pub fps_moving: f64,
    /// Of a moving frame: seconds of the direct pass, of `ρ ⊙ H`, of the operator's frame (GPU:
    /// `ρ ⊙ H` is part of the pass, 0 here; the pass is the whole frame's time less the
    /// evaluator's frame alone, timed beside it).
    pub direct_s: f64,
    pub reflect_s: f64,
    pub evaluate_s: f64,
    /// Shadow rays per moving frame and per second of the direct pass.
    pub rays_per_frame: u64,
    pub rays_per_s: f64,
    /// Frames per second with the lights still (their intensity changing: no ray).
    pub fps_still: f64,
}

pub fn run(b: &LightsBench, out: &mut dyn Write) -> Result<()> {
    if b.lights == 0 || b.frames == 0 || b.rounds == 0 {
        bail!("--lights, --frames and --rounds must be at least 1");
    }
    let op = Operator::load(&b.file).map_err(|e| anyhow::anyhow!("{}: {e}", b.file.display()))?;
    let threads = b
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |p| p.get()));
    let pass = DirectLighting::new(op.file(), b.samples, threads)
        .map_err(|e| anyhow::anyhow!("{}: {e}", b.file.display()))?;
    let (centres, radius) = places(&op, b.lights);
    let lights_at = |frame: usize, moving: bool| -> Vec<Light> {
        centres
            .iter()
            .enumerate()
            .map(|(i, (c, u, v))| {
                let t = if moving { frame as f32 * 0.05 } else { 0.0 } + i as f32;
                let (s, co) = t.sin_cos();
                let p = std::array::from_fn(|a| c[a] + radius * (co * u[a] + s * v[a]));
                let power = if moving {
                    1.0
                } else {
                    1.0 + 0.5 * (frame as f32 * 0.1).sin()
                };
                Light::Point {
                    position: p,
                    intensity: [power * 10.0; 3],
                }
            })
            .collect()
    };
    let mut runner = Runner::new(b.device, &op, pass, threads)?;
    // GPU: the shadow rays of one frame counted once (a counted frame reads them back).
    let gpu_rays = runner.count_rays(&lights_at(0, true))?;
    let mut moving_rounds = Vec::new();
    let mut still_rounds = Vec::new();
    let mut frame_no = 0usize;
    for _ in 0..b.rounds {
        for moving in [true, false] {
            let (mut total, mut direct, mut reflect, mut evaluate, mut rays) =
                (0.0, 0.0, 0.0, 0.0, 0u64);
            for _ in 0..b.frames {
                frame_no += 1;
                let lights = lights_at(frame_no, moving);
                let t = runner.frame(&lights)?;
                total += t.total;
                direct += t.direct;
                reflect += t.reflect;
                evaluate += t.evaluate;
                rays += t.rays;
            }
            let f = b.frames as f64;
            let row = (f / total, direct / f, reflect / f, evaluate / f, rays);
            if moving {
                moving_rounds.push(row);
            } else {
                still_rounds.push(row);
            }
        }
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let pick = |rows: &[(f64, f64, f64, f64, u64)], f: fn(&(f64, f64, f64, f64, u64)) -> f64| {
        median(rows.iter().map(f).collect())
    };
    let rays_per_frame = gpu_rays.unwrap_or(moving_rounds[0].4 / b.frames as u64);
    let direct_s = pick(&moving_rounds, |r| r.1);
    let row = LightsRow {
        n: op.n(),
        k: op.k(),
        lights: b.lights,
        samples: b.samples,
        threads,
        device: runner.describe(),
        fps_moving: pick(&moving_rounds, |r| r.0),
        direct_s,
        reflect_s: pick(&moving_rounds, |r| r.2),
        evaluate_s: pick(&moving_rounds, |r| r.3),
        rays_per_frame,
        rays_per_s: rays_per_frame as f64 / direct_s,
        fps_still: pick(&still_rounds, |r| r.0),
    };
    if b.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&row)?)?;
        return Ok(());
    }
    writeln!(
        out,
        "{}: n = {}, k = {}; {} moving point light(s), {} samples per element, {}",
        b.file.display(),
        row.n,
        row.k,
        row.lights,
        row.samples,
        if runner.is_gpu() {
            row.device.clone()
        } else {
            format!("{} thread(s)", row.threads)
        }
    )?;
    writeln!(
        out,
        "moving: {:.1} frames/s (direct pass {:.2} ms: {} shadow rays, {:.2} M rays/s; rho*H \
         {:.2} ms; operator {:.2} ms)",
        row.fps_moving,
        1e3 * row.direct_s,
        row.rays_per_frame,
        1e-6 * row.rays_per_s,
        1e3 * row.reflect_s,
        1e3 * row.evaluate_s
    )?;
    writeln!(
        out,
        "still (intensity changing, nothing traced): {:.1} frames/s",
        row.fps_still
    )?;
    if runner.on_cpu_adapter() {
        writeln!(
            out,
            "note: the adapter is a CPU (lavapipe or similar): these times say nothing about a \
             GPU"
        )?;
    }
    Ok(())
}

/// What one frame cost, in seconds, and its shadow rays (the CPU pass's count; 0 on the GPU,
/// whose rays are counted once).
struct FrameTimes {
    total: f64,
    direct: f64,
    reflect: f64,
    evaluate: f64,
    rays: u64,
}

/// Where the frames run.
enum Runner {
    /// The CPU pass (its cache of still lights), `ρ ⊙ H` and the CPU evaluator.
    Cpu(Box<CpuRunner>),
    /// The GPU pass feeding the GPU evaluator, each frame waited for.
    Gpu(Box<GpuRunner>),
}

/// [`Runner::Cpu`]'s pass, evaluator, reflectance and buffers.
struct CpuRunner {
    pass: DirectLighting,
    eval: lrr_runtime::Evaluator,
    rho: Vec<[f32; 3]>,
    base: Vec<[f32; 3]>,
    h: Vec<[f32; 3]>,
    e: Vec<[f32; 3]>,
    b: Vec<[f32; 3]>,
}

/// [`Runner::Gpu`]'s device, pass, evaluator and base emission.
struct GpuRunner {
    gpu: lrr_runtime::gpu::Gpu,
    direct: lrr_runtime::gpu::GpuDirect,
    eval: lrr_runtime::gpu::GpuEvaluator,
    base: Vec<[f32; 3]>,
}

impl Runner {
    fn new(device: Device, op: &Operator, pass: DirectLighting, threads: usize) -> Result<Self> {
        use lrr_runtime::gpu::{Gpu, GpuDirect, GpuEvaluator, GpuOptions};
        let n = op.n();
        let gpu = match device {
            Device::Cpu => None,
            Device::Gpu => Some(Gpu::new(&GpuOptions::default())?),
            Device::Auto => match Gpu::new(&GpuOptions::default()) {
                Ok(gpu) => Some(gpu),
                Err(e) => {
                    eprintln!("lrr: note: no usable GPU ({e}); benchmarking the CPU");
                    None
                }
            },
        };
        let rho = op.reflectance();
        Ok(match gpu {
            None => Runner::Cpu(Box::new(CpuRunner {
                pass,
                eval: op.evaluator(threads)?,
                rho,
                base: vec![[0.0; 3]; n],
                h: vec![[0.0; 3]; n],
                e: vec![[0.0; 3]; n],
                b: vec![[0.0; 3]; n],
            })),
            Some(gpu) => Runner::Gpu(Box::new(GpuRunner {
                direct: GpuDirect::new(&gpu, &pass, &rho)?,
                eval: GpuEvaluator::new(&gpu, op)?,
                gpu,
                base: vec![[0.0; 3]; n],
            })),
        })
    }

    fn is_gpu(&self) -> bool {
        matches!(self, Runner::Gpu(_))
    }

    fn on_cpu_adapter(&self) -> bool {
        matches!(self, Runner::Gpu(g) if g.gpu.is_cpu())
    }

    fn describe(&self) -> String {
        match self {
            Runner::Cpu(_) => "cpu".to_owned(),
            Runner::Gpu(g) => format!("gpu: {}", g.gpu.adapter_name()),
        }
    }

    /// GPU: the shadow rays of a frame lit by `lights`, from one counted frame read back.
    fn count_rays(&mut self, lights: &[Light]) -> Result<Option<u64>> {
        let Runner::Gpu(g) = self else {
            return Ok(None);
        };
        let GpuRunner {
            direct, eval, base, ..
        } = &mut **g;
        let mut b = vec![[0.0f32; 3]; base.len()];
        direct.set_count_rays(true);
        let report = direct.evaluate(eval, lights, Rgb::triples(base), RgbMut::triples(&mut b));
        direct.set_count_rays(false);
        Ok(report?.rays)
    }

    fn frame(&mut self, lights: &[Light]) -> Result<FrameTimes> {
        match self {
            Runner::Cpu(c) => {
                let CpuRunner {
                    pass,
                    eval,
                    rho,
                    base,
                    h,
                    e,
                    b,
                } = &mut **c;
                let t0 = Instant::now();
                let report = pass.irradiance(lights, h)?;
                let t1 = Instant::now();
                reflected(rho, h, base, e)?;
                let t2 = Instant::now();
                eval.evaluate(Rgb::triples(e), RgbMut::triples(b))?;
                let t3 = Instant::now();
                Ok(FrameTimes {
                    total: (t3 - t0).as_secs_f64(),
                    direct: (t1 - t0).as_secs_f64(),
                    reflect: (t2 - t1).as_secs_f64(),
                    evaluate: (t3 - t2).as_secs_f64(),
                    rays: report.rays,
                })
            }
            Runner::Gpu(g) => {
                let GpuRunner {
                    direct, eval, base, ..
                } = &mut **g;
                let t0 = Instant::now();
                direct.submit(eval, lights, Rgb::triples(base))?;
                eval.wait()?;
                let t1 = Instant::now();
                // The evaluator's frame alone, beside it: the pass's share is the difference.
                eval.submit(Rgb::triples(base))?;
                eval.wait()?;
                let t2 = Instant::now();
                let (total, evaluate) = ((t1 - t0).as_secs_f64(), (t2 - t1).as_secs_f64());
                Ok(FrameTimes {
                    total,
                    direct: (total - evaluate).max(0.0),
                    reflect: 0.0,
                    evaluate,
                    rays: 0,
                })
            }
        }
    }
}

/// Where the lights circle: near each light group's emitting elements (their area-weighted
/// centre, moved 10 % of the scene's extent along their mean normal, into the room), else the
/// middle of the scene; and the circles' radius (2 % of the extent). Each centre comes with two
/// unit vectors spanning its circle.
#[allow(clippy::type_complexity)]
fn places(op: &Operator, count: usize) -> (Vec<([f32; 3], [f32; 3], [f32; 3])>, f32) {
    let file = op.file();
    let g = &file.geometry;
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for v in g.vertices.chunks_exact(3) {
        for a in 0..3 {
            lo[a] = lo[a].min(v[a]);
            hi[a] = hi[a].max(v[a]);
        }
    }
    let extent = (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f32>().sqrt();
    let middle: [f32; 3] = std::array::from_fn(|a| 0.5 * (lo[a] + hi[a]));
    let mut spots: Vec<([f32; 3], [f32; 3])> = Vec::new();
    for group in &file.lights {
        let (mut c, mut n, mut area) = ([0.0f32; 3], [0.0f32; 3], 0.0f32);
        for &s in &group.positions {
            let s = s as usize;
            let count = g.vertex_count[s] as usize;
            let v = |i: usize| -> [f32; 3] {
                let at = 12 * s + 3 * i;
                [g.vertices[at], g.vertices[at + 1], g.vertices[at + 2]]
            };
            let mut centroid = [0.0f32; 3];
            for i in 0..count {
                for a in 0..3 {
                    centroid[a] += v(i)[a] / count as f32;
                }
            }
            let e1 = sub(v(1), v(0));
            let e2 = sub(v(count - 1), v(0));
            let a = 0.5 * length(cross(e1, e2)) * if count == 4 { 2.0 } else { 1.0 };
            let normal = g.normal(s);
            for k in 0..3 {
                c[k] += a * centroid[k];
                n[k] += a * normal[k];
            }
            area += a;
        }
        if area > 0.0 {
            let n = normalize(n);
            spots.push((
                std::array::from_fn(|k| c[k] / area + 0.1 * extent * n[k]),
                n,
            ));
        }
    }
    if spots.is_empty() {
        spots.push((middle, [0.0, 1.0, 0.0]));
    }
    let places = (0..count)
        .map(|i| {
            let (c, n) = spots[i % spots.len()];
            let a = if n[0].abs() > 0.9 {
                [0.0, 1.0, 0.0]
            } else {
                [1.0, 0.0, 0.0]
            };
            let u = normalize(cross(a, n));
            (c, u, cross(n, u))
        })
        .collect();
    (places, 0.02 * extent)
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn length(a: [f32; 3]) -> f32 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

fn normalize(a: [f32; 3]) -> [f32; 3] {
    let l = length(a);
    if l > 0.0 { a.map(|x| x / l) } else { a }
}
