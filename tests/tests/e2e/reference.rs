//! Against an independent path tracer: lrr's default bakes at the points where Mitsuba 3's
//! unbiased path tracer measured the radiosity, with its standard error
//! (`tests/data/reference/`, made by `scripts/reference/run.py`; the renderer is never needed
//! here). The reference itself is first held to closed forms (a furnace, a square under a
//! parallel emitting square) in units of its standard error.
//!
//! Error of a point: `‖B_lrr − B_ref‖₁ / ‖B_ref‖₁` over the three channels, `B_lrr` the value
//! of the element the point falls in (`Operator::locate`, the flat reconstruction) and the
//! smooth reconstruction's value there (`Reconstruction`, what `lrr probe` returns by default).
//! The reference's noise at a point: `‖stderr‖₁ / ‖B_ref‖₁`.

use std::path::{Path, PathBuf};
use std::time::Instant;

use lrr_runtime::{Operator, Reconstruction};
use serde_json::Value;
use sha2::{Digest, Sha256};

use crate::util::{bake, cornell, root, temp_dir};

/// One reference point: where, which surface, and the path tracer's B with its stderr.
pub(super) struct RefPoint {
    pub surface: String,
    pub position: [f64; 3],
    pub normal: [f64; 3],
    pub b: [f64; 3],
    pub stderr: [f64; 3],
}

fn data_dir() -> PathBuf {
    root().join("tests/data/reference")
}

fn triple(v: &Value) -> [f64; 3] {
    let a = v.as_array().expect("a JSON array of 3 numbers");
    [0, 1, 2].map(|i| a[i].as_f64().expect("a number"))
}

/// The committed reference `NAME.json`: its document and its points. Refuses a reference made
/// from another version of its scene file ([`assert_fresh`]).
pub(super) fn load_reference(name: &str) -> (Value, Vec<RefPoint>) {
    let path = data_dir().join(format!("{name}.json"));
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (made by scripts/reference/run.py)", path.display()));
    let doc: Value = serde_json::from_str(&text).unwrap();
    assert_fresh(name, &doc);
    let points = doc["points"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| RefPoint {
            surface: p["surface"].as_str().unwrap().to_string(),
            position: triple(&p["position"]),
            normal: triple(&p["normal"]),
            b: triple(&p["radiosity"]),
            stderr: triple(&p["stderr"]),
        })
        .collect();
    (doc, points)
}

pub(super) fn scene_path(doc: &Value) -> PathBuf {
    root().join(doc["scene"].as_str().unwrap())
}

/// Refuses a reference made from other bytes than its scene file now holds: its
/// `scene_sha256` (written by `scripts/reference/run.py`) must be the file's SHA-256.
pub(super) fn assert_fresh(name: &str, doc: &Value) {
    let path = scene_path(doc);
    let bytes = std::fs::read(&path)
        .unwrap_or_else(|e| panic!("{name}: its scene {}: {e}", path.display()));
    let hash: String = Sha256::digest(&bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    assert_eq!(
        doc["scene_sha256"].as_str(),
        Some(hash.as_str()),
        "{name}: {} changed since its reference was made; remake it with \
         `python3 scripts/reference/run.py --only {name}` (scripts/setup-reference.sh first)",
        path.display()
    );
}

pub(super) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
pub(super) fn l1(a: [f64; 3]) -> f64 {
    a.iter().map(|x| x.abs()).sum()
}

/// Every point lies on a face of its surface, front side, in lrr's import of the scene today:
/// a changed scene fails here instead of being compared with a stale reference.
fn assert_points_on_scene(scene: &Path, points: &[RefPoint]) {
    let s = lrr_precompute::scene::load(scene).unwrap();
    let tol = 1e-6 * s.extent();
    for (i, p) in points.iter().enumerate() {
        let on = s.faces.iter().any(|f| {
            let poly = &f.polygon;
            let n = poly.normal.to_array();
            let v: Vec<[f64; 3]> = poly.vertices().iter().map(|v| v.to_array()).collect();
            s.surfaces[f.surface] == p.surface
                && dot(n, p.normal) > 1.0 - 1e-6
                && dot(n, sub(p.position, v[0])).abs() <= tol
                && (0..v.len()).all(|j| {
                    let e = sub(v[(j + 1) % v.len()], v[j]);
                    dot(cross(e, sub(p.position, v[j])), n)
                        >= -tol * e.iter().map(|x| x.abs()).sum::<f64>()
                })
        });
        assert!(
            on,
            "{}: reference point {i} ({:?} on '{}') is on no face of that surface: the scene \
             changed since the reference was made; rerun scripts/reference/run.py",
            scene.display(),
            p.position,
            p.surface
        );
    }
}

/// Quantile `q` of `v` (nearest rank on the sorted values).
pub(super) fn quantile(v: &[f64], q: f64) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[((q * (s.len() - 1) as f64).round() as usize).min(s.len() - 1)]
}

/// Median, 90th percentile and max of the per-point relative error, and the reference's noise.
#[derive(Debug)]
pub(super) struct Errors {
    pub median: f64,
    pub p90: f64,
    pub max: f64,
    pub noise_median: f64,
    pub noise_p90: f64,
}

pub(super) fn errors(points: &[RefPoint], values: &[[f64; 3]]) -> Errors {
    let rel: Vec<f64> = points
        .iter()
        .zip(values)
        .map(|(p, v)| l1(sub(*v, p.b)) / l1(p.b))
        .collect();
    let noise: Vec<f64> = points.iter().map(|p| l1(p.stderr) / l1(p.b)).collect();
    Errors {
        median: quantile(&rel, 0.5),
        p90: quantile(&rel, 0.9),
        max: quantile(&rel, 1.0),
        noise_median: quantile(&noise, 0.5),
        noise_p90: quantile(&noise, 0.9),
    }
}

/// B of the element each point falls in (the flat reconstruction of `lrr probe`); asserts the
/// display face it lies on faces the way the point does.
fn flat_values(op: &Operator, points: &[RefPoint]) -> Vec<[f64; 3]> {
    let b = op.evaluate_baked();
    let faces = op.file().faces();
    points
        .iter()
        .map(|p| {
            let face = op
                .locate_face(p.position.map(|x| x as f32), p.normal.map(|x| x as f32))
                .unwrap();
            let id = op.file().order[faces.element(face)] as usize;
            let n = faces.geometry.normal(face).map(f64::from);
            assert!(
                dot(n, p.normal) > 0.99,
                "point {:?} on '{}' was located in element {id} facing {n:?}",
                p.position,
                p.surface
            );
            b[id].map(f64::from)
        })
        .collect()
}

/// The smooth reconstruction at each point (`lrr probe`'s default), on the display face
/// `locate_face` finds.
fn smooth_values(op: &Operator, points: &[RefPoint]) -> Vec<[f64; 3]> {
    let b = op.evaluate_baked();
    let r = Reconstruction::new(op.file()).expect("a default bake carries smooth weights");
    let mut vertices = vec![[0.0f32; 3]; r.vertex_count()];
    r.vertex_values(&b, &mut vertices).unwrap();
    points
        .iter()
        .map(|p| {
            let position = p.position.map(|x| x as f32);
            let face = op
                .locate_face(position, p.normal.map(|x| x as f32))
                .unwrap();
            r.at(&vertices, face, position).map(f64::from)
        })
        .collect()
}

/// Bakes the scene of reference `name` with the default settings and measures its error, flat
/// and smooth.
fn default_bake_against_reference(name: &str) -> (Errors, Errors) {
    bake_against_reference(name, &[])
}

/// Bakes the scene of reference `name` with the flags `extra` and measures its error, flat
/// and smooth.
fn bake_against_reference(name: &str, extra: &[&str]) -> (Errors, Errors) {
    bake_against_noisy_reference(name, extra, 0.3)
}

/// [`bake_against_reference`], the reference's p90 noise allowed up to `noise_share` of the
/// median error it measures.
fn bake_against_noisy_reference(name: &str, extra: &[&str], noise_share: f64) -> (Errors, Errors) {
    let (doc, points) = load_reference(name);
    let scene = scene_path(&doc);
    assert_points_on_scene(&scene, &points);
    let out = temp_dir(&format!("reference-{name}")).join(format!("{name}.lrr"));
    let start = Instant::now();
    bake(&scene, &out, extra).unwrap();
    let seconds = start.elapsed().as_secs_f64();
    let op = Operator::load(&out).unwrap();
    let e = errors(&points, &flat_values(&op, &points));
    let smooth = errors(&points, &smooth_values(&op, &points));
    println!(
        "{name} {extra:?}: n = {}, k = {}, bake {seconds:.1} s; against {} reference points: flat median \
         {:.2}%, p90 {:.2}%, max {:.1}%; smooth median {:.2}%, p90 {:.2}%, max {:.1}%; \
         reference noise median {:.2}%, p90 {:.2}% ({})",
        op.n(),
        op.k(),
        points.len(),
        100.0 * e.median,
        100.0 * e.p90,
        100.0 * e.max,
        100.0 * smooth.median,
        100.0 * smooth.p90,
        100.0 * smooth.max,
        100.0 * e.noise_median,
        100.0 * e.noise_p90,
        doc["renderer"].as_str().unwrap(),
    );
    // Cornell: the reference's p90 noise 0.48% against the smooth median 1.34% (0.36×).
    assert!(
        e.noise_p90 < noise_share * smooth.median.min(e.median),
        "{name}: the reference's noise ({e:?}) is not small against the error it measures"
    );
    (e, smooth)
}

/// Asserts measured errors within `FACTOR` of what they were when these tests were written
/// (`expected` = median, p90, max; docs/ACCURACY.md, "Against an independent path tracer"):
/// a regression of the bake or of `locate` fails here. Bakes are deterministic, so the
/// measured values only move when the bake does; an improvement should lower `expected`.
fn assert_within(name: &str, e: &Errors, expected: [f64; 3]) {
    const FACTOR: f64 = 1.25;
    for (what, got, was) in [
        ("median", e.median, expected[0]),
        ("90th percentile", e.p90, expected[1]),
        ("max", e.max, expected[2]),
    ] {
        assert!(
            got <= FACTOR * was,
            "{name}: {what} relative error {got:.4} against the path tracer, more than \
             {FACTOR} × the {was:.4} measured when the test was written"
        );
    }
}

/// Measured smooth errors (median, p90, max) of the default bakes (docs/ACCURACY.md: 2MSC by
/// merging at its default threshold 7e-5, refined where light changes with `--refine 0.2`;
/// the closed scenes with their enclosed rows summing to one).
const CORNELL_SMOOTH: [f64; 3] = [0.0133, 0.0435, 1.138];
const CLUTTERED_SMOOTH: [f64; 3] = [0.0102, 0.0562, 1.544];
const SPHERE_SMOOTH: [f64; 3] = [0.0147, 0.0406, 0.180];

/// Issue #14's goal for the Cornell box, met by the default bake: median ≤ 2% and p90 ≤ 5%
/// against the path tracer (smooth; measured 1.33% / 4.35%, n = 2 539, k = 162: docs/ACCURACY.md;
/// by the split rule, the default before, 1.34% / 4.65% with k = 333).
#[test]
fn cornell_box_default_bake_against_the_path_tracer_meets_the_goal() {
    // The reference's p90 noise (0.48%) is 0.36 of the smooth median: still well under the p90.
    let (e, smooth) = bake_against_noisy_reference("cornell-box", &[], 0.4);
    assert_eq!(
        scene_path(&load_reference("cornell-box").0),
        cornell(),
        "the Cornell reference is of the shipped scene"
    );
    assert_within("cornell-box", &e, [0.0258, 0.0889, 0.504]);
    assert_within("cornell-box smooth", &smooth, CORNELL_SMOOTH);
    assert!(
        smooth.median <= 0.02 && smooth.p90 <= 0.05,
        "the goal: median {:.4} ≤ 0.02 and p90 {:.4} ≤ 0.05",
        smooth.median,
        smooth.p90
    );
}

#[test]
fn cluttered_room_default_bake_against_the_path_tracer() {
    let (e, smooth) = default_bake_against_reference("cluttered");
    assert_within("cluttered", &e, [0.0222, 0.1068, 1.798]);
    assert_within("cluttered smooth", &smooth, CLUTTERED_SMOOTH);
}

/// The dense sphere's description asks for h = 0.125, but before issue #31 each of its 1 280
/// sphere faces was an element whatever h said (n = 2 020, the errors below). Its small faces
/// are now grouped into elements of about h (n = 565 at 0.125: flat median 3.1%, smooth
/// 2.2%, docs/ACCURACY.md); at this element size it has about the former n (2 244), and
/// is held to the errors measured then.
const SPHERE_FORMER_N: &[&str] = &["--element-size", "0.0625"];

#[test]
fn dense_sphere_bake_at_its_former_element_count_against_the_path_tracer() {
    // Measured at n = 2 244: smooth median 0.78%, p90 2.45%; the reference's p90 noise
    // (0.25%) is then 0.32× the median.
    let (e, smooth) = bake_against_noisy_reference("dense-sphere", SPHERE_FORMER_N, 0.4);
    assert_within("dense-sphere", &e, [0.0212, 0.0723, 0.419]);
    assert_within("dense-sphere smooth", &smooth, SPHERE_SMOOTH);
}

/// Measured errors (flat, then smooth: median, p90, max) of the default bakes without the
/// refinement, `--refine 0` (docs/ACCURACY.md, "Refinement where light changes").
const CORNELL_UNREFINED: [[f64; 3]; 2] = [[0.0261, 0.0899, 2.483], [0.0138, 0.0499, 1.846]];
const CLUTTERED_UNREFINED: [[f64; 3]; 2] = [[0.0225, 0.1054, 1.798], [0.0098, 0.0915, 1.946]];
const SPHERE_UNREFINED: [[f64; 3]; 2] = [[0.0259, 0.0871, 0.469], [0.0200, 0.0684, 0.168]];

/// `--refine 0` against the path tracer: within 1.25× of what it measured, and the default
/// (refined) bake's smooth p90 below 0.9× of it (the refinement's purpose: the worst points
/// lie where one element straddles a change).
fn unrefined_against_reference(
    name: &str,
    extra: &[&str],
    expected: [[f64; 3]; 2],
    default_smooth: [f64; 3],
    noise_share: f64,
) {
    let flags: Vec<&str> = extra.iter().copied().chain(["--refine", "0"]).collect();
    let (e, smooth) = bake_against_noisy_reference(name, &flags, noise_share);
    assert_within(&format!("{name} --refine 0"), &e, expected[0]);
    assert_within(&format!("{name} --refine 0 smooth"), &smooth, expected[1]);
    assert!(
        default_smooth[1] < 0.9 * expected[1][1],
        "{name}: the refined default's smooth p90 {:.4} is not below the unrefined {:.4}",
        default_smooth[1],
        expected[1][1]
    );
}

#[test]
fn cornell_box_unrefined_bake_against_the_path_tracer() {
    unrefined_against_reference("cornell-box", &[], CORNELL_UNREFINED, CORNELL_SMOOTH, 0.4);
}

#[test]
fn cluttered_room_unrefined_bake_against_the_path_tracer() {
    unrefined_against_reference("cluttered", &[], CLUTTERED_UNREFINED, CLUTTERED_SMOOTH, 0.3);
}

#[test]
fn dense_sphere_unrefined_bake_against_the_path_tracer() {
    unrefined_against_reference(
        "dense-sphere",
        SPHERE_FORMER_N,
        SPHERE_UNREFINED,
        SPHERE_SMOOTH,
        0.4,
    );
}

/// z-scores of the reference against exact values, per point and channel with stderr > 0.
fn z_scores(points: &[RefPoint], exact: &[[f64; 3]]) -> Vec<f64> {
    points
        .iter()
        .zip(exact)
        .flat_map(|(p, x)| (0..3).map(move |c| (p.b[c] - x[c], p.stderr[c])))
        .filter(|&(_, se)| se > 0.0)
        .map(|(d, se)| d / se)
        .collect()
}

/// The reference is unbiased within its noise where the answer is known: the z-scores have an
/// RMS near 1 and no outlier beyond 4.5 σ (p ≈ 7e-6 per value for a normal error).
fn assert_unbiased(name: &str, points: &[RefPoint], exact: &[[f64; 3]]) {
    let z = z_scores(points, exact);
    assert!(z.len() >= 60, "{name}: only {} values", z.len());
    let rms = (z.iter().map(|x| x * x).sum::<f64>() / z.len() as f64).sqrt();
    let mean = z.iter().sum::<f64>() / z.len() as f64;
    let worst = z.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let noise = quantile(
        &points
            .iter()
            .map(|p| l1(p.stderr) / l1(p.b))
            .collect::<Vec<_>>(),
        0.5,
    );
    println!(
        "{name}: {} values, mean z {mean:.2}, rms z {rms:.2}, max |z| {worst:.2}, median \
         relative stderr {noise:.1e}",
        z.len()
    );
    // With m independent values the mean of z has a spread of 1/√m, the RMS of about
    // 1/√(2m). A point's three channels come from the same paths (identical in a grey scene):
    // m counts points, not values.
    let m = points.len() as f64;
    assert!(mean.abs() < 4.0 / m.sqrt(), "{name}: biased: mean z {mean}");
    assert!(
        (rms - 1.0).abs() < 4.0 / (2.0 * m).sqrt(),
        "{name}: rms z {rms}"
    );
    assert!(worst < 4.5, "{name}: an outlier of {worst} σ");
}

#[test]
fn the_reference_meets_the_furnace() {
    let (doc, points) = load_reference("furnace");
    let scene = lrr_precompute::scene::load(&scene_path(&doc)).unwrap();
    assert_points_on_scene(&scene_path(&doc), &points);
    let m = &scene.materials[0];
    let exact = [0, 1, 2].map(|c| m.emission[c] / (1.0 - m.reflectance[c]));
    assert_unbiased("furnace", &points, &vec![exact; points.len()]);
}

/// View factor from a point to a parallel `a × b` rectangle at distance `c` facing it, the
/// point under one corner (Howell's catalogue, B-3).
fn corner_factor(a: f64, b: f64, c: f64) -> f64 {
    let (x, y) = (a / c, b / c);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
}

#[test]
fn the_reference_meets_a_square_under_an_emitting_square() {
    let (doc, points) = load_reference("squares");
    let scene = lrr_precompute::scene::load(&scene_path(&doc)).unwrap();
    assert_points_on_scene(&scene_path(&doc), &points);
    let material = |name: &str| scene.materials.iter().find(|m| m.name == name).unwrap();
    let (rho, e) = (
        material("receiver").reflectance,
        material("emitter").emission,
    );
    let mut receivers = 0;
    let exact: Vec<[f64; 3]> = points
        .iter()
        .map(|p| {
            if p.surface == "emitter" {
                return e;
            }
            receivers += 1;
            let [x, y, _] = p.position;
            let f: f64 = [x, 1.0 - x]
                .iter()
                .flat_map(|&u| [y, 1.0 - y].map(|v| corner_factor(u, v, 1.0)))
                .sum();
            [0, 1, 2].map(|c| rho[c] * e[c] * f)
        })
        .collect();
    assert!(receivers >= 20, "{receivers} receiver points");
    for (p, x) in points.iter().zip(&exact) {
        if p.surface == "emitter" {
            let rel = l1(sub(p.b, *x)) / l1(*x);
            assert!(
                rel < 1e-6,
                "the emitter's B is E exactly (ρ = 0): {:?}",
                p.b
            );
        }
    }
    assert_unbiased("squares", &points, &exact);
}
