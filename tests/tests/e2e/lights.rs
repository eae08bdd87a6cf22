//! Lights that are not surfaces (issue #32, DESIGN.md §9), end to end: scene description →
//! `lrr bake` → `lrr probe` / `lrr render`, against the independent path tracer
//! (`tests/data/reference/`, Mitsuba's `point`, `spot`, `directional` and `constant` emitters;
//! `scripts/reference/lights.py` reads the lights from the description itself).
//!
//! - Closed forms: a unit square (ρ = 0.5) under a point light, a spot, a sun and a uniform sky,
//!   nothing else: one bounce is exact, `B = ρ I cos θ / r²`, `ρ E⊥ cos θ`, `ρ π L`. lrr adds
//!   the direct light at the probed point itself (the square's own radiosity has no bounce), so
//!   it meets the reference's noise-free values to f32 rounding.
//! - The Cornell box with its lamp dark, lit by (a) a point light inside, (b) a spot, (c) a sun
//!   through the open side, (d) a uniform sky: issue #32's goal, median ≤ 2 % and p90 ≤ 5 %
//!   relative error at the reference points, default bake and `lrr probe`.
//! - A reference records the SHA-256 of the scene it was made from; a changed scene fails with
//!   how to remake it (`load_reference` checks it, `reference::assert_fresh`).

use crate::reference::{GOAL, RefPoint, assert_below, errors, l1, load_reference, scene_path, sub};
use crate::util::{bake, lrr, lrr_json, probe, temp_dir};

/// Bakes the reference scene `name` with the default flags and probes it at the reference's
/// points (`lrr probe --json`, smooth by default): the values and the operator's n and k.
fn bake_and_probe(name: &str, points: &[RefPoint], scene: &std::path::Path) -> Vec<[f64; 3]> {
    let dir = temp_dir(&format!("lights-{name}"));
    let out = dir.join(format!("{name}.lrr"));
    bake(scene, &out, &[]).unwrap();
    let at: Vec<([f64; 3], [f64; 3])> = points.iter().map(|p| (p.position, p.normal)).collect();
    probe(&out, &at)
}

#[test]
fn a_square_under_each_light_meets_its_closed_form() {
    for (name, tolerance) in [
        // Deterministic references (stderr 0): the closed forms to ~6e-7.
        ("point-square", 1e-5),
        ("spot-square", 1e-5),
        ("sun-square", 1e-5),
        // The sky's reference is a Monte Carlo estimate (relative stderr 1.9e-3 at most);
        // lrr's open plane sees π L exactly.
        ("sky-square", 1e-2),
    ] {
        let (doc, points) = load_reference(name);
        let values = bake_and_probe(name, &points, &scene_path(&doc));
        let mut worst = 0.0f64;
        for (p, v) in points.iter().zip(&values) {
            let scale = l1(p.b).max(1e-9);
            let e = l1(sub(*v, p.b)) / scale;
            if l1(p.b) == 0.0 {
                // Outside the spot's cone: dark, within f32 rounding of zero.
                assert!(
                    l1(*v) < 1e-6,
                    "{name}: {:?} should be dark, got {v:?}",
                    p.position
                );
                continue;
            }
            worst = worst.max(e);
        }
        println!(
            "{name}: worst relative error {worst:.2e} over {} points",
            points.len()
        );
        assert!(
            worst < tolerance,
            "{name}: worst {worst:.2e}, allowed {tolerance:.0e}"
        );
    }
}

#[test]
fn the_cornell_box_lit_by_each_light_meets_issue_32s_goal() {
    for name in [
        "cornell-point",
        "cornell-spot",
        "cornell-sun",
        "cornell-sky",
    ] {
        let (doc, points) = load_reference(name);
        let values = bake_and_probe(name, &points, &scene_path(&doc));
        let e = errors(&points, &values);
        println!(
            "{name}: {} points: median {:.2}%, p90 {:.2}%, p99 {:.1}%; reference noise median \
             {:.2}%, p90 {:.2}%",
            points.len(),
            100.0 * e.median,
            100.0 * e.p90,
            100.0 * e.p99,
            100.0 * e.noise_median,
            100.0 * e.noise_p90
        );
        // Issue #32's goal (median ≤ 2 %, p90 ≤ 5 %) and the p99 ceiling of every reference.
        assert_below(name, &e, GOAL);
    }
}

#[test]
fn a_frame_without_lights_casts_no_shadow_ray_and_with_them_it_does() {
    let dir = temp_dir("lights-render");
    // The Cornell box has an emitting lamp and no other light: no direct pass, no shadow ray.
    let plain = dir.join("cornell.lrr");
    bake(&crate::util::cornell(), &plain, &["--element-size", "100"]).unwrap();
    let png = dir.join("a.png");
    let text = lrr(&[
        "render",
        plain.to_str().unwrap(),
        "--size",
        "32x32",
        "--explain",
        "-o",
        png.to_str().unwrap(),
    ])
    .unwrap();
    assert!(text.contains("direct pass: none"), "{text}");
    assert!(text.contains(" 0 shadow"), "{text}");
    // The same file with a sun from the flags: the pass traces, each hit casts its ray.
    let text = lrr(&[
        "render",
        plain.to_str().unwrap(),
        "--size",
        "32x32",
        "--explain",
        "--sun",
        "0.2,-1,0.3:2,2,2",
        "-o",
        png.to_str().unwrap(),
    ])
    .unwrap();
    assert!(text.contains("direct pass: 1 light and no sky"), "{text}");
    assert!(!text.contains(" 0 shadow"), "{text}");
    // Bad flags name themselves.
    let e = lrr(&[
        "render",
        plain.to_str().unwrap(),
        "--spot-light",
        "1,2,3:0,0,0:1,1,1:10,20",
        "-o",
        png.to_str().unwrap(),
    ])
    .unwrap_err();
    assert!(e.contains("direction"), "{e}");
    let e = lrr(&[
        "render",
        plain.to_str().unwrap(),
        "--point-light",
        "1,2:3,3,3",
        "-o",
        png.to_str().unwrap(),
    ])
    .unwrap_err();
    assert!(
        e.contains("--point-light 1,2:3,3,3") && e.contains("three numbers"),
        "{e}"
    );
}

/// DESIGN.md §9: a uniform sky over an open plane gives `π L`, inside a closed box nothing; a
/// sun outside the box nothing either. The closed box is convex, where pairs of faces need no
/// visibility test (`visibility::nothing_occludes`): lights still do (the walls block the sky),
/// so the bake builds its occluder for them, and its stored sky transfer is zero.
#[test]
fn a_closed_box_sees_no_sky_and_no_sun() {
    let dir = temp_dir("lights-closed");
    let scene = crate::util::generated_scene(&dir, "box", &["furnace", "--reflectance", "0.5"]);
    let mut text = std::fs::read_to_string(&scene).unwrap();
    text += "\n[[directional_light]]\nname = \"sun\"\ndirection = [0.2, -1, 0.3]\nirradiance = [5, 5, 5]\n\
             [sky]\nradiance = [1, 1, 1]\n";
    std::fs::write(&scene, text).unwrap();
    let out = dir.join("box.lrr");
    let report = bake(&scene, &out, &[]).unwrap();
    let op = lrr_runtime::Operator::load(&out).unwrap();
    let t = op
        .file()
        .display
        .sky_transfer
        .as_ref()
        .expect("a sky's transfer");
    assert!(
        t.iter().all(|&x| x == 0.0),
        "every sky ray is blocked: {report}"
    );
    // The frame: only the furnace's own emission, as without the lights.
    let lit = lrr_json(&["info", out.to_str().unwrap(), "--json"]);
    assert_eq!(lit["display"]["sky_transfer"], true, "{lit}");
    let points = dir.join("p.json");
    std::fs::write(
        &points,
        r#"[{"position": [0.5, 0.5, 0.0], "normal": [0, 0, 1]}]"#,
    )
    .unwrap();
    let probe = |extra: &[&str]| {
        let mut args = vec![
            "probe",
            out.to_str().unwrap(),
            "--points",
            points.to_str().unwrap(),
            "--json",
        ];
        args.extend_from_slice(extra);
        lrr_json(&args)[0]["radiosity"][0].as_f64().unwrap()
    };
    let with = probe(&[]);
    let without = probe(&["--no-file-lights"]);
    assert!(
        (with - without).abs() <= 1e-6 * without,
        "{with} vs {without}: the box's walls block the sky and the sun"
    );
}
