//! The GPU ray tracer (`lrr_runtime::gpu::GpuTracer`, `trace.wgsl`) against its CPU twin
//! (`lrr_runtime::trace::Tracer`), per pixel, on whatever adapter wgpu finds (CI: lavapipe, with
//! `LRR_EXPECT_ADAPTER=llvmpipe`; no adapter is a failure, never a skip).
//!
//! Tolerance: both run the same f32 operations in the same order, but a GPU compiler may fuse a
//! multiply and an add, and WGSL's division, `sqrt` and `pow` need not round correctly, so a
//! pixel whose rays hit the same triangles agrees to a few ulp per operation: within
//! [`REL`] = 1e-4 relative (measured on lavapipe: see each test's printout). A ray that passes
//! within rounding of an edge or a silhouette may hit another triangle on the GPU than on the
//! CPU, and then its pixel differs by whatever the two surfaces show; those pixels are counted
//! and bounded by [`MAX_OFF_FRACTION`] of the image. On a CPU adapter (lavapipe) the images
//! agree much more closely, and the tests hold it to that: no pixel off, 1e-6 relative (measured:
//! bit-identical without highlights, 2.2e-7 with them, from `pow`; bit-identical with lights that
//! are not surfaces, their shadow rays counted alike).
//!
//! Smooth shading: the CPU twin reconstructs in f64 (`Reconstruction`: vertex sums, mean value
//! coordinates), the GPU in f32 (`smooth.wgsl`, `trace.wgsl`; the mirrors' tests in
//! `lrr-shaders` bound each step: the vertex sums by their rounding-error bound, the weights
//! within 8 ε). The same [`REL`] and [`MAX_OFF_FRACTION`] hold on any adapter; on a CPU adapter
//! no pixel is off and every pixel is within [`SMOOTH_CPU_ADAPTER_REL`].

#![cfg(feature = "gpu")]

use std::sync::OnceLock;

use lrr_formats::{
    Camera, Display, Geometry, Layout, Material, Materials, OperatorFile, PointLight, Precision,
};
use lrr_runtime::gpu::{self, Gpu, GpuEvaluator, GpuOptions, GpuTracer};
use lrr_runtime::lights::{DirectLighting, Light};
use lrr_runtime::testkit;
use lrr_runtime::trace::{DirectShading, Image, Lighting, Tracer, View};
use lrr_runtime::{Operator, Rgb};

/// Per-pixel relative agreement of a pixel whose rays hit what the CPU's hit.
const REL: f64 = 1e-4;
/// Pixels allowed beyond [`REL`] (a different hit near an edge): 0.5% of the image.
const MAX_OFF_FRACTION: f64 = 0.005;
/// Flat shading on a CPU adapter: every pixel within this.
const FLAT_CPU_ADAPTER_REL: f64 = 1e-6;
/// Smooth shading on a CPU adapter (f32 against the CPU twin's f64): every pixel within this
/// (measured on lavapipe: 2.9e-7 diffuse, 3.0e-6 in a ray tree with clamped vertices).
const SMOOTH_CPU_ADAPTER_REL: f64 = 1e-5;

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
        eprintln!("GPU tracer tests on {}", gpu.describe());
        gpu
    })
}

/// A quad or a triangle (counter-clockwise seen from its normal; `count` corners) and its
/// material.
struct Face {
    corners: [[f32; 3]; 4],
    count: u8,
    material: u32,
}

/// `nu × nv` quads tiling the parallelogram `o + s u + t v`, facing `u × v`.
fn grid(faces: &mut Vec<Face>, o: [f32; 3], u: [f32; 3], v: [f32; 3], nu: u32, nv: u32, m: u32) {
    let at = |s: f32, t: f32| std::array::from_fn(|c| o[c] + s * u[c] + t * v[c]);
    for j in 0..nv {
        for i in 0..nu {
            let (s0, s1) = (i as f32 / nu as f32, (i + 1) as f32 / nu as f32);
            let (t0, t1) = (j as f32 / nv as f32, (j + 1) as f32 / nv as f32);
            faces.push(Face {
                corners: [at(s0, t0), at(s1, t0), at(s1, t1), at(s0, t1)],
                count: 4,
                material: m,
            });
        }
    }
}

/// An axis-aligned box from `lo` to `hi`, faces outwards, `cells` quads a side.
fn block(faces: &mut Vec<Face>, lo: [f32; 3], hi: [f32; 3], cells: u32, m: u32) {
    let [x0, y0, z0] = lo;
    let [dx, dy, dz] = [hi[0] - x0, hi[1] - y0, hi[2] - z0];
    let c = cells;
    grid(faces, [x0, y0, z0], [0.0, dy, 0.0], [dx, 0.0, 0.0], c, c, m); // -z
    grid(
        faces,
        [x0, y0, hi[2]],
        [dx, 0.0, 0.0],
        [0.0, dy, 0.0],
        c,
        c,
        m,
    ); // +z
    grid(faces, [x0, y0, z0], [0.0, 0.0, dz], [0.0, dy, 0.0], c, c, m); // -x
    grid(
        faces,
        [hi[0], y0, z0],
        [0.0, dy, 0.0],
        [0.0, 0.0, dz],
        c,
        c,
        m,
    ); // +x
    grid(faces, [x0, y0, z0], [dx, 0.0, 0.0], [0.0, 0.0, dz], c, c, m); // -y
    grid(
        faces,
        [x0, hi[1], z0],
        [0.0, 0.0, dz],
        [dx, 0.0, 0.0],
        c,
        c,
        m,
    ); // +y
}

/// A closed room (walls facing inwards, `cells` quads a side) from 0 to 4 on each axis; the wall
/// at x = 0 has material `left`, the rest material 0.
fn room(faces: &mut Vec<Face>, cells: u32, left: u32) {
    let s = 4.0;
    let c = cells;
    grid(faces, [0.0; 3], [s, 0.0, 0.0], [0.0, s, 0.0], c, c, 0); // back z = 0, +z
    grid(faces, [0.0, 0.0, s], [0.0, s, 0.0], [s, 0.0, 0.0], c, c, 0); // front z = 4, -z
    grid(faces, [0.0; 3], [0.0, s, 0.0], [0.0, 0.0, s], c, c, left); // x = 0, +x
    grid(faces, [s, 0.0, 0.0], [0.0, 0.0, s], [0.0, s, 0.0], c, c, 0); // x = 4, -x
    grid(faces, [0.0; 3], [0.0, 0.0, s], [s, 0.0, 0.0], c, c, 0); // floor, +y
    grid(faces, [0.0, s, 0.0], [s, 0.0, 0.0], [0.0, 0.0, s], c, c, 0); // ceiling, -y
}

/// A file of `faces` (element e = face e; original ids reversed, so the id indirection is
/// exercised) with materials, point lights, `groups` light groups and the testkit's BVH.
fn file_of(
    faces: &[Face],
    materials: Vec<Material>,
    lights: Vec<PointLight>,
    groups: usize,
) -> OperatorFile {
    let n = faces.len();
    let mut file =
        testkit::synthetic::file(n.max(3), 1, 3, Precision::F32, Layout::Factored, 1).unwrap();
    file.n = n as u32;
    file.order = (0..n as u32).rev().collect();
    let mut vertices = Vec::with_capacity(12 * n);
    let mut normals = Vec::with_capacity(3 * n);
    for f in faces {
        let unused = (f.count == 3).then_some([0.0f32; 3]);
        vertices.extend(f.corners.iter().take(3).flatten());
        vertices.extend(unused.unwrap_or(f.corners[3]));
        let [a, b, c, _] = f.corners;
        let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let nrm = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        let l = (nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]).sqrt();
        normals.extend(nrm.map(|c| c / l));
    }
    file.geometry = Geometry {
        vertex_count: faces.iter().map(|f| f.count).collect(),
        vertices,
        normals,
    };
    file.lights.truncate(groups);
    assert_eq!(file.lights.len(), groups);
    file.display = Display {
        materials: Some(Materials {
            materials,
            element_material: faces.iter().map(|f| f.material).collect(),
        }),
        point_lights: lights,
        bvh: Some(testkit::bvh::build(&file.geometry)),
        ..Display::default()
    };
    file
}

/// A smooth but varied radiosity per element (no two neighbours alike, all positive).
fn radiosity(n: usize) -> Vec<[f32; 3]> {
    (0..n)
        .map(|i| {
            let x = i as f32;
            [
                1.0 + 0.5 * (0.37 * x).sin(),
                1.0 + 0.5 * (0.23 * x + 1.0).sin(),
                0.6 + 0.3 * (0.11 * x + 2.0).cos(),
            ]
        })
        .collect()
}

fn camera(eye: [f32; 3], target: [f32; 3]) -> Camera {
    Camera {
        name: String::new(),
        eye,
        target,
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 55.0,
    }
}

/// How far the GPU image is from the CPU's: the worst relative error over pixels within
/// [`REL`], and the number of pixels beyond it.
struct Agreement {
    worst_within: f64,
    off: usize,
    worst_off: f64,
}

fn agreement(gpu: &Image, cpu: &Image) -> Agreement {
    assert_eq!((gpu.width, gpu.height), (cpu.width, cpu.height));
    // Relative to the pixel, with a floor of 1e-3 of the image's mean for black pixels.
    let mean = cpu
        .pixels
        .iter()
        .flatten()
        .map(|&c| f64::from(c))
        .sum::<f64>()
        / (3 * cpu.pixels.len()) as f64;
    let floor = 1e-3 * mean.max(1e-30);
    let mut a = Agreement {
        worst_within: 0.0,
        off: 0,
        worst_off: 0.0,
    };
    for (g, c) in gpu.pixels.iter().zip(&cpu.pixels) {
        let mut worst = 0.0f64;
        for ch in 0..3 {
            let (g, c) = (f64::from(g[ch]), f64::from(c[ch]));
            assert!(g.is_finite(), "GPU pixel {g}");
            worst = worst.max((g - c).abs() / c.abs().max(floor));
        }
        if worst <= REL {
            a.worst_within = a.worst_within.max(worst);
        } else {
            a.off += 1;
            a.worst_off = a.worst_off.max(worst);
        }
    }
    a
}

/// Renders `file` from `cam` on both twins with `b` and `groups` and checks the agreement;
/// returns the GPU tracer's report.
fn compare(
    name: &str,
    file: &OperatorFile,
    cam: &Camera,
    (w, h): (u32, u32),
    groups: &[f32],
    tile: Option<u32>,
) -> lrr_runtime::gpu::GpuRenderReport {
    compare_images(name, file, cam, (w, h), groups, tile).0
}

/// [`compare`], also returning both images (GPU, CPU).
fn compare_images(
    name: &str,
    file: &OperatorFile,
    cam: &Camera,
    (w, h): (u32, u32),
    groups: &[f32],
    tile: Option<u32>,
) -> (lrr_runtime::gpu::GpuRenderReport, Image, Image) {
    let b = radiosity(file.n as usize);
    let tracer = Tracer::new(file).unwrap();
    let view = View::new(cam, w, h).unwrap();
    let lighting = Lighting {
        radiosity: &b,
        group_intensities: groups,
        direct: None,
    };
    let mut gt = GpuTracer::new(gpu(), &tracer).unwrap();
    if let Some(t) = tile {
        gt.set_tile_pixels(t).unwrap();
    }
    compare_frame(name, &tracer, &mut gt, (&view, w, h), &lighting)
}

/// One frame of `lighting` through `view` on both twins (`gt` made from `tracer`), checked as
/// [`compare`] says; the GPU's report and both images (GPU, CPU).
fn compare_frame(
    name: &str,
    tracer: &Tracer,
    gt: &mut GpuTracer,
    (view, w, h): (&View, u32, u32),
    lighting: &Lighting,
) -> (lrr_runtime::gpu::GpuRenderReport, Image, Image) {
    let (cpu, cpu_report) = tracer.render(view, lighting, w, h, 2).unwrap();
    let (image, report) = gt.render_lighting(view, lighting, w, h).unwrap();
    assert_eq!(report.decision, cpu_report.decision, "{name}");
    // The trace dispatches' GPU time, where the adapter has timestamps, within the frame's wall.
    let timestamps = gpu()
        .device()
        .features()
        .contains(gpu::wgpu::Features::TIMESTAMP_QUERY);
    let timed = timestamps && 2 * report.tiles <= gpu::wgpu::QUERY_SET_MAX_QUERIES;
    assert_eq!(report.gpu.is_some(), timed, "{name}");
    if let Some(g) = report.gpu {
        assert!(
            g.as_nanos() > 0 && g <= report.wall,
            "{name}: {g:?} of {:?}",
            report.wall
        );
    }
    let a = agreement(&image, &cpu);
    let pixels = (w * h) as usize;
    eprintln!(
        "{name}: {w}x{h}, {} tiles; worst relative {:.2e} over {} pixels; {} pixels ({:.3}%) \
         beyond {REL:e} (worst {:.2e}); rays GPU {:?} CPU {:?}",
        report.tiles,
        a.worst_within,
        pixels - a.off,
        a.off,
        100.0 * a.off as f64 / pixels as f64,
        a.worst_off,
        report.rays,
        cpu_report.rays,
    );
    if gpu().is_cpu() {
        // lavapipe compiles through LLVM without fusing or approximating: the same hits
        // everywhere; flat, only pow differs in the last bits (measured: 0 and 2.2e-7).
        let rel = if report.decision.effects.smooth {
            SMOOTH_CPU_ADAPTER_REL
        } else {
            FLAT_CPU_ADAPTER_REL
        };
        assert!(
            a.off == 0 && a.worst_within <= rel,
            "{name}: on a CPU adapter {} pixels differ beyond {REL:e}, worst within {:.2e} \
             (bound {rel:e})",
            a.off,
            a.worst_within
        );
    }
    assert!(
        (a.off as f64) <= MAX_OFF_FRACTION * pixels as f64,
        "{name}: {} of {pixels} pixels differ beyond {REL:e} (worst {:.2e})",
        a.off,
        a.worst_off
    );
    // Ray counts agree up to the pixels whose trees differ.
    let g = report.rays.expect("render counts rays");
    let c = cpu_report.rays;
    let close = |x: u64, y: u64| x.abs_diff(y) as f64 <= 8.0 * a.off as f64;
    assert!(
        close(g.primary, c.primary) && close(g.shadow, c.shadow),
        "{name}: {g:?} vs {c:?}"
    );
    assert!(close(g.secondary, c.secondary), "{name}: {g:?} vs {c:?}");
    (report, image, cpu)
}

#[test]
fn a_diffuse_room_matches_the_cpu_twin_per_pixel() {
    let mut faces = Vec::new();
    room(&mut faces, 6, 0);
    block(&mut faces, [1.0, 0.0, 1.0], [2.2, 1.5, 2.0], 3, 0);
    block(&mut faces, [2.6, 0.0, 2.2], [3.4, 2.5, 3.0], 2, 0);
    let file = file_of(
        &faces,
        vec![Material::diffuse("white", [0.7; 3])],
        vec![],
        0,
    );
    let cam = camera([2.0, 2.0, 3.9], [2.0, 1.5, 0.0]);
    // Small tiles: the image crosses many tile boundaries, one not on a row's end.
    let report = compare("diffuse room", &file, &cam, (97, 61), &[], Some(64 * 7));
    assert!(!report.decision.effects.secondary && !report.decision.effects.highlights);
    assert_eq!(report.tiles, (97 * 61u32).div_ceil(64 * 7));
}

/// A frame of more tiles than one timestamp query set can time (2 queries per tile, at most
/// 4096): it renders, matches the CPU twin, and reports no GPU time rather than failing.
#[test]
fn a_frame_of_more_than_2048_tiles_renders_untimed() {
    let file = white_room(0);
    let cam = camera([2.0, 2.0, 3.9], [2.0, 1.5, 0.0]);
    // 64 pixels: the smallest tile (one workgroup of the tracer).
    let tile = 64;
    let (w, h) = (260, 2100 * tile / 260 + 1);
    let report = compare("many tiles", &file, &cam, (w, h), &[], Some(tile));
    assert!(
        2 * report.tiles > gpu::wgpu::QUERY_SET_MAX_QUERIES,
        "{}",
        report.tiles
    );
    assert!(report.gpu.is_none());
}

/// Every `every`-th quad of `faces` (from `first`) split into two triangles along a diagonal.
fn split_quads(faces: &mut Vec<Face>, first: usize, every: usize) {
    let mut out = Vec::with_capacity(faces.len() * 2);
    for (i, f) in faces.drain(..).enumerate() {
        if f.count == 4 && i >= first && (i - first).is_multiple_of(every) {
            let [a, b, c, d] = f.corners;
            out.push(Face {
                corners: [a, b, c, [0.0; 3]],
                count: 3,
                material: f.material,
            });
            out.push(Face {
                corners: [a, c, d, [0.0; 3]],
                count: 3,
                material: f.material,
            });
        } else {
            out.push(f);
        }
    }
    *faces = out;
}

/// SMOOTH weights joining the corners at one position (equal weights), and at every third
/// shared vertex weights that extrapolate as a surface's boundary does (1.6 and a negative one,
/// 0.1 on the rest): negative weights, and values the sum takes below zero that the
/// reconstruction clamps.
fn smooth_weights(g: &Geometry) -> lrr_formats::Smooth {
    let n = g.vertex_count.len();
    let mut keys: Vec<[i64; 3]> = Vec::new();
    let mut members: Vec<Vec<u32>> = Vec::new();
    let mut corners = vec![lrr_formats::Smooth::NONE; 4 * n];
    for e in 0..n {
        for i in 0..usize::from(g.vertex_count[e]) {
            let at = 12 * e + 3 * i;
            let key = [0, 1, 2].map(|c| (g.vertices[at + c] * 1024.0).round() as i64);
            let v = keys.iter().position(|k| *k == key).unwrap_or_else(|| {
                keys.push(key);
                members.push(Vec::new());
                keys.len() - 1
            });
            members[v].push(e as u32);
            corners[4 * e + i] = v as u32;
        }
    }
    let mut s = lrr_formats::Smooth {
        corners,
        offsets: vec![0],
        ..lrr_formats::Smooth::default()
    };
    for (v, m) in members.into_iter().enumerate() {
        let k = m.len();
        // Extrapolating: 1.6, -0.6 - 0.1 (k - 2), then 0.1 each (the format wants non-zero
        // weights summing to one).
        s.weights
            .extend((0..k).map(|i| match (k >= 2 && v % 3 == 0, i) {
                (true, 0) => 1.6,
                (true, 1) => -0.6 - 0.1 * (k - 2) as f32,
                (true, _) => 0.1,
                _ => 1.0 / k as f32,
            }));
        s.positions.extend(m);
        s.offsets.push(s.positions.len() as u32);
    }
    s
}

/// Pixels of `a` and `b` differing by more than 1e-3 relative.
fn differing(a: &Image, b: &Image) -> usize {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .filter(|(p, q)| (0..3).any(|c| (p[c] - q[c]).abs() > 1e-3 * q[c].abs().max(1e-6)))
        .count()
}

/// Smooth shading (the default on a file with SMOOTH weights): `smooth.wgsl` computes the
/// smooth-vertex values from the radiosity buffer, `trace.wgsl` interpolates them at every hit;
/// the image equals the CPU twin's f64 reconstruction per pixel, on quads and triangles, with
/// negative weights and clamped vertices, across tiles, and is not the flat image.
#[test]
fn smooth_shading_matches_the_cpu_twin_per_pixel() {
    let mut faces = Vec::new();
    room(&mut faces, 6, 0);
    block(&mut faces, [1.0, 0.0, 1.0], [2.2, 1.5, 2.0], 3, 0);
    block(&mut faces, [2.6, 0.0, 2.2], [3.4, 2.5, 3.0], 2, 0);
    split_quads(&mut faces, 1, 3);
    let mut file = file_of(
        &faces,
        vec![Material::diffuse("white", [0.7; 3])],
        vec![],
        0,
    );
    file.display.smooth = Some(smooth_weights(&file.geometry));
    let cam = camera([2.0, 2.0, 3.9], [2.0, 1.5, 0.0]);
    let (report, image, cpu) =
        compare_images("smooth room", &file, &cam, (97, 61), &[], Some(64 * 7));
    let e = report.decision.effects;
    assert!(e.smooth && !e.secondary && !e.highlights, "{e:?}");
    let text = report.decision.text();
    assert!(text.contains("smooth radiosity: on"), "{text}");
    // Smooth is not flat: most pixels change.
    let mut tracer = Tracer::new(&file).unwrap();
    tracer.set_smooth(false).unwrap();
    let b = radiosity(file.n as usize);
    let lighting = Lighting {
        radiosity: &b,
        group_intensities: &[],
        direct: None,
    };
    let view = View::new(&cam, 97, 61).unwrap();
    let mut gt = GpuTracer::new(gpu(), &tracer).unwrap();
    let (flat_gpu, flat_report) = gt.render_lighting(&view, &lighting, 97, 61).unwrap();
    assert!(!flat_report.decision.effects.smooth);
    let (flat_cpu, _) = tracer.render(&view, &lighting, 97, 61, 2).unwrap();
    let a = agreement(&flat_gpu, &flat_cpu);
    assert!(a.off as f64 <= MAX_OFF_FRACTION * (97 * 61) as f64);
    let changed = differing(&image, &flat_gpu);
    eprintln!(
        "smooth room: {changed} of {} pixels differ from flat by > 1e-3",
        97 * 61
    );
    assert!(changed > 97 * 61 / 2, "{changed}");
    assert!(differing(&cpu, &flat_cpu) > 97 * 61 / 2);
}

/// A file drawn through display faces (section FACES, format 1.4; `testkit::faces`): the GPU's
/// per-face tables (triangle -> face, face -> element id, normal and material, smooth corners)
/// give the CPU twin's image, flat and smooth, with one element shiny under a point light so
/// that the face -> material table matters.
#[test]
fn display_faces_match_the_cpu_twin_per_pixel() {
    let mut file = testkit::faces::interleaved();
    let shiny = Material {
        name: "shiny".into(),
        specular: [0.6; 3],
        shininess: 8.0,
        ..Material::diffuse("shiny", [0.5; 3])
    };
    let materials = file.display.materials.as_mut().unwrap();
    materials.materials.push(shiny);
    materials.element_material = vec![0, 1];
    file.display.point_lights = vec![PointLight {
        name: "lamp".into(),
        position: [1.2, 0.4, 0.8],
        intensity: [2.0; 3],
        group: PointLight::FIXED,
    }];
    file.validate().unwrap();
    let cam = file.display.cameras[0].clone();
    let (report, smooth_gpu, _) = compare_images("display faces", &file, &cam, (80, 60), &[], None);
    let e = report.decision.effects;
    assert!(e.smooth && e.highlights, "{e:?}");
    let mut tracer = Tracer::new(&file).unwrap();
    tracer.set_smooth(false).unwrap();
    let b = radiosity(file.n as usize);
    let lighting = Lighting {
        radiosity: &b,
        group_intensities: &[],
        direct: None,
    };
    let view = View::new(&cam, 80, 60).unwrap();
    let mut gt = GpuTracer::new(gpu(), &tracer).unwrap();
    let (flat_gpu, _) = gt.render_lighting(&view, &lighting, 80, 60).unwrap();
    let (flat_cpu, _) = tracer.render(&view, &lighting, 80, 60, 2).unwrap();
    let a = agreement(&flat_gpu, &flat_cpu);
    assert!(a.off as f64 <= MAX_OFF_FRACTION * (80 * 60) as f64);
    if gpu().is_cpu() {
        assert!(a.off == 0 && a.worst_within <= FLAT_CPU_ADAPTER_REL);
    }
    assert!(differing(&smooth_gpu, &flat_gpu) > 80 * 60 / 4);
}

/// Smooth shading inside the ray tree (mirror, glass, highlights behind shadow rays): every
/// diffuse term of every ray, reconstructed, equals the CPU twin's.
#[test]
fn smooth_shading_in_the_ray_tree_matches_the_cpu_twin_per_pixel() {
    let mut faces = Vec::new();
    room(&mut faces, 5, 1);
    block(&mut faces, [1.2, 0.5, 1.0], [2.4, 1.8, 2.2], 2, 2);
    block(&mut faces, [2.6, 0.0, 2.4], [3.4, 1.6, 3.2], 2, 3);
    split_quads(&mut faces, 0, 4);
    let materials = vec![
        Material {
            specular: [0.2; 3],
            shininess: 8.0,
            ..Material::diffuse("plaster", [0.6; 3])
        },
        Material {
            mirror: [0.9, 0.85, 0.8],
            ..Material::diffuse("mirror", [0.1; 3])
        },
        Material {
            mirror: [1.0; 3],
            transmission: [0.95, 0.97, 1.0],
            ior: 1.5,
            ..Material::diffuse("glass", [0.0; 3])
        },
        Material {
            specular: [0.6, 0.5, 0.4],
            shininess: 40.0,
            ..Material::diffuse("metal", [0.3; 3])
        },
    ];
    let lights = vec![PointLight {
        name: "lamp".into(),
        position: [2.0, 3.6, 2.0],
        intensity: [4.0, 3.5, 3.0],
        group: PointLight::FIXED,
    }];
    let mut file = file_of(&faces, materials, lights, 0);
    file.display.smooth = Some(smooth_weights(&file.geometry));
    let cam = camera([3.5, 2.5, 3.9], [1.5, 1.0, 1.0]);
    let report = compare("smooth ray tree", &file, &cam, (120, 90), &[], None);
    let e = report.decision.effects;
    assert!(e.smooth && e.secondary && e.highlights, "{e:?}");
}

/// A room with a glass block (reflective too: Fresnel-weighted mirror), a glass slab seen
/// edge-on and a mirror wall. The slab stands 1 cm above the floor: standing on it, its bottom
/// face and the floor were coplanar, and a ray inside the slab met either by rounding, so that
/// the CPU twin itself changed 6.6% of the pixels when the eye moved by 1e-7 relative
/// (`mirror_and_glass_scene_is_well_conditioned`), and so did an H100 against the CPU twin.
fn mirror_and_glass_scene() -> (OperatorFile, Camera) {
    let mut faces = Vec::new();
    room(&mut faces, 5, 1);
    block(&mut faces, [1.2, 0.5, 1.0], [2.4, 1.8, 2.2], 2, 2);
    block(&mut faces, [2.8, 0.01, 0.8], [3.3, 2.0, 2.6], 1, 2);
    let materials = vec![
        Material::diffuse("white", [0.7; 3]),
        Material {
            mirror: [0.9, 0.85, 0.8],
            ..Material::diffuse("mirror", [0.1; 3])
        },
        Material {
            mirror: [1.0; 3],
            transmission: [0.95, 0.97, 1.0],
            ior: 1.5,
            ..Material::diffuse("glass", [0.0; 3])
        },
    ];
    let file = file_of(&faces, materials, vec![], 0);
    (file, camera([3.5, 2.5, 3.9], [1.5, 1.0, 1.0]))
}

#[test]
fn mirror_and_glass_match_the_cpu_twin_per_pixel() {
    let (file, cam) = mirror_and_glass_scene();
    let report = compare("mirror and glass", &file, &cam, (120, 90), &[], None);
    let e = report.decision.effects;
    assert!(e.secondary && !e.highlights);
    let rays = report.rays.unwrap();
    assert!(
        rays.secondary > rays.primary,
        "the glass spawns trees: {rays:?}"
    );
}

/// The GPU's tolerances (at most [`MAX_OFF_FRACTION`] of the pixels beyond [`REL`], ray
/// counts within 8 per such pixel) presume scenes whose image and ray tree do not change under
/// rounding: the CPU twin itself, with the eye moved by 1e-7 and 1e-6 relative (a few ulp,
/// what a GPU's fused or approximate arithmetic does to a ray), must stay within them.
#[test]
fn the_ray_tree_scenes_are_well_conditioned() {
    let scenes = [
        (
            "mirror and glass",
            mirror_and_glass_scene(),
            (120, 90),
            vec![],
        ),
        (
            "point lights",
            point_lights_scene(),
            (110, 80),
            vec![0.7, 0.0],
        ),
    ];
    for (name, (file, base), (w, h), groups) in scenes {
        let b = radiosity(file.n as usize);
        let tracer = Tracer::new(&file).unwrap();
        let lighting = Lighting {
            radiosity: &b,
            group_intensities: &groups,
            direct: None,
        };
        let (image, report) = tracer
            .render(&View::new(&base, w, h).unwrap(), &lighting, w, h, 2)
            .unwrap();
        for eps in [1e-7f32, 1e-6] {
            let mut cam = base.clone();
            cam.eye[0] *= 1.0 + eps;
            cam.eye[1] *= 1.0 - eps;
            let (moved, moved_report) = tracer
                .render(&View::new(&cam, w, h).unwrap(), &lighting, w, h, 2)
                .unwrap();
            let a = agreement(&moved, &image);
            let (r, m) = (report.rays, moved_report.rays);
            eprintln!(
                "{name}, eye moved by {eps:e}: {} of {} pixels beyond {REL:e} (worst {:.2e}); \
                 rays {r:?} then {m:?}",
                a.off,
                w * h,
                a.worst_off
            );
            assert!(
                (a.off as f64) < MAX_OFF_FRACTION * f64::from(w * h),
                "{name}, eye moved by {eps:e}: {} pixels change",
                a.off
            );
            let close = |x: u64, y: u64| x.abs_diff(y) <= 8 * a.off as u64;
            assert!(
                close(r.shadow, m.shadow) && close(r.secondary, m.secondary),
                "{name}, eye moved by {eps:e}: rays {r:?} then {m:?}"
            );
        }
    }
}

/// A room of plaster with a metal and a lacquered block (a mirror too), three point lights
/// (one fixed, one off by its group). No light lies in the plane of a face: the fill light hangs
/// 10 cm above the tall block's top and the lamp 10 cm off the planes of the short block's +x
/// and +z faces. In those planes, every hit on the face had its light at exactly 90°, and
/// whether it cast a shadow ray was decided by rounding (an H100 cast 61 more than the CPU
/// twin, with every pixel within 1e-4).
fn point_lights_scene() -> (OperatorFile, Camera) {
    let mut faces = Vec::new();
    room(&mut faces, 5, 0);
    block(&mut faces, [1.0, 0.0, 1.0], [2.0, 1.2, 2.0], 2, 1);
    block(&mut faces, [2.5, 0.0, 1.5], [3.3, 2.0, 2.3], 2, 2);
    let materials = vec![
        Material {
            specular: [0.2; 3],
            shininess: 8.0,
            ..Material::diffuse("plaster", [0.6; 3])
        },
        Material {
            specular: [0.6, 0.5, 0.4],
            shininess: 40.0,
            ..Material::diffuse("metal", [0.3; 3])
        },
        Material {
            specular: [0.3; 3],
            shininess: 0.0,
            mirror: [0.4; 3],
            ..Material::diffuse("lacquer", [0.3; 3])
        },
    ];
    let light = |name: &str, position, intensity, group| PointLight {
        name: name.into(),
        position,
        intensity,
        group,
    };
    let lights = vec![
        light("lamp", [2.1, 3.6, 1.9], [4.0, 3.5, 3.0], 0),
        light("fill", [0.5, 2.1, 3.5], [1.0, 1.0, 1.5], PointLight::FIXED),
        light("off", [3.5, 3.5, 0.5], [2.0; 3], 1),
    ];
    let file = file_of(&faces, materials, lights, 2);
    (file, camera([3.6, 2.8, 3.8], [1.6, 0.8, 1.4]))
}

#[test]
fn point_lights_highlights_and_shadows_match_the_cpu_twin_per_pixel() {
    let (file, cam) = point_lights_scene();
    let report = compare("point lights", &file, &cam, (110, 80), &[0.7, 0.0], None);
    let e = report.decision.effects;
    assert!(e.highlights && e.secondary);
    assert!(report.rays.unwrap().shadow > 0);
}

/// The frame's radiosity never leaves the GPU: the evaluator's buffer is bound as it is (read by
/// the smooth-vertex pass and the tracer), and the image equals the CPU twin's shading of the
/// CPU evaluator's radiosity (within the evaluators' own 1e-5 agreement plus [`REL`]).
#[test]
fn the_tracer_reads_the_relighting_buffer_without_readback() {
    let mut file =
        testkit::synthetic::file(256, 8, 3, Precision::F32, Layout::Factored, 7).unwrap();
    file.display.bvh = Some(testkit::bvh::build(&file.geometry));
    file.display.smooth = Some(smooth_weights(&file.geometry));
    let op = Operator::from_file(file).unwrap();
    let tracer = Tracer::new(op.file()).unwrap();
    let (lo, hi) = bounds(&op.file().geometry.vertices);
    let centre: [f32; 3] = std::array::from_fn(|c| 0.5 * (lo[c] + hi[c]));
    let eye = [
        centre[0],
        centre[1],
        hi[2] + 2.0 * (hi[0] - lo[0]).max(hi[1] - lo[1]),
    ];
    let cam = camera(eye, centre);
    let (w, h) = (80, 60);
    let view = View::new(&cam, w, h).unwrap();
    let groups = vec![1.0; op.light_groups().len()];
    let cpu_b = op.evaluate_baked();
    let lighting = Lighting {
        radiosity: &cpu_b,
        group_intensities: &groups,
        direct: None,
    };
    let (cpu, _) = tracer.render(&view, &lighting, w, h, 2).unwrap();
    let mut eval = GpuEvaluator::new(gpu(), &op).unwrap();
    eval.submit(Rgb::triples(&op.baked_emission())).unwrap();
    let mut gt = GpuTracer::new(gpu(), &tracer).unwrap();
    let (image, report) = gt
        .render(&view, eval.radiosity_buffer(), &groups, w, h)
        .unwrap();
    assert!(report.decision.effects.smooth);
    let a = agreement(&image, &cpu);
    eprintln!(
        "evaluator buffer: worst {:.2e}, {} pixels off (worst {:.2e})",
        a.worst_within, a.off, a.worst_off
    );
    assert!(image.pixels.iter().any(|p| p[0] > 0.0), "the scene is seen");
    assert!(a.off as f64 <= MAX_OFF_FRACTION * (w * h) as f64);
}

fn bounds(v: &[f32]) -> ([f32; 3], [f32; 3]) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in v.chunks_exact(3) {
        for c in 0..3 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    (lo, hi)
}

/// The bounds-check-free build (the default) computes the same image as the checked one, flat
/// and smooth, with and without lights that are not surfaces.
#[test]
fn the_unchecked_pipeline_equals_the_checked_one() {
    let mut faces = Vec::new();
    room(&mut faces, 3, 1);
    block(&mut faces, [1.2, 0.5, 1.0], [2.4, 1.8, 2.2], 1, 1);
    let materials = vec![
        Material::diffuse("white", [0.7; 3]),
        Material {
            transmission: [1.0; 3],
            ior: 1.33,
            ..Material::diffuse("water", [0.0; 3])
        },
    ];
    let mut file = file_of(&faces, materials, vec![], 0);
    file.display.smooth = Some(smooth_weights(&file.geometry));
    let lights = direct_lights();
    for (smooth, direct) in [(true, false), (false, false), (true, true), (false, true)] {
        unchecked_equals_checked(&file, smooth, direct.then_some(lights.as_slice()));
    }
}

fn unchecked_equals_checked(file: &OperatorFile, smooth: bool, lights: Option<&[Light]>) {
    let mut tracer = Tracer::new(file).unwrap();
    tracer.set_smooth(smooth).unwrap();
    let view = View::new(&camera([3.0, 2.0, 3.9], [1.8, 1.1, 1.6]), 48, 32).unwrap();
    let b = radiosity(file.n as usize);
    let rho = reflectance(file.n as usize);
    let lighting = Lighting {
        radiosity: &b,
        group_intensities: &[],
        direct: lights.map(|lights| DirectShading {
            lights,
            reflectance: &rho,
        }),
    };
    let checked_gpu = open(&GpuOptions {
        bounds_checks: true,
        ..GpuOptions::default()
    });
    let (checked, _) = GpuTracer::new(&checked_gpu, &tracer)
        .unwrap()
        .render_lighting(&view, &lighting, 48, 32)
        .unwrap();
    let (unchecked, _) = GpuTracer::new(gpu(), &tracer)
        .unwrap()
        .render_lighting(&view, &lighting, 48, 32)
        .unwrap();
    assert_eq!(checked, unchecked);
}

/// A white room of 2 × 2 cells a wall with `groups` light groups, no lights.
fn white_room(groups: usize) -> OperatorFile {
    let mut faces = Vec::new();
    room(&mut faces, 2, 0);
    file_of(
        &faces,
        vec![Material::diffuse("white", [0.7; 3])],
        vec![],
        groups,
    )
}

#[test]
fn bad_calls_are_clear_errors() {
    let file = white_room(1);
    let tracer = Tracer::new(&file).unwrap();
    let mut gt = GpuTracer::new(gpu(), &tracer).unwrap();
    let view = View::new(&camera([2.0, 2.0, 3.0], [2.0, 2.0, 0.0]), 8, 8).unwrap();
    let short = radiosity(file.n as usize - 1);
    let e = gt.upload_radiosity(&short).unwrap_err().to_string();
    assert!(e.contains("values for 24 elements"), "{e}");
    let mut nan = radiosity(file.n as usize);
    nan[3][1] = f32::NAN;
    let e = gt.upload_radiosity(&nan).unwrap_err().to_string();
    assert!(e.contains("element 3 is not finite"), "{e}");
    let b = gt.upload_radiosity(&radiosity(file.n as usize)).unwrap();
    let e = gt.render(&view, &b, &[], 8, 8).unwrap_err().to_string();
    assert!(e.contains("0 values for the file's 1 groups"), "{e}");
    let e = gt.render(&view, &b, &[1.0], 0, 8).unwrap_err().to_string();
    assert!(e.contains("at least 1"), "{e}");
    let e = gt.set_tile_pixels(10).unwrap_err().to_string();
    assert!(e.contains("tile of 10 pixels"), "{e}");
    let e = gt.set_max_depth(99).unwrap_err().to_string();
    assert!(e.contains("at most 16"), "{e}");
    let tiny = gpu().device().create_buffer(&gpu::wgpu::BufferDescriptor {
        label: None,
        size: 16,
        usage: gpu::wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    let e = gt
        .render(&view, &tiny, &[1.0], 8, 8)
        .unwrap_err()
        .to_string();
    assert!(e.contains("radiosity buffer holds 16 bytes"), "{e}");
}

/// An open court (a floor and two walls, no ceiling: a sun's rays leave it) with two blocks on
/// the floor (the first, glass in the ray tree's scene, 1 cm above it: see
/// [`mirror_and_glass_scene`]) and a slab hanging above it, all casting shadows, lit by lights that are
/// not surfaces: a point light, a soft spot, a hard-edged spot (equal cones), a sun and a dark
/// light (skipped before any ray). No light lies in the plane of a face and the sun is parallel
/// to none (a cosine of exactly 0 would be decided by rounding).
fn direct_scene(materials: Vec<Material>, block_material: u32) -> (OperatorFile, Camera) {
    let mut faces = Vec::new();
    let s = 4.0;
    grid(&mut faces, [0.0; 3], [0.0, 0.0, s], [s, 0.0, 0.0], 5, 5, 0); // floor, +y
    grid(
        &mut faces,
        [0.0; 3],
        [s, 0.0, 0.0],
        [0.0, 3.0, 0.0],
        5,
        4,
        0,
    ); // back z = 0, +z
    grid(
        &mut faces,
        [0.0; 3],
        [0.0, 3.0, 0.0],
        [0.0, 0.0, s],
        4,
        5,
        0,
    ); // x = 0, +x
    block(
        &mut faces,
        [1.0, 0.01, 1.2],
        [2.0, 1.2, 2.2],
        2,
        block_material,
    );
    block(&mut faces, [2.6, 0.0, 0.6], [3.2, 2.2, 1.2], 1, 0);
    block(&mut faces, [1.4, 1.9, 2.6], [2.4, 2.0, 3.4], 1, 0);
    let file = file_of(&faces, materials, vec![], 0);
    (file, camera([3.9, 3.4, 4.6], [1.6, 0.7, 1.6]))
}

fn direct_lights() -> Vec<Light> {
    vec![
        Light::Point {
            position: [2.3, 2.7, 2.9],
            intensity: [3.0, 2.6, 2.2],
        },
        Light::Spot {
            position: [0.7, 2.9, 0.9],
            direction: [0.8, -3.0, 1.9],
            intensity: [6.0, 5.0, 4.0],
            inner: 20f32.to_radians(),
            outer: 35f32.to_radians(),
        },
        Light::Point {
            position: [3.1, 0.5, 3.3],
            intensity: [0.0; 3],
        },
        Light::Spot {
            position: [3.6, 2.5, 3.6],
            direction: [-2.1, -1.9, -1.9],
            intensity: [2.0, 2.0, 3.0],
            inner: 15f32.to_radians(),
            outer: 15f32.to_radians(),
        },
        Light::Directional {
            direction: [-0.45, -1.0, -0.35],
            irradiance: [1.2, 1.1, 0.9],
        },
    ]
}

/// A frame of radiosity `b` (the bounced light) and `lights` reflected with `rho`.
fn lit<'a>(b: &'a [[f32; 3]], lights: &'a [Light], rho: &'a [[f32; 3]]) -> Lighting<'a> {
    Lighting {
        radiosity: b,
        group_intensities: &[],
        direct: Some(DirectShading {
            lights,
            reflectance: rho,
        }),
    }
}

/// A varied reflectance per element.
fn reflectance(n: usize) -> Vec<[f32; 3]> {
    (0..n)
        .map(|i| {
            let x = i as f32;
            [
                0.5 + 0.3 * (0.41 * x).sin(),
                0.5 + 0.25 * (0.29 * x + 0.5).cos(),
                0.4 + 0.2 * (0.17 * x + 1.0).sin(),
            ]
        })
        .collect()
}

/// Lights that are not surfaces, shaded at every hit (`trace.wgsl`'s `DIRECT` variant): the
/// images equal the CPU twin's per pixel, shadow rays included, frame after frame on one tracer
/// (more lights than its buffer held, then a new reflectance, then none: the variant without
/// them), and the GPU-resident entry point gives the same image. The scene's shadows are real:
/// the sun's and the point light's shadow rays are blocked where the blocks stand between.
#[test]
fn direct_lights_and_their_shadows_match_the_cpu_twin_per_pixel() {
    let (file, cam) = direct_scene(vec![Material::diffuse("white", [0.7; 3])], 0);
    let n = file.n as usize;
    let (w, h) = (110, 80);
    let tracer = Tracer::new(&file).unwrap();
    let view = View::new(&cam, w, h).unwrap();
    let mut gt = GpuTracer::new(gpu(), &tracer).unwrap();
    let b = radiosity(n);
    let mut rho = reflectance(n);
    let all = direct_lights();
    // One light first (the buffer holds one), then all of them.
    let (report, one, _) = compare_frame(
        "direct: the spot",
        &tracer,
        &mut gt,
        (&view, w, h),
        &lit(&b, &all[1..2], &rho),
    );
    assert!(report.rays.unwrap().shadow > 0);
    let (report, image, cpu) = compare_frame(
        "direct: point, spots, sun",
        &tracer,
        &mut gt,
        (&view, w, h),
        &lit(&b, &all, &rho),
    );
    let e = report.decision.effects;
    assert!(!e.smooth && !e.secondary && !e.highlights, "{e:?}");
    let rays = report.rays.unwrap();
    assert!(rays.shadow > rays.primary, "{rays:?}");
    assert!(differing(&image, &one) > (w * h) as usize / 4);
    // A new reflectance is uploaded (and the image follows it).
    for r in rho.iter_mut().step_by(3) {
        r[1] *= 0.5;
    }
    let (_, dimmer, _) = compare_frame(
        "direct: new reflectance",
        &tracer,
        &mut gt,
        (&view, w, h),
        &lit(&b, &all, &rho),
    );
    assert!(differing(&dimmer, &image) > 0);
    // The GPU-resident entry point: the same image from a storage buffer.
    let buffer = gt.upload_radiosity(&b).unwrap();
    let direct = DirectShading {
        lights: &all,
        reflectance: &rho,
    };
    let (resident, _) = gt
        .render_direct(&view, &buffer, &[], Some(direct), w, h)
        .unwrap();
    assert_eq!(resident, dimmer);
    // No lights again: the plain variant, the plain image.
    let plain = Lighting {
        radiosity: &b,
        group_intensities: &[],
        direct: None,
    };
    let (none, report) = gt.render_lighting(&view, &plain, w, h).unwrap();
    assert_eq!(report.rays.unwrap().shadow, 0);
    let (cpu_none, _) = tracer.render(&view, &plain, w, h, 2).unwrap();
    assert_eq!(agreement(&none, &cpu_none).off, 0);
    assert!(differing(&cpu, &cpu_none) > (w * h) as usize / 3);
    // The shadows: a floor point that the first block hides from the sun, and one it does not.
    let pass = DirectLighting::new(&file, 1, 1).unwrap();
    let sun = &all[4..5];
    let Light::Directional { direction: d, .. } = sun[0] else {
        unreachable!()
    };
    // The floor point whose ray to the sun passes the middle of the block's top.
    let centre = [1.5f32, 1.2, 1.7];
    let t = -centre[1] / d[1];
    let under = [centre[0] + t * d[0], 0.0, centre[2] + t * d[2]];
    let up = [0.0, 1.0, 0.0];
    assert_eq!(
        pass.at(sun, under, up),
        [0.0; 3],
        "{under:?} is in the shadow"
    );
    assert!(pass.at(sun, [3.5, 0.0, 3.5], up)[0] > 0.0);
    let point = &all[0..1];
    assert_eq!(
        pass.at(point, [1.9, 0.0, 3.1], up),
        [0.0; 3],
        "under the slab"
    );
}

/// [`direct_scene`] with a glass block, a mirror wall, plaster with highlights under a file's
/// point light, and SMOOTH weights.
fn direct_ray_tree_scene() -> (OperatorFile, Camera) {
    let materials = vec![
        Material {
            specular: [0.2; 3],
            shininess: 8.0,
            ..Material::diffuse("plaster", [0.6; 3])
        },
        Material {
            mirror: [1.0; 3],
            transmission: [0.95, 0.97, 1.0],
            ior: 1.5,
            ..Material::diffuse("glass", [0.0; 3])
        },
    ];
    let (mut file, cam) = direct_scene(materials, 1);
    file.display.point_lights = vec![PointLight {
        name: "lamp".into(),
        position: [0.6, 2.6, 3.3],
        intensity: [2.0, 1.8, 1.6],
        group: PointLight::FIXED,
    }];
    // The back wall a mirror.
    let materials = file.display.materials.as_mut().unwrap();
    materials.materials.push(Material {
        mirror: [0.8, 0.75, 0.7],
        ..Material::diffuse("mirror", [0.1; 3])
    });
    for m in &mut materials.element_material[25..45] {
        *m = 2;
    }
    file.display.smooth = Some(smooth_weights(&file.geometry));
    file.validate().unwrap();
    (file, cam)
}

/// The lights' direct light inside the ray tree and with smooth shading: every diffuse term of
/// every ray (camera, mirror, glass) adds its own `ρ H(x) / π` behind its shadow rays, as the
/// CPU twin's does, beside a file's point light's highlights.
#[test]
fn direct_lights_in_the_ray_tree_and_smooth_match_the_cpu_twin_per_pixel() {
    let (file, cam) = direct_ray_tree_scene();
    let n = file.n as usize;
    let (w, h) = (110, 80);
    let tracer = Tracer::new(&file).unwrap();
    let view = View::new(&cam, w, h).unwrap();
    let mut gt = GpuTracer::new(gpu(), &tracer).unwrap();
    let (b, rho, lights) = (radiosity(n), reflectance(n), direct_lights());
    let lighting = Lighting {
        radiosity: &b,
        group_intensities: &[],
        direct: Some(DirectShading {
            lights: &lights,
            reflectance: &rho,
        }),
    };
    let (report, _, _) = compare_frame(
        "direct: ray tree, smooth",
        &tracer,
        &mut gt,
        (&view, w, h),
        &lighting,
    );
    let e = report.decision.effects;
    assert!(e.smooth && e.secondary && e.highlights, "{e:?}");
    let rays = report.rays.unwrap();
    assert!(rays.secondary > 0 && rays.shadow > rays.primary, "{rays:?}");
}

/// The direct scenes, as [`the_ray_tree_scenes_are_well_conditioned`] asks of the others: the
/// CPU twin's image and rays barely move when the eye moves by a few ulp (the shadow
/// edges and the hard-edged spot's cone included).
#[test]
fn the_direct_scenes_are_well_conditioned() {
    let flat = direct_scene(vec![Material::diffuse("white", [0.7; 3])], 0);
    for (name, (file, base)) in [
        ("direct", flat),
        ("direct ray tree", direct_ray_tree_scene()),
    ] {
        direct_scene_is_well_conditioned(name, &file, &base);
    }
}

fn direct_scene_is_well_conditioned(name: &str, file: &OperatorFile, base: &Camera) {
    let n = file.n as usize;
    let (w, h) = (110, 80);
    let (b, rho, lights) = (radiosity(n), reflectance(n), direct_lights());
    let tracer = Tracer::new(file).unwrap();
    let lighting = lit(&b, &lights, &rho);
    let (image, report) = tracer
        .render(&View::new(base, w, h).unwrap(), &lighting, w, h, 2)
        .unwrap();
    for eps in [1e-7f32, 1e-6] {
        let mut cam = base.clone();
        cam.eye[0] *= 1.0 + eps;
        cam.eye[1] *= 1.0 - eps;
        let (moved, moved_report) = tracer
            .render(&View::new(&cam, w, h).unwrap(), &lighting, w, h, 2)
            .unwrap();
        let a = agreement(&moved, &image);
        let (r, m) = (report.rays, moved_report.rays);
        eprintln!(
            "{name}, eye moved by {eps:e}: {} of {} pixels beyond {REL:e} (worst {:.2e}); \
             rays {r:?} then {m:?}",
            a.off,
            w * h,
            a.worst_off
        );
        assert!(
            (a.off as f64) < MAX_OFF_FRACTION * f64::from(w * h),
            "{name}"
        );
        let close = |x: u64, y: u64| x.abs_diff(y) <= 8 * a.off as u64;
        assert!(
            close(r.shadow, m.shadow) && close(r.secondary, m.secondary),
            "{name}: {r:?} then {m:?}"
        );
    }
}

/// Bad lights and reflectances are refused naming them, as the CPU twin refuses them.
#[test]
fn bad_direct_lights_are_clear_errors() {
    let file = white_room(0);
    let n = file.n as usize;
    let tracer = Tracer::new(&file).unwrap();
    let mut gt = GpuTracer::new(gpu(), &tracer).unwrap();
    let view = View::new(&camera([2.0, 2.0, 3.0], [2.0, 2.0, 0.0]), 8, 8).unwrap();
    let b = radiosity(n);
    let rho = reflectance(n);
    let cases: Vec<(Vec<Light>, usize, &str)> = vec![
        (
            vec![Light::Point {
                position: [1.0; 3],
                intensity: [1.0, -1.0, 1.0],
            }],
            n,
            "light 0",
        ),
        (
            vec![
                Light::Point {
                    position: [1.0; 3],
                    intensity: [1.0; 3],
                },
                Light::Spot {
                    position: [1.0; 3],
                    direction: [0.0; 3],
                    intensity: [1.0; 3],
                    inner: 0.1,
                    outer: 0.2,
                },
            ],
            n,
            "light 1",
        ),
        (
            vec![Light::Directional {
                direction: [0.0, -1.0, 0.0],
                irradiance: [1.0; 3],
            }],
            n - 1,
            "23 reflectances for 24 elements",
        ),
    ];
    for (lights, len, want) in cases {
        let lighting = Lighting {
            radiosity: &b,
            group_intensities: &[],
            direct: Some(DirectShading {
                lights: &lights,
                reflectance: &rho[..len],
            }),
        };
        let e = gt
            .render_lighting(&view, &lighting, 8, 8)
            .unwrap_err()
            .to_string();
        let cpu = tracer
            .render(&view, &lighting, 8, 8, 1)
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "{e}");
        assert_eq!(e, cpu);
    }
}
