//! The GPU path against the CPU path, on whatever adapter wgpu finds (CI: lavapipe, with
//! `LRR_EXPECT_ADAPTER=llvmpipe`). No adapter is a failure with the list of adapters, never a
//! silent skip: a machine without a driver runs `scripts/setup-gpu.sh` first.
//!
//! Tolerances: the GPU sums in f32 where the CPU path computes `X` and `Z` in f64, and adds in
//! another order; with the non-negative terms of a physical operator both are within a few
//! 1e-6 relative of the exact value of the same stored matrix, so they agree within 1e-5.
//! Binary16 operators are compared with the CPU's binary16 path (the same stored values).

#![cfg(feature = "gpu")]

mod common;

use std::sync::OnceLock;

use common::emission;
use lrr_runtime::gpu::{self, Gpu, GpuError, GpuEvaluator, GpuOptions, Reduce, Storage, wgpu};
use lrr_runtime::testkit::synthetic;
use lrr_runtime::{Layout, Operator, Precision, Rgb, RgbMut};

/// A device with `options`; fails loudly without an adapter, or on the wrong one.
fn open(options: &GpuOptions) -> Gpu {
    let gpu = Gpu::new(options).unwrap_or_else(|e| panic!("{e}"));
    if let Ok(want) = std::env::var("LRR_EXPECT_ADAPTER") {
        assert!(
            gpu.adapter_name()
                .to_lowercase()
                .contains(&want.to_lowercase()),
            "LRR_EXPECT_ADAPTER={want}, but the adapter is {}; adapters found: {:?}",
            gpu.describe(),
            gpu::adapters()
        );
    }
    gpu
}

fn gpu() -> &'static Gpu {
    static GPU: OnceLock<Gpu> = OnceLock::new();
    GPU.get_or_init(|| {
        let gpu = open(&GpuOptions::default());
        eprintln!("GPU tests on {}", gpu.describe());
        gpu
    })
}

/// Largest `|gpu - cpu| / |cpu|` (values are non-negative radiosities).
fn worst(gpu: &[[f32; 3]], cpu: &[[f32; 3]]) -> f64 {
    let mut worst = 0.0f64;
    for (g, c) in gpu.iter().zip(cpu) {
        for ch in 0..3 {
            let (g, c) = (f64::from(g[ch]), f64::from(c[ch]));
            assert!(g.is_finite(), "GPU gave {g}");
            let err = (g - c).abs();
            if err > 0.0 {
                worst = worst.max(err / c.abs().max(1e-30));
            }
        }
    }
    worst
}

/// One frame of `op` on the CPU and on `gpu`, compared; returns the worst relative error.
fn compare(gpu: &Gpu, op: &Operator, seed: u64) -> f64 {
    let e = emission(op.n(), seed);
    let mut cpu = vec![[0.0f32; 3]; op.n()];
    op.evaluator(2)
        .unwrap()
        .evaluate(Rgb::triples(&e), RgbMut::triples(&mut cpu))
        .unwrap();
    let mut eval = GpuEvaluator::new(gpu, op).unwrap();
    let mut out = vec![[f32::NAN; 3]; op.n()];
    eval.evaluate(Rgb::triples(&e), RgbMut::triples(&mut out))
        .unwrap();
    let w = worst(&out, &cpu);
    assert!(w <= 1e-5, "{}: worst relative {w:e}", eval.describe());
    w
}

#[test]
fn every_layout_channel_count_and_precision_matches_the_cpu() {
    for layout in [Layout::Factored, Layout::PlainYk] {
        for channels in [1, 3] {
            for precision in [Precision::F32, Precision::F16] {
                // k = 53: rows padded to 56 entries.
                let op = synthetic::operator(3001, 53, channels, precision, layout, 7).unwrap();
                let w = compare(gpu(), &op, 3);
                eprintln!("{layout:?} {channels} ch {precision:?}: worst {w:.1e}");
            }
        }
    }
}

/// Every binary16 loader and row reduction the adapter supports, checked and unchecked.
#[test]
fn every_kernel_variant_matches_the_cpu() {
    let base = gpu();
    let has = |f: wgpu::Features| base.device().features().contains(f);
    let mut loaders = vec![Storage::F16Bits];
    if has(wgpu::Features::SHADER_F16) {
        // llvmpipe grants SHADER_F16_IN_F32 with SHADER_F16 only.
        loaders.extend([Storage::F16, Storage::F16Unpack]);
    }
    let mut reduces = vec![Reduce::Workgroup];
    if has(wgpu::Features::SUBGROUP) {
        reduces.push(Reduce::Subgroup);
    }
    let f32_op = synthetic::operator(2000, 200, 3, Precision::F32, Layout::Factored, 1).unwrap();
    let f16_op = synthetic::operator(2000, 200, 3, Precision::F16, Layout::Factored, 1).unwrap();
    for &loader in &loaders {
        for &reduce in &reduces {
            for bounds_checks in [false, true] {
                let options = GpuOptions {
                    f16_loader: Some(loader),
                    reduce: Some(reduce),
                    bounds_checks,
                    ..GpuOptions::default()
                };
                let gpu = open(&options);
                compare(&gpu, &f16_op, 5);
                compare(&gpu, &f32_op, 5);
            }
        }
    }
}

/// The gather's tuning knobs: lanes per row, rows per lane and iteration, the workgroup cap
/// (down to one workgroup walking every row), both row reductions (alternating over the
/// caps), on chunks whose row counts are no multiple of
/// the rows a workgroup takes per iteration (so the clamped tail rows are exercised), in every
/// layout the gather specialises (factored, plain grey, plain RGB per block).
#[test]
fn lanes_rows_and_workgroup_caps_match_the_cpu() {
    let ops = [
        synthetic::operator(2003, 61, 3, Precision::F32, Layout::Factored, 21).unwrap(),
        synthetic::operator(1999, 37, 3, Precision::F16, Layout::Factored, 22).unwrap(),
        synthetic::operator(1501, 29, 1, Precision::F32, Layout::PlainYk, 23).unwrap(),
        synthetic::operator(1501, 29, 3, Precision::F32, Layout::PlainYk, 24).unwrap(),
    ];
    let mut reduces = vec![Reduce::Workgroup];
    if gpu().device().features().contains(wgpu::Features::SUBGROUP) {
        reduces.push(Reduce::Subgroup);
    }
    for row_lanes in [1, 4, 8, 32] {
        for gather_rows in [1, 2, 3, 4] {
            for (gather_groups, &reduce) in [Some(1), Some(7), None]
                .into_iter()
                .zip(reduces.iter().cycle())
            {
                let options = GpuOptions {
                    row_lanes: Some(row_lanes),
                    gather_rows: Some(gather_rows),
                    gather_groups,
                    reduce: Some(reduce),
                    max_chunk_bytes: Some(40_000),
                    ..GpuOptions::default()
                };
                let gpu = open(&options);
                for op in &ops {
                    let eval = GpuEvaluator::new(&gpu, op).unwrap();
                    assert_eq!(eval.gather_rows(), gather_rows);
                    assert!(eval.chunks() >= 2, "{}", eval.describe());
                    drop(eval);
                    compare(&gpu, op, u64::from(row_lanes * 10 + gather_rows));
                }
            }
        }
    }
    for (options, what) in [
        (
            GpuOptions {
                gather_rows: Some(5),
                ..GpuOptions::default()
            },
            "gather rows",
        ),
        (
            GpuOptions {
                row_lanes: Some(3),
                ..GpuOptions::default()
            },
            "lanes per row",
        ),
        (
            GpuOptions {
                gather_groups: Some(0),
                ..GpuOptions::default()
            },
            "gather workgroups",
        ),
        (
            GpuOptions {
                gather_groups: Some(65_536),
                ..GpuOptions::default()
            },
            "gather workgroups",
        ),
    ] {
        let Err(e) = Gpu::new(&options) else {
            panic!("{what}: accepted");
        };
        assert!(e.to_string().contains(what), "{e}");
    }
}

#[test]
fn light_groups_match_the_cpu() {
    for layout in [Layout::Factored, Layout::PlainYk] {
        let op = synthetic::operator(2500, 40, 3, Precision::F32, layout, 9).unwrap();
        assert_eq!(op.light_groups().len(), 3);
        let mut eval = GpuEvaluator::new(gpu(), &op).unwrap();
        let mut cpu_eval = op.evaluator(1).unwrap();
        for a in [[1.0, 0.0, 2.5], [0.0, 0.0, 0.0], [0.3, 7.0, 1.0]] {
            let (mut cpu, mut out) = (vec![[0.0f32; 3]; op.n()], vec![[f32::NAN; 3]; op.n()]);
            cpu_eval
                .evaluate_groups(&a, RgbMut::triples(&mut cpu))
                .unwrap();
            eval.evaluate_groups(&a, RgbMut::triples(&mut out)).unwrap();
            let w = worst(&out, &cpu);
            assert!(w <= 1e-5, "{layout:?} {a:?}: {w:e}");
        }
    }
}

#[test]
fn planar_buffers_match_interleaved_ones() {
    let op = synthetic::operator(1000, 30, 3, Precision::F32, Layout::Factored, 2).unwrap();
    let e = emission(op.n(), 8);
    let planes: [Vec<f32>; 3] = std::array::from_fn(|c| e.iter().map(|v| v[c]).collect());
    let mut eval = GpuEvaluator::new(gpu(), &op).unwrap();
    let mut inter = vec![[0.0f32; 3]; op.n()];
    eval.evaluate(Rgb::triples(&e), RgbMut::triples(&mut inter))
        .unwrap();
    let (mut r, mut g, mut b) = (vec![0.0; op.n()], vec![0.0; op.n()], vec![0.0; op.n()]);
    let input = Rgb::Planar([&planes[0], &planes[1], &planes[2]]);
    eval.evaluate(input, RgbMut::Planar([&mut r, &mut g, &mut b]))
        .unwrap();
    for i in 0..op.n() {
        assert_eq!([r[i], g[i], b[i]], inter[i]);
    }
}

/// Chunks forced small on a small operator: odd chunk sizes, several per frame.
#[test]
fn chunked_operators_match_the_cpu() {
    let options = GpuOptions {
        max_chunk_bytes: Some(100_000),
        ..GpuOptions::default()
    };
    let gpu = open(&options);
    for (layout, precision) in [
        (Layout::Factored, Precision::F32),
        (Layout::Factored, Precision::F16),
        (Layout::PlainYk, Precision::F32),
    ] {
        let op = synthetic::operator(3001, 45, 3, precision, layout, 4).unwrap();
        let eval = GpuEvaluator::new(&gpu, &op).unwrap();
        assert!(eval.chunks() >= 3, "{}", eval.describe());
        compare(&gpu, &op, 6);
    }
}

/// Operators larger than lavapipe's 128 MiB per binding: the adapter's own limit splits them.
#[test]
fn operators_over_128_mib_are_chunked_and_match_the_cpu() {
    for (n, precision) in [(160_000, Precision::F32), (320_000, Precision::F16)] {
        let op = synthetic::operator(n, 224, 3, precision, Layout::Factored, 11).unwrap();
        assert!(op.matrix_bytes() > 128 << 20);
        let eval = GpuEvaluator::new(gpu(), &op).unwrap();
        let limit = gpu().device().limits().max_storage_buffer_binding_size;
        if limit < op.matrix_bytes() as u64 {
            assert!(eval.chunks() >= 2, "{}", eval.describe());
        }
        drop(eval);
        let w = compare(gpu(), &op, 12);
        eprintln!(
            "n = {n}, {precision:?}, {} MiB: worst {w:.1e}",
            op.matrix_bytes() >> 20
        );
    }
}

/// The papers' hybrid (sums and cores on the CPU, the gather on the GPU) gives the CPU's frame:
/// every layout, channel count and precision, a chunked operator, an albedo edit, and frames
/// submitted back to back (each frame's `Z` upload must not disturb the previous gather).
#[test]
fn hybrid_frames_match_the_cpu() {
    let check = |op: &Operator, gpu: &Gpu, rho: Option<&[[f32; 3]]>| {
        let e = emission(op.n(), 9);
        let mut cpu = op.evaluator(2).unwrap();
        let mut eval = GpuEvaluator::new(gpu, op).unwrap();
        if let Some(rho) = rho {
            cpu.set_reflectance(rho).unwrap();
            eval.set_reflectance(rho).unwrap();
        }
        let (mut want, mut got) = (vec![[0.0f32; 3]; op.n()], vec![[f32::NAN; 3]; op.n()]);
        cpu.evaluate(Rgb::triples(&e), RgbMut::triples(&mut want))
            .unwrap();
        // A different frame first, submitted and not waited for.
        eval.submit_hybrid(Rgb::triples(&emission(op.n(), 4)))
            .unwrap();
        eval.evaluate_hybrid(Rgb::triples(&e), RgbMut::triples(&mut got))
            .unwrap();
        let w = worst(&got, &want);
        assert!(
            w <= 1e-5,
            "hybrid, {}: worst relative {w:e}",
            eval.describe()
        );
        assert!(eval.last_timing().is_some());
    };
    for layout in [Layout::Factored, Layout::PlainYk] {
        for channels in [1, 3] {
            for precision in [Precision::F32, Precision::F16] {
                let op = synthetic::operator(2100, 37, channels, precision, layout, 5).unwrap();
                check(&op, gpu(), None);
            }
        }
    }
    let op = synthetic::operator(1500, 25, 3, Precision::F32, Layout::Factored, 3).unwrap();
    check(&op, gpu(), Some(&vec![[0.6, 0.3, 0.2]; op.n()]));
    let small_chunks = open(&GpuOptions {
        max_chunk_bytes: Some(64 * 1024),
        ..GpuOptions::default()
    });
    let op = synthetic::operator(3000, 40, 3, Precision::F16, Layout::Factored, 8).unwrap();
    check(&op, &small_chunks, None);
}

#[test]
fn albedo_edits_match_the_cpu() {
    let op = synthetic::operator(1500, 25, 1, Precision::F32, Layout::Factored, 3).unwrap();
    let rho = vec![[0.6, 0.3, 0.2]; op.n()];
    let mut cpu = op.evaluator(1).unwrap();
    cpu.set_reflectance(&rho).unwrap();
    let mut eval = GpuEvaluator::new(gpu(), &op).unwrap();
    eval.set_reflectance(&rho).unwrap();
    let e = emission(op.n(), 2);
    let (mut want, mut got) = (vec![[0.0f32; 3]; op.n()], vec![[0.0f32; 3]; op.n()]);
    cpu.evaluate(Rgb::triples(&e), RgbMut::triples(&mut want))
        .unwrap();
    eval.evaluate(Rgb::triples(&e), RgbMut::triples(&mut got))
        .unwrap();
    assert!(worst(&got, &want) <= 1e-5);
}

#[test]
fn bad_input_gets_the_cpu_errors_and_writes_nothing() {
    let op = synthetic::operator(100, 5, 3, Precision::F32, Layout::Factored, 1).unwrap();
    let mut eval = GpuEvaluator::new(gpu(), &op).unwrap();
    let mut cpu = op.evaluator(1).unwrap();
    let mut e = vec![[0.0f32; 3]; op.n()];
    e[17] = [1.0, f32::NAN, 0.0];
    let mut out = vec![[0.0f32; 3]; op.n()];
    let got = eval.evaluate(Rgb::triples(&e), RgbMut::triples(&mut out));
    let want = cpu.evaluate(Rgb::triples(&e), RgbMut::triples(&mut out));
    assert_eq!(got, Err(GpuError::Runtime(want.clone().unwrap_err())));
    assert!(out.iter().flatten().all(|v| *v == 0.0));
    // The hybrid refuses it in its CPU segment sums, with the same error.
    let got = eval.evaluate_hybrid(Rgb::triples(&e), RgbMut::triples(&mut out));
    assert_eq!(got, Err(GpuError::Runtime(want.unwrap_err())));
    assert!(out.iter().flatten().all(|v| *v == 0.0));
    let got = eval.evaluate_groups(&[1.0], RgbMut::triples(&mut out));
    let want = cpu.evaluate_groups(&[1.0], RgbMut::triples(&mut out));
    assert_eq!(got, Err(GpuError::Runtime(want.unwrap_err())));
    let short = eval.evaluate(Rgb::triples(&e[1..]), RgbMut::triples(&mut out));
    assert!(
        short
            .unwrap_err()
            .to_string()
            .contains("must hold 3 values")
    );
}

/// A renderer's path: frames submitted without readback; the storage buffer holds the last.
#[test]
fn submitted_frames_stay_on_the_gpu() {
    let op = synthetic::operator(800, 20, 3, Precision::F32, Layout::Factored, 5).unwrap();
    let mut eval = GpuEvaluator::new(gpu(), &op).unwrap();
    let (e1, e2) = (emission(op.n(), 1), emission(op.n(), 2));
    let mut want = vec![[0.0f32; 3]; op.n()];
    eval.evaluate(Rgb::triples(&e2), RgbMut::triples(&mut want))
        .unwrap();
    eval.submit(Rgb::triples(&e1)).unwrap();
    eval.submit(Rgb::triples(&e2)).unwrap();
    let device = gpu().device();
    let size = eval.radiosity_buffer().size();
    let copy = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    encoder.copy_buffer_to_buffer(eval.radiosity_buffer(), 0, &copy, 0, size);
    gpu().queue().submit([encoder.finish()]);
    copy.map_async(wgpu::MapMode::Read, .., |r| r.unwrap());
    eval.wait().unwrap();
    let bytes = copy.get_mapped_range(..).unwrap();
    let got: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
        .collect();
    assert_eq!(got, want.as_flattened());
}

#[test]
fn timings_are_reported() {
    let op = synthetic::operator(5000, 64, 3, Precision::F32, Layout::Factored, 5).unwrap();
    let mut eval = GpuEvaluator::new(gpu(), &op).unwrap();
    let e = op.baked_emission();
    let mut out = vec![[0.0f32; 3]; op.n()];
    eval.evaluate(Rgb::triples(&e), RgbMut::triples(&mut out))
        .unwrap();
    let t = eval.last_timing().unwrap();
    assert!(t.end_to_end.as_nanos() > 0);
    if gpu()
        .device()
        .features()
        .contains(wgpu::Features::TIMESTAMP_QUERY)
    {
        let g = t.gpu.expect("timestamps on an adapter that has them");
        assert!(g <= t.end_to_end, "{t:?}");
        assert!(eval.read_pass().unwrap().gpu.is_some());
        // A burst: as many timed frames as asked (up to 42), each read kernel as often, every
        // time positive; the frames leave the same radiosity as a single frame.
        let start = std::time::Instant::now();
        let burst = eval
            .burst(Rgb::triples(&e), 7)
            .unwrap()
            .expect("timestamps");
        let wall = start.elapsed();
        assert_eq!((burst.frames.len(), burst.reads.len()), (7, 7));
        for d in burst.frames.iter().chain(&burst.reads) {
            assert!(d.as_nanos() > 0 && *d < wall, "{burst:?}");
        }
        assert!(
            wall >= std::time::Duration::from_millis(300),
            "the warm-up: {wall:?}"
        );
        let capped = eval
            .burst(Rgb::triples(&e), 1000)
            .unwrap()
            .expect("timestamps");
        assert_eq!(capped.frames.len(), 42);
        let mut again = vec![[0.0f32; 3]; op.n()];
        eval.evaluate(Rgb::triples(&e), RgbMut::triples(&mut again))
            .unwrap();
        assert_eq!(again, out);
    } else {
        assert!(eval.burst(Rgb::triples(&e), 3).unwrap().is_none());
    }
}

#[test]
fn a_missing_adapter_is_an_error_listing_the_adapters_found() {
    let options = GpuOptions {
        adapter: Some("no such adapter".into()),
        ..GpuOptions::default()
    };
    let e = Gpu::new(&options).unwrap_err();
    let GpuError::NoAdapter(message) = &e else {
        panic!("{e:?}");
    };
    assert!(
        message.contains("apt-get install mesa-vulkan-drivers libvulkan1"),
        "{message}"
    );
    assert!(message.contains(gpu().adapter_name()), "{message}");
}
