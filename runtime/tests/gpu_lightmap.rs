//! The GPU lightmap fill (`lrr_runtime::gpu::GpuLightmap`: `lightmap_tiles.wgsl`, or
//! `smooth.wgsl` then `lightmap.wgsl`) against the CPU's
//! (`Lightmap::fill`) of the same frame, on whatever adapter wgpu finds (CI: lavapipe, with
//! `LRR_EXPECT_ADAPTER=llvmpipe`; no adapter is a failure, never a skip).
//!
//! Tolerance, relative: the texture holds binary16, rounded to nearest or (Vulkan leaves it to
//! the implementation; lavapipe and the H200's driver do) toward zero, so within 2⁻¹⁰ ≈
//! 9.77e-4, and the GPU sums in f32 where the CPU sums in f64 (a few 1e-7): [`REL`] (measured:
//! 9.70e-4 smooth, 8.30e-4 flat, on both). The coverage is exact: alpha 1 on every texel the
//! CPU writes (samples and dilation rings), 0 and black on every other.

#![cfg(feature = "gpu")]

use lrr_runtime::gpu::{Gpu, GpuEvaluator, GpuFill, GpuLightmap, GpuOptions};
use lrr_runtime::testkit::faces::{lightmapped, lightmapped_grid};
use lrr_runtime::{Lightmap, LightmapValues, Operator, Rgb, RgbMut};

const REL: f32 = 1e-3;

fn gpu() -> Gpu {
    let gpu = Gpu::new(&GpuOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    if let Ok(want) = std::env::var("LRR_EXPECT_ADAPTER") {
        assert!(
            gpu.adapter_name()
                .to_lowercase()
                .contains(&want.to_lowercase()),
            "LRR_EXPECT_ADAPTER={want}, but the adapter is {}",
            gpu.describe()
        );
    }
    gpu
}

/// The texels `got` (the GPU's, RGBA) against the CPU's fill `want` of the same frame.
fn assert_fill(got: &[[f32; 4]], want: &[[f32; 3]], cpu: &Lightmap, what: &str) {
    let mut written = vec![false; want.len()];
    for s in cpu.samples() {
        written[s.texel] = true;
    }
    let (mut covered, mut worst) = (0, 0.0f32);
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        let is_written = written[i] || w.iter().any(|&v| v != 0.0);
        if is_written {
            covered += 1;
            assert_eq!(g[3], 1.0, "{what} texel {i}: alpha");
            for c in 0..3 {
                if w[c] > 1e-4 {
                    worst = worst.max((g[c] - w[c]).abs() / w[c]);
                }
                assert!(
                    (g[c] - w[c]).abs() <= REL * w[c].abs() + 1e-7,
                    "{what} texel {i}: GPU {g:?} against CPU {w:?}"
                );
            }
        } else {
            assert_eq!(*g, [0.0; 4], "{what} texel {i} is not the lightmap's");
        }
    }
    assert_eq!(covered, cpu.sample_count() + cpu.dilated_count(), "{what}");
    eprintln!("{what}: largest relative difference {worst:.3e}");
}

/// Each fill equals the CPU's of its frame, also when fills alternate between two evaluators'
/// radiosity buffers (the fill keeps the bindings of the last buffer it read).
#[test]
fn the_gpu_fill_is_the_cpu_fill_in_half_floats() {
    let gpu = gpu();
    // The strip over part of a 97 × 61 atlas, 3 rings of dilation.
    let file = lightmapped(|x, y| [0.1 + x / 2.5, 0.05 + y * 0.7], 97, 61, 3);
    let op = Operator::from_file(file.clone()).unwrap();
    let frame = |emission: [[f32; 3]; 2]| {
        let mut eval = GpuEvaluator::new(&gpu, &op).unwrap();
        let mut b = vec![[0.0f32; 3]; 2];
        eval.evaluate(Rgb::triples(&emission), RgbMut::triples(&mut b))
            .unwrap();
        (eval, b)
    };
    let (first, b_first) = frame([[1.0, 0.5, 0.25], [0.0, 0.25, 2.0]]);
    let (second, b_second) = frame([[0.0, 3.0, 0.5], [1.5, 0.0, 0.0]]);
    for (values, fill) in [
        (LightmapValues::Smooth, GpuFill::Tiles),
        (LightmapValues::Smooth, GpuFill::Passes),
        (LightmapValues::Flat, GpuFill::Auto),
    ] {
        let mut cpu = Lightmap::new(&file, Some(values)).unwrap();
        let mut want_first = vec![[f32::NAN; 3]; 97 * 61];
        cpu.fill(&b_first, &mut want_first).unwrap();
        let mut want_second = want_first.clone();
        cpu.fill(&b_second, &mut want_second).unwrap();
        assert_ne!(want_first, want_second);
        let map = GpuLightmap::with_fill(&gpu, &file, &cpu, fill).unwrap();
        assert_eq!(map.size(), (97, 61));
        let kind = map.fill_kind();
        assert_eq!(kind == GpuFill::Tiles, fill == GpuFill::Tiles);
        for (i, (eval, want)) in [
            (&first, &want_first),
            (&second, &want_second),
            (&first, &want_first),
        ]
        .into_iter()
        .enumerate()
        {
            map.fill(eval.radiosity_buffer()).unwrap();
            let got = map.read_texels().unwrap();
            assert_fill(
                &got,
                want,
                &cpu,
                &format!("{values:?} in {kind:?}, fill {i}"),
            );
        }
        assert!(cpu.dilated_count() > 0 && cpu.sample_count() > 1000);
    }
}

/// A dense grid (40 000 elements over a 128² atlas, about 2.4 elements a texel): tiles whose
/// texels read over 128 smooth vertices (more than a workgroup's 128 lanes, so lanes compute
/// several), and 16 × 8 blocks cut into several tiles at the 256-vertex limit; both fills
/// equal the CPU's. A flat lightmap cannot
/// be filled in tiles: an error that says what to do.
#[test]
fn dense_tiles_are_the_cpu_fill() {
    let gpu = gpu();
    let file = lightmapped_grid(40_000, 16, 128, 128, 2, 3);
    let op = Operator::from_file(file.clone()).unwrap();
    let emission: Vec<[f32; 3]> = (0..op.n())
        .map(|e| [(e % 7) as f32, (e % 5) as f32 * 0.5, 1.0 + (e % 3) as f32])
        .collect();
    let mut eval = GpuEvaluator::new(&gpu, &op).unwrap();
    let mut b = vec![[0.0f32; 3]; op.n()];
    eval.evaluate(Rgb::triples(&emission), RgbMut::triples(&mut b))
        .unwrap();
    let mut cpu = Lightmap::new(&file, None).unwrap();
    let mut want = vec![[f32::NAN; 3]; 128 * 128];
    cpu.fill(&b, &mut want).unwrap();
    for fill in [GpuFill::Tiles, GpuFill::Passes] {
        let map = GpuLightmap::with_fill(&gpu, &file, &cpu, fill).unwrap();
        if let Some(c) = map.tile_counts() {
            eprintln!("{c:?}");
            // Blocks of 16 × 8 texels that the lightmap writes.
            let mut blocks: Vec<usize> = (want.iter().enumerate())
                .filter(|(_, w)| w.iter().any(|&v| v != 0.0))
                .map(|(i, _)| (i / 128 / 8) * 8 + i % 128 / 16)
                .collect();
            blocks.dedup();
            blocks.sort_unstable();
            blocks.dedup();
            assert!(c.largest > 128 && c.tiles as usize > blocks.len(), "{c:?}");
        }
        map.fill(eval.radiosity_buffer()).unwrap();
        let got = map.read_texels().unwrap();
        assert_fill(&got, &want, &cpu, &format!("dense grid in {fill:?}"));
    }
    let flat = Lightmap::new(&file, Some(LightmapValues::Flat)).unwrap();
    let e = GpuLightmap::with_fill(&gpu, &file, &flat, GpuFill::Tiles)
        .err()
        .expect("a flat lightmap in tiles is refused")
        .to_string();
    assert!(
        e.contains("cannot be filled in tiles") && e.contains("passes"),
        "{e}"
    );
}

/// A tile table over a binding (here a cap of `GpuOptions::max_table_bytes`): `Auto` fills in
/// passes where they fit, and equals the CPU's fill; `Tiles` is refused with advice that
/// names the passes; under a cap that neither fits, both are refused, naming the CPU's fill.
#[test]
fn tiles_over_a_binding_fall_back_to_passes() {
    let file = lightmapped_grid(40_000, 16, 128, 128, 2, 3);
    let op = Operator::from_file(file.clone()).unwrap();
    let cpu = Lightmap::new(&file, None).unwrap();
    let gpu_capped = |cap: u64| {
        let options = GpuOptions {
            max_table_bytes: Some(cap),
            ..GpuOptions::default()
        };
        Gpu::new(&options).unwrap_or_else(|e| panic!("{e}"))
    };
    // The largest cap at which tiles are refused and passes fit: tiles hold SMOOTH's weights
    // as (element, weight) pairs, 8 bytes where the passes' two tables take 4 each.
    let mut found = None;
    let mut cap = 4u64 << 20;
    while cap > 4096 && found.is_none() {
        let gpu = gpu_capped(cap);
        let tiles = GpuLightmap::with_fill(&gpu, &file, &cpu, GpuFill::Tiles);
        let passes = GpuLightmap::with_fill(&gpu, &file, &cpu, GpuFill::Passes);
        if let (Err(e), Ok(_)) = (&tiles, &passes) {
            let e = e.to_string();
            assert!(e.contains("fill it in passes"), "{e}");
            found = Some(gpu);
        }
        cap = cap * 4 / 5;
    }
    let gpu = found.expect("a cap that refuses tiles and fits passes");
    let map = GpuLightmap::new(&gpu, &file, &cpu).unwrap();
    assert_eq!(map.fill_kind(), GpuFill::Passes);
    let emission: Vec<[f32; 3]> = (0..op.n()).map(|e| [1.0, (e % 3) as f32, 0.5]).collect();
    let mut eval = GpuEvaluator::new(&gpu, &op).unwrap();
    let mut b = vec![[0.0f32; 3]; op.n()];
    eval.evaluate(Rgb::triples(&emission), RgbMut::triples(&mut b))
        .unwrap();
    let mut want = vec![[f32::NAN; 3]; 128 * 128];
    let mut cpu = cpu;
    cpu.fill(&b, &mut want).unwrap();
    map.fill(eval.radiosity_buffer()).unwrap();
    assert_fill(
        &map.read_texels().unwrap(),
        &want,
        &cpu,
        "passes under a cap",
    );
    let e = GpuLightmap::new(&gpu_capped(4096), &file, &cpu)
        .err()
        .expect("nothing fits 4 KiB")
        .to_string();
    assert!(
        e.contains("over the 4096-byte limit") && e.contains("Lightmap::fill"),
        "{e}"
    );
}

#[test]
fn a_radiosity_buffer_too_small_is_an_error() {
    let gpu = gpu();
    let file = lightmapped(|x, y| [x / 2.0, y], 16, 8, 1);
    let cpu = Lightmap::new(&file, None).unwrap();
    let map = GpuLightmap::new(&gpu, &file, &cpu).unwrap();
    let small = gpu
        .device()
        .create_buffer(&lrr_runtime::gpu::wgpu::BufferDescriptor {
            label: None,
            size: 16,
            usage: lrr_runtime::gpu::wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
    let e = map.fill(&small).unwrap_err().to_string();
    assert!(
        e.contains("holds 16 bytes") && e.contains("24 it needs"),
        "{e}"
    );
}
