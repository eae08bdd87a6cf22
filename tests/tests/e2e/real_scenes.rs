//! The corpus of real scenes in `scenes/real/`: files exported by others from real tools
//! (McGuire's Computer Graphics Archive, Godot's demo projects; the source, licence and quirks
//! of each in the README.txt beside it), each with a scene description that adds area lights
//! where the file has none. Every one is baked with the default flags, as a new user would:
//! the bake (its own process) finishes, the element count stays within the bound the mesher
//! promises, the bake's peak resident memory (its report's `peak_resident_bytes`, Linux) stays
//! within issue #31's 4 GB, every stage that plans its buffers before allocating them
//! ([`PLANNED`]: the import, the occlusion BVH, meshing with 2MSC's probes, the first pass's
//! matrix and its solve's cores, the display BVH, the smooth weights, the lightmap's charts,
//! the form factors' matrix, the cores `(I − VᵀU)⁻¹`, the file's writing: what `--max-memory`
//! is checked against)
//! stays within the estimate (the process's peak by the stage's end at most what was resident
//! when it began plus the estimate and [`SCRATCH`], or the peak before it began: a stage that
//! stays under an earlier peak is not seen), every surface's radiosity is finite, the surfaces
//! the light reaches are lit, and `lrr render` of the file shows no NaN. (The enclosure tests
//! are planned too, 9 bytes an element, too little to tell from the worker scratch; the whole
//! bake's peak is held to the 4 GB goal only.)
//!
//! The bound on n is today's: `4 A / h² + 2 F` before the refinement's 20% (subdivision halves
//! a face until its elements are at most the element size `h`, so they are at least `h² / 4`
//! over the area `A` away from boundaries, and every input face `F` is at least one element,
//! two where imprinting cuts it). Since issue #31 small faces and grid cells are grouped into
//! elements of about `h²` (`mesh/dense.rs`), so `F` no longer drives n; the bound keeps its
//! `2 F` term because pieces cut from large faces are not grouped (CornellBox-Water's right
//! wall: 3 660 elements along the water line). Measured `n / (A / h²)`, the refinement's
//! elements included: 2.9 (mirror), 2.7 (sphere), 4.5 (living room), 6.9 (water).

use std::path::{Path, PathBuf};

use crate::render_reference::read_rgb;
use crate::util::{lrr, lrr_binary, lrr_json, root, temp_dir};

/// The bake's threads here (the bytes are the same at any count).
const THREADS: usize = 2;

/// What a worker thread of a planned stage holds that the estimate, which plans the
/// matrices' buffers, does not: its stack (Rust's default 2 MiB at most) and its allocator
/// arena (glibc keeps a thread's freed blocks resident for the thread to reuse), whose working
/// set is a row's buffers, O(k + samples) values: well under a MiB for the k of a scene whose
/// matrix fits in memory. 8 MiB a thread bounds both with room for the arena's growth steps;
/// a buffer the estimate forgot that grows with n or k (zdm2's n·k f64 alone is 236 MB) does
/// not fit in it. (Measured: at most 4.5 MB over on 2 threads, on the corpus.)
const SCRATCH_PER_THREAD: f64 = 8.0 * 1024.0 * 1024.0;

/// [`SCRATCH_PER_THREAD`] for the bake's [`THREADS`].
const SCRATCH: f64 = THREADS as f64 * SCRATCH_PER_THREAD;

/// The stages of a default bake that plan their buffers (`Progress::estimate`), each of
/// which the report must give an estimate for.
const PLANNED: [&str; 14] = [
    "import",
    "visibility",
    "mesh",
    "first pass enclosure",
    "first pass",
    "first pass solve",
    "refine",
    "enclosure",
    "bvh",
    "smooth",
    "lightmap",
    "form factors",
    "operator",
    "write",
];

/// A scene of the corpus.
struct Case {
    /// Folder under `scenes/real/`.
    dir: &'static str,
    /// The file `lrr bake` is given.
    file: &'static str,
    /// Surfaces the light reaches (their mean radiosity must be positive in every channel).
    lit: &'static [&'static str],
    /// Camera of the render: eye, target (y up).
    eye: [f64; 3],
    target: [f64; 3],
}

const CORNELL_EYE: [f64; 3] = [0.0, 0.8, 3.2];
const CORNELL_TARGET: [f64; 3] = [0.0, 0.8, 0.0];

fn path(c: &Case) -> PathBuf {
    root().join("scenes/real").join(c.dir).join(c.file)
}

/// Bakes `c` with the default flags and checks what the module docs say.
fn bakes_with_the_defaults(c: &Case) {
    let scene = path(c);
    let dir = temp_dir(&format!("real-{}", c.dir));
    let out = dir.join("out.lrr");
    let report = dir.join("report.json");
    let lrr_bin = lrr_binary();
    let start = std::time::Instant::now();
    // Its own process, so that its memory figures are the bake's alone (the tests of this
    // binary run side by side); on [`THREADS`] threads, which [`SCRATCH`] counts.
    let run = std::process::Command::new(lrr_bin)
        .args([
            "bake",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "-q",
        ])
        .args(["--report", report.to_str().unwrap()])
        .args(["--threads", &THREADS.to_string()])
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}: the default bake failed: {}",
        c.dir,
        String::from_utf8_lossy(&run.stderr)
    );
    let seconds = start.elapsed().as_secs_f64();
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let n = report["n"].as_f64().unwrap();
    let h = report["element_size"].as_f64().unwrap();
    let faces = lrr_precompute::scene::load(&scene).unwrap().faces.len() as f64;
    let info = lrr_json(&["info", out.to_str().unwrap(), "--json"]);
    let surfaces = info["surfaces"].as_array().unwrap();
    let area: f64 = surfaces.iter().map(|s| s["area"].as_f64().unwrap()).sum();
    let cells = area / (h * h);
    println!(
        "{}: {faces} faces, n = {n}, k = {}, A/h² = {cells:.0} (n / (A/h²) = {:.2}), {seconds:.1} s",
        c.dir,
        report["k"],
        n / cells
    );
    let bound = 1.2 * (4.0 * cells + 2.0 * faces);
    assert!(n <= bound, "{}: n = {n} above {bound:.0}", c.dir);
    // Issue #31's memory goal for a real level on the 2-core CI machine: 4 GB.
    if let Some(peak) = report["peak_resident_bytes"].as_f64() {
        println!("{}: peak resident memory {:.0} MB", c.dir, peak / 1e6);
        assert!(peak <= 4e9, "{}: peak resident memory {peak} bytes", c.dir);
    }
    let estimates = report["stage_estimate_bytes"].as_object().unwrap();
    for stage in PLANNED {
        assert!(
            estimates.contains_key(stage),
            "{}: no estimate for {stage}: {estimates:?}",
            c.dir
        );
    }
    for (stage, estimate) in estimates {
        let at = |key: &str| report[key][stage].as_f64();
        let (Some(resident), Some(before), Some(after)) = (
            at("stage_start_resident_bytes"),
            at("stage_start_peak_bytes"),
            at("stage_peak_bytes"),
        ) else {
            // Only where Linux reports no memory (then no peak either).
            assert!(
                report["peak_resident_bytes"].is_null(),
                "{}: {stage}",
                c.dir
            );
            continue;
        };
        let estimate = estimate.as_f64().unwrap();
        println!(
            "{}: {stage}: estimate {:.1} MB, peak {:.1} MB over the {:.1} MB resident when it began",
            c.dir,
            estimate / 1e6,
            (after - resident) / 1e6,
            resident / 1e6
        );
        assert!(
            after <= before.max(resident + estimate + SCRATCH),
            "{}: {stage} peaked at {after} bytes, {resident} resident when it began, estimate \
             {estimate}",
            c.dir
        );
    }
    for s in surfaces {
        let name = s["name"].as_str().unwrap();
        let b: Vec<f64> = (0..3)
            .map(|i| s["mean_radiosity"][i].as_f64().unwrap())
            .collect();
        assert!(
            b.iter().all(|x| x.is_finite() && *x >= 0.0),
            "{}: surface {name}: {b:?}",
            c.dir
        );
        if c.lit.contains(&name) {
            assert!(
                b.iter().all(|&x| x > 0.0),
                "{}: {name} is dark: {b:?}",
                c.dir
            );
        }
    }
    for name in c.lit {
        assert!(
            surfaces.iter().any(|s| s["name"] == *name),
            "{}: no surface {name}",
            c.dir
        );
    }
    rendered_without_nan(c, &out, &dir);
}

/// `lrr render` of the bake through the case's camera: every pixel finite, some lit.
fn rendered_without_nan(c: &Case, file: &Path, dir: &Path) {
    let image = dir.join("frame.exr");
    let v = |x: [f64; 3]| format!("{},{},{}", x[0], x[1], x[2]);
    let (eye, target) = (v(c.eye), v(c.target));
    lrr(&[
        "render",
        file.to_str().unwrap(),
        "--eye",
        &eye,
        "--target",
        &target,
        "--up",
        "0,1,0",
        "--size",
        "96x72",
        "--exr-samples",
        "float",
        "-o",
        image.to_str().unwrap(),
    ])
    .unwrap_or_else(|e| panic!("{}: render failed: {e}", c.dir));
    let (_, _, pixels) = read_rgb(&image);
    assert!(
        pixels.iter().flatten().all(|x| x.is_finite()),
        "{}: a pixel is not finite",
        c.dir
    );
    let lit = pixels
        .iter()
        .filter(|p| p.iter().sum::<f64>() > 0.0)
        .count();
    assert!(
        lit * 4 > pixels.len(),
        "{}: {lit} of {} pixels lit",
        c.dir,
        pixels.len()
    );
}

/// McGuire's CornellBox-Sphere (2 188 triangles; a mirror and a glass sphere, taken as their
/// diffuse part): before issue #31 its bake failed on the smooth weights' check.
#[test]
fn cornell_sphere() {
    bakes_with_the_defaults(&Case {
        dir: "cornell-sphere",
        file: "CornellBox-Sphere.obj",
        lit: &["floor", "ceiling", "backWall", "leftWall", "rightWall"],
        eye: CORNELL_EYE,
        target: CORNELL_TARGET,
    });
}

/// McGuire's CornellBox-Mirror (36 triangles: non-planar quads, duplicate faces).
#[test]
fn cornell_mirror() {
    bakes_with_the_defaults(&Case {
        dir: "cornell-mirror",
        file: "CornellBox-Mirror.obj",
        lit: &["floor", "ceiling", "backWall"],
        eye: [0.0, 1.0, 3.6],
        target: [0.0, 1.0, 0.0],
    });
}

/// Godot's living room (5 088 triangles, 3 537 of them without area; two emitting panels
/// added where Godot's scene has its bulbs): before issue #31 its bake failed on the smooth
/// weights' check after printing a warning per degenerate triangle.
#[test]
fn living_room() {
    bakes_with_the_defaults(&Case {
        dir: "living-room",
        file: "living-room.toml",
        lit: &["panel-west", "panel-east"],
        // Godot's camera of the scene (godot_test_scene.tscn), looking into the room.
        eye: [-2.932, 2.207, -1.895],
        target: [-1.80, 2.12, -0.25],
    });
}

/// McGuire's CornellBox-Water (7 088 triangles, a water surface of many small ones, grouped
/// into elements of about the element size since issue #31; before, its bake took minutes).
#[test]
fn cornell_water() {
    bakes_with_the_defaults(&Case {
        dir: "cornell-water",
        file: "CornellBox-Water.obj",
        lit: &["floor", "ceiling", "backWall"],
        eye: CORNELL_EYE,
        target: CORNELL_TARGET,
    });
}

/// Godot's GI demo level zdm2 (58 772 triangles) under a sky quad: issue #31's goal, a default
/// bake within 10 minutes and 4 GB on two cores (measured 105 s, 1.22 GB, n = 11 187;
/// docs/MESHING.md, "Real scenes"). Before issue #31 it aborted, then was refused.
#[test]
fn zdm2() {
    bakes_with_the_defaults(&Case {
        dir: "zdm2",
        file: "zdm2.toml",
        lit: &["zdm2"],
        eye: [0.0, 8.0, -20.0],
        target: [0.0, 4.0, 0.0],
    });
}
