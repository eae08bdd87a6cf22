//! `lrr bench render`: rays per second of the CPU ray tracer by kind (primary and secondary
//! closest hits, shadow any hits) at 1920×1080, against Embree's single-ray queries
//! (`rtcIntersect1`, `rtcOccluded1`) on the same rays in the same run, one thread each,
//! alternated; and whole frames with the effects the scene needs against all effects forced on
//! (what simulating only what the scene calls for saves).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use lrr_formats::{Camera, Display, Geometry, Layout, OperatorFile, PointLight, Precision};
use lrr_precompute::scene::procedural;
use lrr_runtime::testkit;
use lrr_runtime::trace::{Effects, Lighting, RayBatch, TraceHit, Tracer, View};

#[derive(Debug, Args)]
pub struct RenderBench {
    /// Operator file with a BVH and a camera [default: the generated dense scene: the dense
    /// sphere (subdivision 6) in its room, every triangle split in 4 (328 k triangles), two
    /// point lights, the BVH `--tree` builds].
    #[arg(long, value_name = "FILE.lrr")]
    pub file: Option<PathBuf>,
    /// Image size.
    #[arg(long, value_name = "WxH", default_value = "1920x1080")]
    pub size: String,
    /// Rounds (tracer and Embree alternated in each; medians reported).
    #[arg(long, default_value_t = 5)]
    pub runs: usize,
    /// Threads of the whole-frame renders [default: all cores]. Ray kinds run on one thread.
    #[arg(long)]
    pub threads: Option<usize>,
    /// `cpu`: the CPU twin by ray kind against Embree, and whole frames. `gpu`: whole frames of
    /// the WGSL tracer (primary rays only, the decided effects, on a file with SMOOTH weights
    /// the decided effects shaded flat, all effects forced on), alternated, after one counted
    /// frame checked against the CPU twin per pixel.
    #[arg(long, value_enum, default_value_t = crate::render::TraceDevice::Cpu)]
    pub device: crate::render::TraceDevice,
    /// The generated dense scene's BVH: `bake` the tree a bake stores (what users trace),
    /// `testkit` the runtime testkit's simple binned SAH builder.
    #[arg(long, value_enum, default_value_t = Tree::Bake)]
    pub tree: Tree,
    /// Embree's build quality (`rtcSetSceneBuildQuality`): `high` builds with spatial splits
    /// (a triangle may sit in several leaves), `medium` a binned SAH tree like the file's.
    #[arg(long, value_enum, default_value_t = EmbreeQuality::High)]
    pub embree_quality: EmbreeQuality,
    /// The view [default: the file's first camera, or the generated scene's]: what the rays
    /// and frames see, and so which effects a frame needs.
    #[command(flatten)]
    pub view: crate::picture::CameraArgs,
}

/// Which builder makes the generated scene's BVH (`--tree`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Tree {
    Bake,
    Testkit,
}

/// Embree's build quality (`--embree-quality`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum EmbreeQuality {
    Low,
    Medium,
    High,
}

/// The scene under test: the file (its first camera the default view) and what it is.
struct Bench {
    file: OperatorFile,
    what: String,
}

pub fn run(b: &RenderBench, out: &mut dyn Write) -> Result<()> {
    if b.runs == 0 {
        bail!("--runs must be at least 1");
    }
    let (w, h) = crate::bench_operators::parse_size(&b.size)
        .with_context(|| format!("--size {}: expected WxH like 1920x1080", b.size))?;
    let bench = match &b.file {
        Some(path) => from_file(path)?,
        None => dense(b.tree)?,
    };
    if let (Some(name), None) = (&b.view.camera, &b.file) {
        bail!("--camera {name}: the generated scene has no named cameras");
    }
    let tracer = Tracer::new(&bench.file)?;
    // The file's first camera (the generated scene's own), its fields overridden by the flags.
    let camera = b.view.camera(
        &tracer,
        b.file
            .as_deref()
            .unwrap_or(Path::new("the generated scene")),
    )?;
    let view = View::new(&camera, w as u32, h as u32)?;
    if b.device == crate::render::TraceDevice::Gpu {
        writeln!(
            out,
            "scene: {} ({} triangles); {w}x{h}; {} rounds",
            bench.what,
            tracer.triangle_count(),
            b.runs
        )?;
        return gpu_frames(&tracer, &bench, &view, (w as u32, h as u32), b, out)
            .map_err(|e| anyhow::anyhow!("--device gpu: {e}"));
    }
    writeln!(
        out,
        "scene: {} ({} triangles); {w}x{h}; ray kinds on 1 thread, {} rounds",
        bench.what,
        tracer.triangle_count(),
        b.runs
    )?;
    let primary = tracer.primary_rays(&view, w as u32, h as u32);
    let hits = tracer.closest_hits(&primary);
    let shadow = tracer.shadow_rays(&primary, &hits);
    let secondary = tracer.reflected_rays(&primary, &hits);
    // The display triangles the tracer's BVH holds (the fan of the display faces).
    let tris: Vec<[[f32; 3]; 3]> = bench.file.faces().triangles().map(|(_, t)| t).collect();
    let embree = baseline::Baseline::build(&tris, b.embree_quality)?;
    if let Some(bvh) = &bench.file.display.bvh {
        writeln!(
            out,
            "tree: SAH cost {:.1} (inner 1, triangle 1, relative to the root box), {} nodes; \
             embree: build quality {:?}",
            sah_cost(bvh),
            bvh.nodes.len(),
            b.embree_quality
        )?;
    }
    writeln!(
        out,
        "{:<10} {:>9} {:>14} {:>14} {:>22} {:>9} {:>15}",
        "kind",
        "rays",
        "tracer Mray/s",
        "embree Mray/s",
        "tracer/embree (range)",
        "disagree",
        "f64 sides with"
    )?;
    for (kind, rays) in [
        ("primary", &primary),
        ("shadow", &shadow),
        ("secondary", &secondary),
    ] {
        if rays.is_empty() {
            writeln!(out, "{kind:<10} {:>9}", 0)?;
            continue;
        }
        let closest = kind != "shadow";
        let m = measure(&tracer, &embree, rays, closest, b.runs);
        let arbiter = m.disagree.as_ref().map_or("n/a".into(), |d| {
            let (t, e) = arbitrate(&tris, rays, d);
            format!("{t} tr / {e} em")
        });
        let (e_rate, ratio) = match (m.embree_s, m.ratios.is_empty()) {
            (Some(e), false) => {
                let (lo, mid, hi) = spread(m.ratios.clone());
                (
                    format!("{:.2}", rays.len() as f64 / e / 1e6),
                    format!("{mid:.2} ({lo:.2}-{hi:.2})"),
                )
            }
            _ => ("n/a".into(), "n/a".into()),
        };
        writeln!(
            out,
            "{kind:<10} {:>9} {:>14.2} {:>14} {:>22} {:>9} {:>15}",
            rays.len(),
            rays.len() as f64 / m.tracer_s / 1e6,
            e_rate,
            ratio,
            m.disagree
                .as_ref()
                .map_or("n/a".into(), |d| d.rays.len().to_string()),
            arbiter
        )?;
    }
    if !baseline::AVAILABLE {
        writeln!(
            out,
            "embree: not in this build (run scripts/setup-embree.sh, then build with --features embree)"
        )?;
    }
    frames(&tracer, &bench, &view, (w as u32, h as u32), b, out)
}

/// Medians of one ray kind.
struct Measured {
    tracer_s: f64,
    embree_s: Option<f64>,
    /// Per round: Embree's time / the tracer's (the tracer's rate over Embree's).
    ratios: Vec<f64>,
    /// Rays where the two disagree (hit or miss, or the triangle at a distinct distance).
    disagree: Option<Disagreement>,
}

/// One side's answer for a ray: the hit's (distance, triangle id); for a shadow ray, blocked
/// as `(0, u32::MAX)`; `None`: a miss (not blocked).
type Said = Option<(f32, u32)>;

/// The rays on which the tracer and Embree answered differently, with both answers.
struct Disagreement {
    rays: Vec<usize>,
    /// Per ray of `rays`: (tracer, Embree).
    answers: Vec<(Said, Said)>,
}

/// Most disagreeing rays [`arbitrate`] checks (each against every triangle in f64).
const ARBITRATE_MAX: usize = 1000;

/// Of the disagreeing rays (the first [`ARBITRATE_MAX`]), on how many a brute-force test of
/// every triangle in f64 agrees with the tracer, and on how many with Embree: the same
/// triangle, or a hit within 1e-6 relative of the f64 distance, or the same miss (for shadow
/// rays: the same blocked or not).
fn arbitrate(tris: &[[[f32; 3]; 3]], rays: &RayBatch, d: &Disagreement) -> (usize, usize) {
    let (mut tracer, mut embree) = (0, 0);
    for (&i, &(a, b)) in d.rays.iter().zip(&d.answers).take(ARBITRATE_MAX) {
        let truth = nearest_f64(tris, rays.origins[i], rays.dirs[i], rays.t_max[i]);
        let agrees = |x: Said| match (x, truth) {
            (None, None) => true,
            (Some((0.0, u32::MAX)), Some(_)) => true, // a shadow ray blocked
            (Some((t, id)), Some((tt, tid))) => {
                id == tid || (f64::from(t) - tt).abs() <= 1e-6 * tt.abs()
            }
            _ => false,
        };
        tracer += agrees(a) as usize;
        embree += agrees(b) as usize;
    }
    (tracer, embree)
}

/// The nearest triangle the ray `o + t d`, `0 < t < t_max`, hits, in f64 (Möller–Trumbore with
/// the f32 data widened; edges count as inside): (distance, id).
fn nearest_f64(tris: &[[[f32; 3]; 3]], o: [f32; 3], d: [f32; 3], t_max: f32) -> Option<(f64, u32)> {
    let v = |p: [f32; 3]| p.map(f64::from);
    let (o, d) = (v(o), v(d));
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let mut best: Option<(f64, u32)> = None;
    for (id, t) in tris.iter().enumerate() {
        let (a, b, c) = (v(t[0]), v(t[1]), v(t[2]));
        let (e1, e2) = (sub(b, a), sub(c, a));
        let p = cross(d, e2);
        let det = dot(e1, p);
        if det == 0.0 {
            continue;
        }
        let s = sub(o, a);
        let u = dot(s, p) / det;
        let q = cross(s, e1);
        let w = dot(d, q) / det;
        let dist = dot(e2, q) / det;
        if u < 0.0 || w < 0.0 || u + w > 1.0 || dist <= 0.0 || dist >= f64::from(t_max) {
            continue;
        }
        if best.is_none_or(|(bt, _)| dist < bt) {
            best = Some((dist, id as u32));
        }
    }
    best
}

fn measure(
    tracer: &Tracer,
    embree: &baseline::Baseline,
    rays: &RayBatch,
    closest: bool,
    runs: usize,
) -> Measured {
    let (mut ts, mut es, mut ratios) = (Vec::new(), Vec::new(), Vec::new());
    let mut disagree = None;
    for round in 0..runs {
        let time_tracer = || {
            let start = Instant::now();
            let answer = if closest {
                Answer::Hits(tracer.closest_hits(rays))
            } else {
                Answer::Blocked(tracer.occluded(rays))
            };
            (start.elapsed().as_secs_f64(), answer)
        };
        let time_embree = || {
            let start = Instant::now();
            let answer = embree.answer(rays, closest);
            answer.map(|a| (start.elapsed().as_secs_f64(), a))
        };
        // Alternate which goes first.
        let (t, e) = if round % 2 == 0 {
            let t = time_tracer();
            (t, time_embree())
        } else {
            let e = time_embree();
            (time_tracer(), e)
        };
        ts.push(t.0);
        if let Some((e_s, e_answer)) = e {
            es.push(e_s);
            ratios.push(e_s / t.0);
            disagree = Some(t.1.differences(&e_answer));
        }
    }
    Measured {
        tracer_s: spread(ts).1,
        embree_s: (!es.is_empty()).then(|| spread(es).1),
        ratios,
        disagree,
    }
}

/// What a batch answered.
pub(crate) enum Answer {
    Hits(Vec<Option<TraceHit>>),
    #[cfg_attr(not(feature = "embree"), allow(dead_code))]
    Embree(Vec<Option<(f32, u32)>>),
    Blocked(Vec<bool>),
}

impl Answer {
    /// The rays on which `self` (the tracer's) and `other` (Embree's) differ.
    fn differences(&self, other: &Answer) -> Disagreement {
        let mut d = Disagreement {
            rays: Vec::new(),
            answers: Vec::new(),
        };
        let blocked = |x: bool| x.then_some((0.0, u32::MAX));
        match (self, other) {
            (Answer::Hits(a), Answer::Embree(b)) => {
                for (i, (a, b)) in a.iter().zip(b).enumerate() {
                    let differ = match (a, b) {
                        (Some(a), Some((t, id))) => {
                            a.triangle != *id && (a.t - t).abs() > 1e-4 * t.max(1e-6)
                        }
                        (None, None) => false,
                        _ => true,
                    };
                    if differ {
                        d.rays.push(i);
                        d.answers.push((a.as_ref().map(|h| (h.t, h.triangle)), *b));
                    }
                }
            }
            (Answer::Blocked(a), Answer::Blocked(b)) => {
                for (i, (a, b)) in a.iter().zip(b).enumerate() {
                    if a != b {
                        d.rays.push(i);
                        d.answers.push((blocked(*a), blocked(*b)));
                    }
                }
            }
            _ => {}
        }
        d
    }
}

/// (min, median, max).
fn spread(mut v: Vec<f64>) -> (f64, f64, f64) {
    v.sort_by(f64::total_cmp);
    (v[0], v[v.len() / 2], v[v.len() - 1])
}

/// Whole frames on all threads: the decided effects against all forced on, alternated.
fn frames(
    tracer: &Tracer,
    bench: &Bench,
    view: &View,
    (w, h): (u32, u32),
    b: &RenderBench,
    out: &mut dyn Write,
) -> Result<()> {
    let threads = b
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let radiosity: Vec<[f32; 3]> = (0..bench.file.n as usize)
        .map(|i| [(i % 7) as f32, 1.0, 0.5])
        .collect();
    let groups = vec![1.0f32; bench.file.lights.len()];
    let lighting = Lighting {
        radiosity: &radiosity,
        group_intensities: &groups,
        direct: None,
    };
    let decision = tracer.decide(view, &lighting)?;
    let (mut decided, mut all, mut ratios) = (Vec::new(), Vec::new(), Vec::new());
    let mut counts = None;
    for round in 0..b.runs {
        let mut time = |effects: Effects| -> Result<f64> {
            let start = Instant::now();
            let (_, c) = tracer.render_with(view, &lighting, effects, w, h, threads)?;
            if effects == decision.effects {
                counts = Some(c);
            }
            Ok(start.elapsed().as_secs_f64())
        };
        let (d, a) = if round % 2 == 0 {
            let d = time(decision.effects)?;
            (d, time(Effects::all())?)
        } else {
            let a = time(Effects::all())?;
            (time(decision.effects)?, a)
        };
        decided.push(d);
        all.push(a);
        ratios.push(a / d);
    }
    let c = counts.unwrap_or_default();
    let d = spread(decided).1;
    let rays = (c.primary + c.shadow + c.secondary) as f64;
    let (lo, mid, hi) = spread(ratios);
    write!(
        out,
        "frames on {threads} thread(s), effects decided:\n{}",
        decision.text()
    )?;
    writeln!(
        out,
        "  {:.1} ms per frame ({:.2} Mray/s: {} primary, {} shadow, {} secondary); all effects \
         forced on: {:.1} ms, x{mid:.2} ({lo:.2}-{hi:.2}) the decided frame's time",
        d * 1e3,
        rays / d / 1e6,
        c.primary,
        c.shadow,
        c.secondary,
        spread(all).1 * 1e3
    )?;
    Ok(())
}

/// Whole frames of the GPU tracer: a counted frame of the decided effects compared with the CPU
/// twin per pixel, then uncounted frames (primary rays only, decided, all effects forced on)
/// alternated; wall time per frame, the tiles' submissions and the image's readback included.
fn gpu_frames(
    tracer: &Tracer,
    bench: &Bench,
    view: &View,
    (w, h): (u32, u32),
    b: &RenderBench,
    out: &mut dyn Write,
) -> std::result::Result<(), Box<dyn std::error::Error + Send + Sync>> {
    use lrr_runtime::gpu::{Gpu, GpuOptions, GpuTracer};
    let gpu = Gpu::new(&GpuOptions::default())?;
    writeln!(out, "GPU: {}", gpu.describe())?;
    if gpu.is_cpu() {
        writeln!(
            out,
            "note: a CPU adapter (lavapipe): the rates below are correctness-only and say \
             nothing about a GPU"
        )?;
    }
    let mut gt = GpuTracer::new(&gpu, tracer)?;
    let radiosity: Vec<[f32; 3]> = (0..bench.file.n as usize)
        .map(|i| [(i % 7) as f32, 1.0, 0.5])
        .collect();
    let groups = vec![1.0f32; bench.file.lights.len()];
    let lighting = Lighting {
        radiosity: &radiosity,
        group_intensities: &groups,
        direct: None,
    };
    let buffer = gt.upload_radiosity(&radiosity)?;
    let decision = tracer.decide(view, &lighting)?;
    let decided = decision.effects;
    let primary = Effects {
        highlights: false,
        secondary: false,
        ..decided
    };
    let mut kinds = vec![
        ("primary only", primary),
        ("decided", decided),
        ("all forced on", Effects::all()),
    ];
    if decided.smooth {
        // What smooth shading costs: the same frames shading flat element values.
        let flat = |e: Effects| Effects { smooth: false, ..e };
        kinds.push(("primary, flat", flat(primary)));
        kinds.push(("decided, flat", flat(decided)));
    }
    // One counted frame of each, and the decided one against the CPU twin.
    let mut counts = Vec::new();
    for (i, &(_, effects)) in kinds.iter().enumerate() {
        let (image, report) = gt.render_with(view, &buffer, &groups, effects, true, w, h)?;
        counts.push(report.rays.unwrap_or_default());
        if i == 1 {
            let threads = b.threads.unwrap_or(0);
            let (cpu, _) = tracer.render(view, &lighting, w, h, threads)?;
            let off = image
                .pixels
                .iter()
                .zip(&cpu.pixels)
                .filter(|(g, c)| {
                    (0..3).any(|ch| (g[ch] - c[ch]).abs() > 1e-4 * c[ch].abs().max(1e-6))
                })
                .count();
            writeln!(
                out,
                "against the CPU twin: {off} of {} pixels differ by more than 1e-4 relative",
                w * h
            )?;
        }
    }
    // One untimed frame of each first: the uncounted pipelines are built on first use.
    for &(_, effects) in &kinds {
        gt.render_with(view, &buffer, &groups, effects, false, w, h)?;
    }
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); kinds.len()];
    let mut gpu_times: Vec<Vec<f64>> = vec![Vec::new(); kinds.len()];
    for round in 0..b.runs {
        for i in 0..kinds.len() {
            // Alternate the order round by round.
            let k = if round % 2 == 0 {
                i
            } else {
                kinds.len() - 1 - i
            };
            let start = Instant::now();
            let (_, report) = gt.render_with(view, &buffer, &groups, kinds[k].1, false, w, h)?;
            times[k].push(start.elapsed().as_secs_f64());
            gpu_times[k].extend(report.gpu.map(|d| d.as_secs_f64()));
        }
    }
    write!(out, "GPU frames, effects decided:\n{}", decision.text())?;
    if decided.smooth {
        // Per round, each smooth frame over its flat twin (alternated in the same round).
        for (smooth, flat, what) in [(0, 3, "primary only"), (1, 4, "decided")] {
            let ratios = times[smooth]
                .iter()
                .zip(&times[flat])
                .map(|(s, f)| s / f)
                .collect();
            let (lo, mid, hi) = spread(ratios);
            writeln!(
                out,
                "smooth shading ({what}: the smooth-vertex pass, mean value coordinates at every \
                 hit): x{mid:.2} ({lo:.2}-{hi:.2}) the flat frame's time, per round"
            )?;
        }
    }
    writeln!(
        out,
        "wall: a frame from its first upload to the image read back (per-frame buffers, tiles, \
         readback); GPU: the trace dispatches alone by timestamp queries ({})",
        if gpu_times.iter().all(Vec::is_empty) {
            "not available on this adapter"
        } else {
            "summed over the frame's tiles"
        }
    )?;
    writeln!(
        out,
        "{:<14} {:>11} {:>11} {:>11} {:>9} {:>10} {:>11} {:>8} {:>12} {:>13}",
        "frame",
        "primary",
        "shadow",
        "secondary",
        "wall ms",
        "Mray/s",
        "range ms",
        "GPU ms",
        "GPU Mray/s",
        "primary Gray/s"
    )?;
    for ((((name, _), c), t), g) in kinds.iter().zip(&counts).zip(times).zip(gpu_times) {
        let (lo, mid, hi) = spread(t);
        let rays = (c.primary + c.shadow + c.secondary) as f64;
        let gpu = (!g.is_empty()).then(|| spread(g).1);
        let opt =
            |v: Option<f64>, digits: usize| v.map_or("-".to_owned(), |v| format!("{v:.digits$}"));
        writeln!(
            out,
            "{name:<14} {:>11} {:>11} {:>11} {:>9.2} {:>10.1} {:>11} {:>8} {:>12} {:>13}",
            c.primary,
            c.shadow,
            c.secondary,
            mid * 1e3,
            rays / mid / 1e6,
            format!("{:.1}-{:.1}", lo * 1e3, hi * 1e3),
            opt(gpu.map(|g| g * 1e3), 3),
            opt(gpu.map(|g| rays / g / 1e6), 1),
            opt(gpu.map(|g| c.primary as f64 / g / 1e9), 3),
        )?;
    }
    Ok(())
}

fn from_file(path: &Path) -> Result<Bench> {
    let file = OperatorFile::read(path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    Ok(Bench {
        what: path.display().to_string(),
        file,
    })
}

/// The surface area heuristic's cost of a binary BVH relative to its root box: the expected
/// node visits plus triangle tests of a ray through the root box (the quality of a tree apart
/// from how it is traversed).
fn sah_cost(bvh: &lrr_formats::Bvh) -> f64 {
    let area = |n: &lrr_formats::BvhNode| {
        let d: Vec<f64> = (0..3)
            .map(|a| f64::from(n.max[a] - n.min[a]).max(0.0))
            .collect();
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    };
    let Some(root) = bvh.nodes.first() else {
        return 0.0;
    };
    let total: f64 = bvh
        .nodes
        .iter()
        .map(|n| area(n) * if n.count > 0 { f64::from(n.count) } else { 1.0 })
        .sum();
    total / area(root).max(f64::MIN_POSITIVE)
}

/// The dense sphere scene as display triangles, each split in 4, in an operator file made in
/// memory (the operator itself is synthetic: the bench traces, it does not relight).
fn dense(tree: Tree) -> Result<Bench> {
    let scene = procedural::dense_sphere(procedural::MAX_SPHERE_SUBDIVISIONS)
        .build("dense", Path::new("."))?;
    let mut tris = Vec::new();
    for f in &scene.faces {
        let v: Vec<[f32; 3]> = f
            .polygon
            .vertices()
            .iter()
            .map(|p| p.as_vec3().to_array())
            .collect();
        for i in 1..v.len() - 1 {
            split4(&[v[0], v[i], v[i + 1]], &mut tris);
        }
    }
    let n = tris.len();
    let mut file = testkit::synthetic::file(n, 1, 1, Precision::F32, Layout::Factored, 1)?;
    file.order = (0..n as u32).collect();
    let mut vertices = Vec::with_capacity(12 * n);
    let mut normals = Vec::with_capacity(3 * n);
    for t in &tris {
        t.iter().for_each(|p| vertices.extend(p));
        vertices.extend([0.0; 3]);
        let (a, b) = (
            glam::Vec3::from(t[1]) - glam::Vec3::from(t[0]),
            glam::Vec3::from(t[2]) - glam::Vec3::from(t[0]),
        );
        normals.extend(a.cross(b).normalize_or_zero().to_array());
    }
    file.geometry = Geometry {
        vertex_count: vec![3; n],
        vertices,
        normals,
    };
    let light = |name: &str, position| PointLight {
        name: name.into(),
        position,
        intensity: [0.2; 3],
        group: PointLight::FIXED,
    };
    file.display = Display {
        point_lights: vec![
            light("top", [0.5, 0.9, 0.5]),
            light("corner", [0.15, 0.8, 0.85]),
        ],
        bvh: Some(match tree {
            Tree::Bake => lrr_precompute::display::bvh(&file.geometry),
            Tree::Testkit => testkit::bvh::build(&file.geometry),
        }),
        cameras: vec![Camera {
            name: "bench".into(),
            eye: [0.5, 0.55, 0.98],
            target: [0.5, 0.4, 0.5],
            up: [0.0, 1.0, 0.0],
            fov_y_deg: 60.0,
        }],
        ..Display::default()
    };
    Ok(Bench {
        what: format!(
            "dense sphere (subdivision 6, triangles split in 4) in its room, {} BVH",
            match tree {
                Tree::Bake => "the bake's",
                Tree::Testkit => "testkit SAH",
            }
        ),
        file,
    })
}

/// The 4 triangles of `t` split at its edge midpoints.
fn split4(t: &[[f32; 3]; 3], out: &mut Vec<[[f32; 3]; 3]>) {
    let mid = |a: [f32; 3], b: [f32; 3]| {
        [
            0.5 * (a[0] + b[0]),
            0.5 * (a[1] + b[1]),
            0.5 * (a[2] + b[2]),
        ]
    };
    let [a, b, c] = *t;
    let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
    out.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
}

/// Embree, or nothing in a build without it.
mod baseline {
    use super::{Answer, EmbreeQuality, RayBatch};
    use anyhow::Result;

    #[cfg(feature = "embree")]
    pub const AVAILABLE: bool = true;
    #[cfg(not(feature = "embree"))]
    pub const AVAILABLE: bool = false;

    pub struct Baseline {
        #[cfg(feature = "embree")]
        scene: crate::bench_render_embree::EmbreeScene,
    }

    impl Baseline {
        #[cfg(feature = "embree")]
        pub fn build(tris: &[[[f32; 3]; 3]], quality: EmbreeQuality) -> Result<Self> {
            use embree4_sys::RTCBuildQuality as Q;
            let quality = match quality {
                EmbreeQuality::Low => Q::LOW,
                EmbreeQuality::Medium => Q::MEDIUM,
                EmbreeQuality::High => Q::HIGH,
            };
            Ok(Baseline {
                scene: crate::bench_render_embree::EmbreeScene::build(tris, quality)?,
            })
        }

        #[cfg(not(feature = "embree"))]
        pub fn build(_tris: &[[[f32; 3]; 3]], _quality: EmbreeQuality) -> Result<Self> {
            Ok(Baseline {})
        }

        #[cfg(feature = "embree")]
        pub fn answer(&self, rays: &RayBatch, closest: bool) -> Option<Answer> {
            Some(if closest {
                Answer::Embree(self.scene.closest_hits(rays))
            } else {
                Answer::Blocked(self.scene.occluded(rays))
            })
        }

        #[cfg(not(feature = "embree"))]
        pub fn answer(&self, _rays: &RayBatch, _closest: bool) -> Option<Answer> {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{Disagreement, arbitrate, nearest_f64};
    use lrr_runtime::trace::RayBatch;

    /// Two unit right triangles at z = 1 and z = 2 over the origin's corner.
    fn tris() -> Vec<[[f32; 3]; 3]> {
        let at = |z: f32| [[0.0, 0.0, z], [1.0, 0.0, z], [0.0, 1.0, z]];
        vec![at(2.0), at(1.0)]
    }

    #[test]
    fn the_f64_arbiter_finds_the_nearest_triangle_and_sides_with_the_right_answer() {
        let tris = tris();
        let up = [0.0, 0.0, 1.0];
        assert_eq!(
            nearest_f64(&tris, [0.2, 0.2, 0.0], up, 10.0),
            Some((1.0, 1))
        );
        // Far end before the first triangle; outside both; an edge point counts as inside.
        assert_eq!(nearest_f64(&tris, [0.2, 0.2, 0.0], up, 0.5), None);
        assert_eq!(nearest_f64(&tris, [0.8, 0.8, 0.0], up, 10.0), None);
        assert_eq!(
            nearest_f64(&tris, [0.5, 0.5, 0.0], up, 10.0),
            Some((1.0, 1))
        );
        let rays = RayBatch {
            origins: vec![[0.2, 0.2, 0.0], [0.8, 0.8, 0.0]],
            dirs: vec![up; 2],
            t_max: vec![10.0; 2],
        };
        // Ray 0: the tracer says triangle 1 at 1, Embree triangle 0 at 2; ray 1: the tracer
        // a miss, Embree a hit; the blocked form (0, MAX) counts as any hit.
        let d = Disagreement {
            rays: vec![0, 1],
            answers: vec![
                (Some((1.0, 1)), Some((2.0, 0))),
                (None, Some((0.0, u32::MAX))),
            ],
        };
        assert_eq!(arbitrate(&tris, &rays, &d), (2, 0));
    }
}
