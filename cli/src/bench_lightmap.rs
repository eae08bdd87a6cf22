//! `lrr bench lightmap`: the runtime's lightmap fill (`lrr_runtime::Lightmap`, issue #34)
//! against its memory roofline. A fill reads the sample table (texel, four smooth vertices and
//! weights per sample), the dilation table and the smooth vertices' rows, and writes every
//! texel: [`Lightmap::fill_bytes`]. The roofline is a plain pass over as many bytes on the same
//! threads, split the same way (each thread reads its share of a table of the table's size and
//! writes its share of an atlas of the atlas's size), so the ratio says how close the fill comes
//! to what moving its bytes costs on this machine. Fill and roofline are alternated over rounds;
//! medians are reported.
//!
//! `--device gpu`: the GPU fill (`lrr_runtime::gpu::GpuLightmap`, into an `rgba16float` texture
//! from the evaluator's radiosity buffer, no readback) against the frame it follows: frames of
//! the GPU evaluator alone and frames with the fill, each submitted back to back and waited for
//! at the end, alternated over rounds; the fill's share of the frame is the difference. A smooth
//! lightmap that can be filled in tiles (`GpuFill::Tiles`, the default) is also filled in
//! passes (`GpuFill::Passes`: the smooth-vertex pass, then the texels), the two alternated in
//! the same rounds, so that their ratio comes from one run. On a CPU adapter (lavapipe) these
//! numbers say nothing about a GPU.

use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Result, bail};
use clap::Args;
use lrr_runtime::{Lightmap, Operator};
use serde::Serialize;

use crate::emission::Device;

#[derive(Debug, Args)]
pub struct LightmapBench {
    /// Operator file (with lightmap coordinates: baked by this version).
    pub file: PathBuf,
    /// A square atlas of N×N texels over the file's coordinates [default: the file's atlas].
    #[arg(long, value_name = "N")]
    pub size: Option<usize>,
    /// Threads of the fill [default: all cores].
    #[arg(long)]
    pub threads: Option<usize>,
    /// Fills per round.
    #[arg(long, default_value_t = 20)]
    pub frames: usize,
    /// Rounds (fill, roofline, fill, … alternated).
    #[arg(long, default_value_t = 5)]
    pub rounds: usize,
    /// Where the fill runs: the CPU (the runtime's threads) or the GPU (after the GPU
    /// evaluator's frame; meaningless on lavapipe); auto: the GPU when one is usable.
    #[arg(long, value_enum, default_value_t = Device::Cpu)]
    pub device: Device,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// What a GPU run measured (medians over rounds of the per-frame time).
#[derive(Debug, Clone, Serialize)]
pub struct GpuLightmapRow {
    pub width: usize,
    pub height: usize,
    pub samples: usize,
    pub dilated: usize,
    pub adapter: String,
    /// Seconds of the evaluator's frame alone.
    pub frame_s: f64,
    /// By timestamp queries (`None` without them): the median GPU seconds of the evaluator's
    /// frame in a burst of 40 back to back after a warm-up.
    pub gpu_frame_s: Option<f64>,
    /// Each way of filling measured: the default first.
    pub fills: Vec<GpuFillRow>,
}

/// One way of filling in a [`GpuLightmapRow`].
#[derive(Debug, Clone, Serialize)]
pub struct GpuFillRow {
    /// "tiles" or "passes".
    pub fill: String,
    /// Seconds of the evaluator's frame with the lightmap fill after it.
    pub frame_fill_s: f64,
    /// `(frame_fill_s - frame_s) / frame_s`: what the fill adds to the frame.
    pub fill_share: f64,
    /// By timestamp queries: the median GPU seconds of the fill in a burst of 40, and its
    /// ratio to the frame's: what the fill adds to the frame on the GPU itself.
    pub gpu_fill_s: Option<f64>,
    pub gpu_fill_share: Option<f64>,
    /// Tiles: workgroups, smooth vertices computed over all tiles, and in the file.
    pub tiles: Option<u32>,
    pub tile_vertices: Option<u32>,
    pub smooth_vertices: Option<u32>,
}

/// What one run measured (medians over rounds of the per-frame time).
#[derive(Debug, Clone, Serialize)]
pub struct LightmapRow {
    pub width: usize,
    pub height: usize,
    pub samples: usize,
    pub dilated: usize,
    pub threads: usize,
    /// Bytes a fill moves at least ([`Lightmap::fill_bytes`]).
    pub bytes: usize,
    /// Seconds of a whole fill, of its samples' pass and of its dilation.
    pub fill_s: f64,
    pub samples_s: f64,
    pub dilate_s: f64,
    /// Seconds of the roofline's pass over the same bytes.
    pub roofline_s: f64,
    /// `bytes / fill_s` and `bytes / roofline_s`, GB/s.
    pub fill_gbps: f64,
    pub roofline_gbps: f64,
    /// `roofline_s / fill_s`: the share of the roofline the fill reaches.
    pub of_roofline: f64,
}

pub fn run(a: &LightmapBench, out: &mut dyn Write) -> Result<()> {
    if a.frames == 0 || a.rounds == 0 {
        bail!("--frames and --rounds must be at least 1");
    }
    let op = Operator::load(&a.file).map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?;
    let mut map = match a.size {
        Some(n) => {
            let padding = op
                .file()
                .display
                .lightmap
                .as_ref()
                .and_then(|l| l.atlas)
                .map_or(2, |atlas| atlas.padding as usize);
            Lightmap::with_size(op.file(), n, n, padding, None)?
        }
        None => Lightmap::new(op.file(), None)?,
    };
    let threads = match a.threads {
        Some(0) | None => std::thread::available_parallelism().map_or(1, |n| n.get()),
        Some(t) => t,
    };
    map.set_threads(threads);
    if a.device != Device::Cpu {
        return run_gpu(a, &op, &map, out);
    }
    let b = op.evaluate_baked();
    let texels = map.width() * map.height();
    let mut atlas = vec![[0.0f32; 3]; texels];
    let table = vec![1u32; (map.fill_bytes() - 12 * texels).div_ceil(4)];
    let mut plain = vec![[0.0f32; 3]; texels];
    // One untimed fill and pass: pages touched, caches warm.
    map.fill(&b, &mut atlas)?;
    roofline(&table, &mut plain, threads);
    let (mut fill, mut samples, mut dilate, mut line) = (vec![], vec![], vec![], vec![]);
    for _ in 0..a.rounds {
        let t = Instant::now();
        for _ in 0..a.frames {
            map.fill(&b, &mut atlas)?;
        }
        fill.push(t.elapsed().as_secs_f64() / a.frames as f64);
        let t = Instant::now();
        for _ in 0..a.frames {
            roofline(&table, &mut plain, threads);
        }
        line.push(t.elapsed().as_secs_f64() / a.frames as f64);
        let (mut s, mut d) = (0.0, 0.0);
        for _ in 0..a.frames {
            let t = Instant::now();
            map.fill_samples(&b, &mut atlas)?;
            s += t.elapsed().as_secs_f64();
            let t = Instant::now();
            map.dilate(&mut atlas)?;
            d += t.elapsed().as_secs_f64();
        }
        samples.push(s / a.frames as f64);
        dilate.push(d / a.frames as f64);
    }
    let bytes = map.fill_bytes();
    let (fill_s, roofline_s) = (median(&mut fill), median(&mut line));
    let row = LightmapRow {
        width: map.width(),
        height: map.height(),
        samples: map.sample_count(),
        dilated: map.dilated_count(),
        threads,
        bytes,
        fill_s,
        samples_s: median(&mut samples),
        dilate_s: median(&mut dilate),
        roofline_s,
        fill_gbps: bytes as f64 / fill_s / 1e9,
        roofline_gbps: bytes as f64 / roofline_s / 1e9,
        of_roofline: roofline_s / fill_s,
    };
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&row)?)?;
        return Ok(());
    }
    writeln!(
        out,
        "lightmap {}×{}: {} samples, {} dilated texels, {:.1} MB per fill, {} threads",
        row.width,
        row.height,
        row.samples,
        row.dilated,
        row.bytes as f64 / 1e6,
        row.threads
    )?;
    writeln!(
        out,
        "fill      {:8.3} ms  {:6.2} GB/s  (samples {:.3} ms, dilation {:.3} ms)",
        1e3 * row.fill_s,
        row.fill_gbps,
        1e3 * row.samples_s,
        1e3 * row.dilate_s
    )?;
    writeln!(
        out,
        "roofline  {:8.3} ms  {:6.2} GB/s  (a plain pass over the same bytes)",
        1e3 * row.roofline_s,
        row.roofline_gbps
    )?;
    writeln!(out, "fill / roofline: {:.2}", row.of_roofline)?;
    Ok(())
}

/// Each of `threads` threads reads its share of `table` and writes its share of `texels`.
fn roofline(table: &[u32], texels: &mut [[f32; 3]], threads: usize) {
    let read = table.len().div_ceil(threads).max(1);
    let write = texels.len().div_ceil(threads).max(1);
    std::thread::scope(|s| {
        for (part, out) in table.chunks(read).zip(texels.chunks_mut(write)) {
            s.spawn(move || {
                let sum = part.iter().fold(0u32, |a, &x| a.wrapping_add(x));
                let v = std::hint::black_box(sum) as f32;
                out.fill([v; 3]);
            });
        }
    });
    std::hint::black_box(texels);
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The GPU fill against the frame it follows (see the module docs).
fn run_gpu(a: &LightmapBench, op: &Operator, map: &Lightmap, out: &mut dyn Write) -> Result<()> {
    use lrr_runtime::gpu::{Gpu, GpuEvaluator, GpuFill, GpuLightmap, GpuOptions};
    use lrr_runtime::{Rgb, RgbMut};
    let gpu = match (a.device, Gpu::new(&GpuOptions::default())) {
        (_, Ok(gpu)) => gpu,
        (Device::Auto, Err(e)) => {
            eprintln!("lrr: note: no usable GPU ({e}); benchmarking the CPU");
            let cpu = LightmapBench {
                file: a.file.clone(),
                device: Device::Cpu,
                ..*a
            };
            return run(&cpu, out);
        }
        (_, Err(e)) => return Err(e.into()),
    };
    let mut eval = GpuEvaluator::new(&gpu, op)?;
    let mut fills = vec![GpuLightmap::new(&gpu, op.file(), map)?];
    if fills[0].fill_kind() == GpuFill::Tiles {
        fills.push(GpuLightmap::with_fill(
            &gpu,
            op.file(),
            map,
            GpuFill::Passes,
        )?);
    }
    let emission = op.baked_emission();
    let mut b = vec![[0.0f32; 3]; op.n()];
    // One frame of each, waited for: pipelines made, pages touched.
    eval.evaluate(Rgb::triples(&emission), RgbMut::triples(&mut b))?;
    for fill in &fills {
        fill.fill(eval.radiosity_buffer())?;
    }
    eval.wait()?;
    let mut alone = vec![];
    let mut with = vec![vec![]; fills.len()];
    for _ in 0..a.rounds {
        let t = Instant::now();
        for _ in 0..a.frames {
            eval.submit(Rgb::triples(&emission))?;
        }
        eval.wait()?;
        alone.push(t.elapsed().as_secs_f64() / a.frames as f64);
        for (fill, times) in fills.iter().zip(&mut with) {
            let t = Instant::now();
            for _ in 0..a.frames {
                eval.submit(Rgb::triples(&emission))?;
                fill.fill(eval.radiosity_buffer())?;
            }
            eval.wait()?;
            times.push(t.elapsed().as_secs_f64() / a.frames as f64);
        }
    }
    let frame_s = median(&mut alone);
    let gpu_median = |times: Option<Vec<std::time::Duration>>| {
        times.map(|t| {
            let mut s: Vec<f64> = t.iter().map(|d| d.as_secs_f64()).collect();
            median(&mut s)
        })
    };
    let gpu_frame_s = gpu_median(eval.burst(Rgb::triples(&emission), 40)?.map(|b| b.frames));
    let mut rows = Vec::new();
    for (fill, times) in fills.iter().zip(&mut with) {
        let frame_fill_s = median(times);
        let gpu_fill_s = gpu_median(fill.burst(eval.radiosity_buffer(), 40)?);
        let counts = fill.tile_counts();
        rows.push(GpuFillRow {
            fill: match fill.fill_kind() {
                GpuFill::Tiles => "tiles",
                _ => "passes",
            }
            .into(),
            frame_fill_s,
            fill_share: (frame_fill_s - frame_s) / frame_s,
            gpu_fill_s,
            gpu_fill_share: gpu_frame_s.zip(gpu_fill_s).map(|(f, l)| l / f),
            tiles: counts.map(|c| c.tiles),
            tile_vertices: counts.map(|c| c.vertices),
            smooth_vertices: counts.map(|c| c.smooth_vertices),
        });
    }
    let row = GpuLightmapRow {
        width: map.width(),
        height: map.height(),
        samples: map.sample_count(),
        dilated: map.dilated_count(),
        adapter: gpu.describe(),
        frame_s,
        gpu_frame_s,
        fills: rows,
    };
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&row)?)?;
        return Ok(());
    }
    writeln!(
        out,
        "lightmap {}×{} on {}: {} samples, {} dilated texels",
        row.width, row.height, row.adapter, row.samples, row.dilated
    )?;
    writeln!(out, "frame          {:8.3} ms", 1e3 * row.frame_s)?;
    for f in &row.fills {
        writeln!(
            out,
            "frame + fill   {:8.3} ms  (the fill adds {:.1}%; {})",
            1e3 * f.frame_fill_s,
            100.0 * f.fill_share,
            f.fill
        )?;
    }
    for f in &row.fills {
        if let (Some(frame), Some(l), Some(share)) =
            (row.gpu_frame_s, f.gpu_fill_s, f.gpu_fill_share)
        {
            writeln!(
                out,
                "GPU time (timestamps, bursts of 40): frame {:.3} ms, fill {:.3} ms ({:.1}% of \
                 the frame; {})",
                1e3 * frame,
                1e3 * l,
                100.0 * share,
                f.fill
            )?;
        }
        if let (Some(tiles), Some(v), Some(s)) = (f.tiles, f.tile_vertices, f.smooth_vertices) {
            writeln!(
                out,
                "tiles: {tiles} workgroups computing {v} smooth vertices a fill ({:.2}× the \
                 file's {s})",
                f64::from(v) / f64::from(s.max(1))
            )?;
        }
    }
    if gpu.is_cpu() {
        writeln!(
            out,
            "note: {} is a CPU adapter: these times say nothing about a GPU",
            gpu.adapter_name()
        )?;
    }
    Ok(())
}
