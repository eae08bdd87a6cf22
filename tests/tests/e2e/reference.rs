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

/// Median, 90th and 99th percentile of the per-point relative error, and the reference's noise.
#[derive(Debug)]
pub(super) struct Errors {
    pub median: f64,
    pub p90: f64,
    pub p99: f64,
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
        p99: quantile(&rel, 0.99),
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

/// Bakes the scene of reference `name` with the flags `extra` and measures its error, flat
/// and smooth; the reference's p90 noise must be under `noise_share` of the median error it
/// measures (else the reference, not the bake, would decide the figures).
fn bake_against_reference(name: &str, extra: &[&str], noise_share: f64) -> (Errors, Errors) {
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
         {:.2}%, p90 {:.2}%, p99 {:.1}%; smooth median {:.2}%, p90 {:.2}%, p99 {:.1}%; \
         reference noise median {:.2}%, p90 {:.2}% ({})",
        op.n(),
        op.k(),
        points.len(),
        100.0 * e.median,
        100.0 * e.p90,
        100.0 * e.p99,
        100.0 * smooth.median,
        100.0 * smooth.p90,
        100.0 * smooth.p99,
        100.0 * e.noise_median,
        100.0 * e.noise_p90,
        doc["renderer"].as_str().unwrap(),
    );
    assert!(
        e.noise_p90 < noise_share * smooth.median.min(e.median),
        "{name}: the reference's noise ({e:?}) is not small against the error it measures"
    );
    (e, smooth)
}

/// Ceilings of the smooth error against the path tracer: median, p90, p99.
///
/// [`GOAL`] is issue #14's goal for the Cornell box (median ≤ 2 %, p90 ≤ 5 %; issue #32 set the
/// same for the lights that are not surfaces, `lights.rs`), with a p99 ceiling of 20 %: the
/// worst points lie where one element straddles a shadow or contact line, and a point off by
/// more than a fifth at the 99th percentile would mean light or shadow put on the wrong
/// element, not an element too coarse. None of these was read off a run.
pub(super) const GOAL: [f64; 3] = [0.02, 0.05, 0.20];
/// The two default bakes that do not reach [`GOAL`] (the cluttered room: contact lines of
/// thin slanted boards; the dense sphere at its description's coarse element size, n = 565)
/// are held below this instead: 1.25× the goal's median, 1.6× its p90 and 1.5× its p99. They
/// are open items of issue #31 (docs/ACCURACY.md), not a claim.
const SHORT_OF_GOAL: [f64; 3] = [0.025, 0.08, 0.30];

pub(super) fn assert_below(name: &str, e: &Errors, ceiling: [f64; 3]) {
    for (what, got, most) in [
        ("median", e.median, ceiling[0]),
        ("90th percentile", e.p90, ceiling[1]),
        ("99th percentile", e.p99, ceiling[2]),
    ] {
        assert!(
            got <= most,
            "{name}: {what} relative error {got:.4} against the path tracer, above its ceiling \
             {most}"
        );
    }
}

/// The smooth reconstruction (what `lrr probe` returns) beats the flat value of the element at
/// the median, measured on the same bake.
fn assert_smooth_beats_flat(name: &str, flat: &Errors, smooth: &Errors) {
    assert!(
        smooth.median < flat.median,
        "{name}: smooth median {:.4} not below flat {:.4}",
        smooth.median,
        flat.median
    );
}

/// The default bake and the same bake without the refinement (`--refine 0`), measured in the
/// same run: the refinement's purpose is a lower p90 (the worst points lie where one element
/// straddles a change, which interpolation cannot mend and splitting does). Returns the
/// default bake's smooth errors.
fn refined_against_unrefined(name: &str, extra: &[&str], noise_share: f64) -> Errors {
    let (flat, smooth) = bake_against_reference(name, extra, noise_share);
    let unrefined: Vec<&str> = extra.iter().copied().chain(["--refine", "0"]).collect();
    let (_, smooth_unrefined) = bake_against_reference(name, &unrefined, noise_share);
    assert_smooth_beats_flat(name, &flat, &smooth);
    println!(
        "{name}: refined / unrefined smooth p90 = {:.3}",
        smooth.p90 / smooth_unrefined.p90
    );
    assert!(
        smooth.p90 < smooth_unrefined.p90,
        "{name}: the refined bake's smooth p90 {:.4} is not below the unrefined bake's {:.4}",
        smooth.p90,
        smooth_unrefined.p90
    );
    smooth
}

/// Issue #14's goal for the Cornell box, met by the default bake (smooth; docs/ACCURACY.md).
#[test]
fn cornell_box_default_bake_against_the_path_tracer_meets_the_goal() {
    assert_eq!(
        scene_path(&load_reference("cornell-box").0),
        cornell(),
        "the Cornell reference is of the shipped scene"
    );
    // The reference's p90 noise (about 0.5%) is about 0.36 of the smooth median.
    let smooth = refined_against_unrefined("cornell-box", &[], 0.4);
    assert_below("cornell-box smooth", &smooth, GOAL);
}

/// A closed room of differing walls lit by a floating emitting box, with floating occluders:
/// visibility decides the answer (issue #33; the uniform furnace cannot tell).
#[test]
fn occluded_room_default_bake_against_the_path_tracer_meets_the_goal() {
    // 1 048 576 paths per point (8× the others: a small lamp in a closed room of high
    // reflectance); the reference's p90 noise (0.36%) is then 0.33 of the smooth median.
    let smooth = refined_against_unrefined("occluded", &[], 0.4);
    assert_below("occluded smooth", &smooth, GOAL);
}

#[test]
fn cluttered_room_default_bake_against_the_path_tracer() {
    let smooth = refined_against_unrefined("cluttered", &[], 0.3);
    assert_below("cluttered smooth", &smooth, SHORT_OF_GOAL);
}

/// The dense sphere's description asks for h = 0.125: its 1 280 small sphere faces are grouped
/// into elements of about h (issue #31; n = 565). At half that size it has about the element
/// count it had when every face was an element (n ≈ 2 200) and meets the goal; the coarse
/// default is short of it. Both bakes are measured here, and the finer one must be the better.
#[test]
fn dense_sphere_bakes_against_the_path_tracer() {
    let (flat, coarse) = bake_against_reference("dense-sphere", &[], 0.4);
    assert_smooth_beats_flat("dense-sphere", &flat, &coarse);
    assert_below("dense-sphere smooth", &coarse, SHORT_OF_GOAL);
    let fine = refined_against_unrefined("dense-sphere", &["--element-size", "0.0625"], 0.4);
    assert_below("dense-sphere --element-size 0.0625 smooth", &fine, GOAL);
    assert!(
        fine.median < coarse.median && fine.p90 < coarse.p90,
        "dense-sphere: halving the element size did not lower the error: {fine:?} against {coarse:?}"
    );
}

/// The reference read each scene itself (scripts/reference/description.py, no lrr code): its
/// surfaces, their areas and materials as it read them (`surfaces` in the JSON) are lrr's
/// import of the same file. An importer or unit error of either side fails here.
#[test]
fn the_reference_and_lrr_read_each_scene_alike() {
    let mut checked = 0;
    for entry in std::fs::read_dir(data_dir()).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_stem().unwrap().to_str().unwrap().to_string();
        if path.extension().is_none_or(|e| e != "json") || name.ends_with("-image") {
            continue;
        }
        let (doc, _) = load_reference(&name);
        let theirs = doc["surfaces"].as_array().unwrap_or_else(|| {
            panic!("{name}: no `surfaces` (made before scripts/reference read scenes itself)")
        });
        let scene = lrr_precompute::scene::load(&scene_path(&doc)).unwrap();
        let mut area = vec![0.0; scene.surfaces.len()];
        let mut material = vec![None; scene.surfaces.len()];
        for f in &scene.faces {
            area[f.surface] += f.polygon.area();
            assert!(
                material[f.surface].is_none_or(|m| m == f.material),
                "{name}: surface '{}' has two materials",
                scene.surfaces[f.surface]
            );
            material[f.surface] = Some(f.material);
        }
        let names: Vec<&str> = theirs.iter().map(|s| s["name"].as_str().unwrap()).collect();
        assert_eq!(names, scene.surfaces, "{name}: the surfaces differ");
        for (s, t) in theirs.iter().enumerate() {
            let m = &scene.materials[material[s].unwrap()];
            let what = format!("{name}: surface '{}'", scene.surfaces[s]);
            let a = t["area"].as_f64().unwrap();
            assert!(
                (a - area[s]).abs() <= 1e-12 * area[s],
                "{what}: area {a} in the reference, {} in lrr",
                area[s]
            );
            assert_eq!(t["material"].as_str(), Some(m.name.as_str()), "{what}");
            let (rho, e) = (triple(&t["reflectance"]), triple(&t["emission"]));
            for c in 0..3 {
                assert_eq!(rho[c], m.reflectance[c], "{what}: reflectance");
                assert!(
                    (e[c] - m.emission[c]).abs() <= 1e-15 * m.emission[c].abs(),
                    "{what}: emission {e:?} in the reference, {:?} in lrr",
                    m.emission
                );
            }
        }
        checked += 1;
    }
    assert!(checked >= 13, "{checked} references checked");
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
