//! The Cornell box: reciprocity, low-rank against exact, plausibility, determinism, OBJ import
//! (the project's OBJ generated from its description; the public archive OBJ as an optional
//! cross-check).

use lrr_precompute::scene::Scene;
use lrr_precompute::scene::description::SceneDescription;
use lrr_runtime::Operator;

use crate::util::{
    archive_cornell_obj, bake, cornell, cornell_obj, description_to_obj, lrr_json, probe, root,
    temp_dir,
};

#[test]
fn reciprocity_between_cornell_surfaces() {
    // Visibility is a ray-sampled fraction, so surface-level factors carry Monte Carlo noise
    // from the pairs a shadow boundary crosses. 64 samples per pair (1024 rays on those pairs)
    // bring it below the 1e-3 asked for; the default 16 measured a worst pair of 3.3e-3.
    let vf = lrr_json(&[
        "view-factors",
        cornell().to_str().unwrap(),
        "--json",
        "--quiet",
        "--samples",
        "64",
    ]);
    let areas: Vec<f64> = vf["areas"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a.as_f64().unwrap())
        .collect();
    let names = vf["surfaces"].as_array().unwrap();
    let f = |i: usize, j: usize| vf["matrix"][i][j].as_f64().unwrap();
    let mut worst: f64 = 0.0;
    for i in 0..areas.len() {
        for j in i + 1..areas.len() {
            let (a, b) = (areas[i] * f(i, j), areas[j] * f(j, i));
            if a == 0.0 && b == 0.0 {
                continue;
            }
            let rel = (a - b).abs() / a.max(b);
            println!(
                "{} ↔ {}: A F = {a:.6e} vs {b:.6e}, relative {rel:.1e}",
                names[i], names[j]
            );
            worst = worst.max(rel);
        }
    }
    assert!(worst < 1e-3, "worst reciprocity error {worst}");
}

/// Per-element radiosity from `lrr solve --json`.
fn solve(extra: &[&str]) -> Vec<[f64; 3]> {
    crate::util::solve_elements(&cornell(), extra)
        .into_iter()
        .map(|e| e.2)
        .collect()
}

#[test]
fn low_rank_against_exact_on_the_same_fine_mesh() {
    let exact = solve(&["--exact"]);
    let low_rank = solve(&[]);
    assert_eq!(exact.len(), low_rank.len());
    assert!((1900..=4000).contains(&exact.len()), "n = {}", exact.len());
    let error = lrr_precompute::radiosity::relative_l2(&low_rank, &exact);
    println!(
        "n = {}, relative L2 error of the low-rank solution: {error:.4}",
        exact.len()
    );
    // Bound: the only approximation is F(e, e') ≈ F(e, P(e')) A_e'/A_P(e') (an element sees all of
    // a patch alike). It errs most for elements next to a patch, where the view of the patch
    // changes fastest; those elements carry a small share of the energy. README: 0.0011 with
    // the default 2MSC patches (k = 167 on n = 2116; 0.0026 with 2MF's k = 242). The bake is
    // deterministic, so the error moves only when the code does: held to 2x the printed
    // figure (a missing channel, a wrong weight or core gives > 10%).
    assert!(error < 0.0022, "relative L2 error {error}");
}

#[test]
fn cornell_energy_is_plausible_and_bakes_are_deterministic() {
    let dir = temp_dir("cornell");
    let one = dir.join("t1.lrr");
    let two = dir.join("t2.lrr");
    let scene = cornell();
    bake(&scene, &one, &["--threads", "1"]).unwrap();
    bake(&scene, &two, &["--threads", "2"]).unwrap();
    assert!(
        std::fs::read(&one).unwrap() == std::fs::read(&two).unwrap(),
        "1 and 2 threads differ"
    );

    let up = [0.0, 1.0, 0.0];
    let b = probe(
        &one,
        &[
            ([555.0, 274.0, 280.0], [-1.0, 0.0, 0.0]), // red wall, middle
            ([450.0, 0.0, 100.0], up),                 // floor in the open, in front
            ([368.0, 0.0, 351.0], up),                 // floor under the tall block
            ([200.0, 0.0, 500.0], up),                 // floor behind the blocks, in the open
        ],
    );
    let (red, floor, under, open) = (b[0], b[1], b[2], b[3]);
    println!(
        "red wall {red:?}, floor {floor:?}, under the tall block {under:?}, open floor {open:?}"
    );
    // Red wall: red dominates far more than on the white floor.
    assert!(
        red[0] / red[1] > 3.0 * (floor[0] / floor[1]),
        "red {red:?} floor {floor:?}"
    );
    // Under the tall block the floor is enclosed: nothing reaches it.
    for c in 0..3 {
        assert!(under[c] < 1e-3 * open[c], "under {under:?} open {open:?}");
        assert!(floor[c] > 0.0 && open[c] > 0.0);
    }
}

/// Opens both generated files.
const OBJ_HEADER: &str = "\
# The Cornell box of lrr, generated from cornell-box.toml (beside this file) by
# description_to_obj in tests/tests/e2e/util.rs: do not edit. After changing the description:
#   cargo test --release -p lrr-tests --locked -- --ignored write_cornell_obj
# (the test cornell::the_shipped_obj_is_generated_from_the_description fails until then).
# Millimetres, y up; faces one-sided, counter-clockwise in front; Kd is the reflectance, Ke the
# emitted radiance (exitance pi * Ke). Sources and licence: the header of cornell-box.toml.
";

/// The OBJ and MTL text the description generates.
fn generated_cornell_obj() -> (String, String) {
    let text = std::fs::read_to_string(cornell()).unwrap();
    let desc = SceneDescription::parse(&text, "cornell-box.toml").unwrap();
    description_to_obj(&desc, "cornell-box.mtl", OBJ_HEADER)
}

/// Rewrites `scenes/cornell-box/cornell-box.obj` and `.mtl` from `cornell-box.toml`. Run by
/// hand after changing the description:
/// `cargo test --release -p lrr-tests --locked -- --ignored write_cornell_obj`.
#[test]
#[ignore = "writes scenes/cornell-box/cornell-box.obj and .mtl"]
fn write_cornell_obj() {
    let (obj, mtl) = generated_cornell_obj();
    std::fs::write(cornell_obj(), obj).unwrap();
    std::fs::write(cornell_obj().with_extension("mtl"), mtl).unwrap();
}

#[test]
fn the_shipped_obj_is_generated_from_the_description() {
    let (obj, mtl) = generated_cornell_obj();
    for (path, generated) in [
        (cornell_obj(), obj),
        (cornell_obj().with_extension("mtl"), mtl),
    ] {
        let shipped =
            std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(
            shipped == generated,
            "{} is not what scenes/cornell-box/cornell-box.toml generates; run \
             `cargo test --release -p lrr-tests --locked -- --ignored write_cornell_obj`",
            path.strip_prefix(root()).unwrap().display()
        );
    }
}

/// Asserts that two imports hold the same scene: names, materials, surfaces, faces (vertices,
/// order, normals) and mesh hints, bit for bit.
fn assert_same_scene(a: &Scene, b: &Scene) {
    assert_eq!(a.name, b.name);
    assert_eq!(a.materials, b.materials);
    assert_eq!(a.surfaces, b.surfaces);
    assert_eq!(a.faces.len(), b.faces.len());
    for (i, (fa, fb)) in a.faces.iter().zip(&b.faces).enumerate() {
        assert_eq!(fa, fb, "face {i}");
    }
    assert_eq!(a.hints, b.hints);
}

#[test]
fn the_shipped_obj_imports_as_the_description_and_bakes() {
    let from_toml = lrr_precompute::scene::load(&cornell()).unwrap();
    let from_obj = lrr_precompute::scene::load(&cornell_obj()).unwrap();
    // Only the red wall, a non-planar quad (issue 18 reports it with its deviation).
    assert_eq!(from_obj.warnings.len(), 1, "{:?}", from_obj.warnings);
    assert!(from_obj.warnings[0].contains("non-planar"));
    assert_eq!(from_obj.surfaces.len(), 8);
    assert_same_scene(&from_obj, &from_toml);
    assert_rows_sum_below_one_and_bakes(&cornell_obj());
}

#[test]
fn repeated_obj_faces_are_dropped_with_warnings_naming_their_lines() {
    // The quirk of the public archive OBJ, on the shipped one: each block has one face written
    // twice (there, its "Bottom Face" lines repeat a side). The copies are dropped, each with a
    // warning naming its file and line, and what remains is the shipped scene.
    let dir = temp_dir("obj-repeated");
    std::fs::copy(
        cornell_obj().with_extension("mtl"),
        dir.join("cornell-box.mtl"),
    )
    .unwrap();
    let text = std::fs::read_to_string(cornell_obj()).unwrap();
    let (mut lines, mut expected) = (Vec::new(), Vec::new());
    let mut group = "";
    for line in text.lines() {
        lines.push(line);
        if let Some(g) = line.strip_prefix("g ") {
            group = g;
        } else if line.starts_with("f ") && ["short-block", "tall-block"].contains(&group) {
            lines.push(line);
            expected.push(format!("cornell-box.obj:{}:", lines.len()));
            group = "";
        }
    }
    assert_eq!(expected.len(), 2);
    let obj = dir.join("cornell-box.obj");
    std::fs::write(&obj, lines.join("\n") + "\n").unwrap();
    let scene = lrr_precompute::scene::load(&obj).unwrap();
    let warnings: Vec<&String> = (scene.warnings.iter())
        .filter(|w| !w.contains("non-planar")) // the red wall
        .collect();
    assert_eq!(warnings.len(), 2, "{:?}", scene.warnings);
    for (w, at) in warnings.iter().zip(&expected) {
        assert!(
            w.contains(at.as_str()) && w.contains("duplicates"),
            "{w} (expected {at})"
        );
    }
    assert_same_scene(
        &scene,
        &lrr_precompute::scene::load(&cornell_obj()).unwrap(),
    );
}

/// The public archive OBJ of the Cornell box (Morgan McGuire's, public domain, committed in
/// `tests/data/cornell-box-archive/`): the importer on a file the project did not write.
#[test]
fn the_public_obj_imports_with_warnings_for_its_quirks() {
    // The archive OBJ repeats two faces (its "Bottom Face" lines); they are dropped.
    let scene = lrr_precompute::scene::load(&archive_cornell_obj()).unwrap();
    let dups: Vec<&String> = scene
        .warnings
        .iter()
        .filter(|w| w.contains("duplicates"))
        .collect();
    assert_eq!(dups.len(), 2, "{:?}", scene.warnings);
    assert!(
        dups.iter().all(|w| w.contains("CornellBox-Original.obj:")),
        "{dups:?}"
    );
    assert_rows_sum_below_one_and_bakes(&archive_cornell_obj());
}

/// The Cornell box OBJ at `path` is closed except the front: every row of the view factors
/// of an inner wall sums to more than 0 and at most 1; it bakes to three channels.
fn assert_rows_sum_below_one_and_bakes(path: &std::path::Path) {
    let vf = lrr_json(&["view-factors", path.to_str().unwrap(), "--json", "--quiet"]);
    // Closed except the front: every row of an inner wall sums to less than 1.
    for row in vf["matrix"].as_array().unwrap() {
        let sum: f64 = row
            .as_array()
            .unwrap()
            .iter()
            .map(|f| f.as_f64().unwrap())
            .sum();
        assert!(sum > 0.0 && sum <= 1.0 + 1e-3, "{sum}");
    }
    let dir = temp_dir("obj");
    let out = dir.join("obj.lrr");
    bake(path, &out, &[]).unwrap();
    let op = Operator::load(&out).unwrap();
    assert_eq!(op.channels(), 3);
}
