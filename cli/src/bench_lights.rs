//! `lrr bench lights`: relit frames per second with moving point lights (issue #32): each frame
//! the direct pass traces every light again (they all move), then the operator bounces
//! `E = ρ ⊙ H`; shadow rays per second beside frames per second, the parts timed apart, and
//! the same frames with the lights standing still (only their intensity changing: the cache
//! traces nothing) for comparison, alternated over rounds.

use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Result, bail};
use clap::Args;
use lrr_runtime::trace::{DirectLighting, Light, reflected};
use lrr_runtime::{Operator, Rgb, RgbMut};
use serde::Serialize;

#[derive(Debug, Args)]
pub struct LightsBench {
    /// Operator file (with a BVH: baked by this version).
    pub file: PathBuf,
    /// Point lights, each circling its own place (near the light groups' emitters, else the
    /// scene's centre).
    #[arg(long, default_value_t = 4)]
    pub lights: usize,
    /// Sample points per element of the direct pass.
    #[arg(long, default_value_t = lrr_runtime::trace::DEFAULT_SAMPLES)]
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
    /// Frames per second with every light moving: direct pass and operator together.
    pub fps_moving: f64,
    /// Of a moving frame: seconds of the direct pass, of `ρ ⊙ H`, of the operator's frame.
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
    let mut pass = DirectLighting::new(op.file(), b.samples, threads)
        .map_err(|e| anyhow::anyhow!("{}: {e}", b.file.display()))?;
    let mut eval = op.evaluator(threads)?;
    let (centres, radius) = places(&op, b.lights);
    let rho = op.reflectance();
    let base = vec![[0.0f32; 3]; op.n()];
    let (mut h, mut e, mut bb) = (
        vec![[0.0f32; 3]; op.n()],
        vec![[0.0f32; 3]; op.n()],
        vec![[0.0f32; 3]; op.n()],
    );
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
    let mut moving_rounds = Vec::new();
    let mut still_rounds = Vec::new();
    let mut frame_no = 0usize;
    for _ in 0..b.rounds {
        for moving in [true, false] {
            let (mut direct, mut reflect, mut evaluate, mut rays) = (0.0, 0.0, 0.0, 0u64);
            let start = Instant::now();
            for _ in 0..b.frames {
                frame_no += 1;
                let lights = lights_at(frame_no, moving);
                let t0 = Instant::now();
                let report = pass.irradiance(&lights, &mut h)?;
                let t1 = Instant::now();
                reflected(&rho, &h, &base, &mut e)?;
                let t2 = Instant::now();
                eval.evaluate(Rgb::triples(&e), RgbMut::triples(&mut bb))?;
                let t3 = Instant::now();
                direct += (t1 - t0).as_secs_f64();
                reflect += (t2 - t1).as_secs_f64();
                evaluate += (t3 - t2).as_secs_f64();
                rays += report.rays;
            }
            let seconds = start.elapsed().as_secs_f64();
            let f = b.frames as f64;
            let row = (f / seconds, direct / f, reflect / f, evaluate / f, rays);
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
    let rays_per_frame = moving_rounds[0].4 / b.frames as u64;
    let direct_s = pick(&moving_rounds, |r| r.1);
    let row = LightsRow {
        n: op.n(),
        k: op.k(),
        lights: b.lights,
        samples: b.samples,
        threads,
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
        "{}: n = {}, k = {}; {} moving point light(s), {} samples per element, {} thread(s)",
        b.file.display(),
        row.n,
        row.k,
        row.lights,
        row.samples,
        row.threads
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
    Ok(())
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
