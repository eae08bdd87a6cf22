//! Refinement where light changes (`lrr bake --refine`, docs/MESHING.md): smaller elements
//! along a shadow's penumbra and nowhere else, the budget and `--element-size` respected,
//! the same bytes whatever the thread count and in sharded bakes. Its accuracy against the
//! path tracer is measured in `reference.rs`.

use std::path::PathBuf;

use lrr_precompute::bake::{BakeSettings, Baked, bake};
use lrr_precompute::progress::Progress;
use lrr_precompute::scene::Scene;

use crate::util::{cornell, temp_dir};

/// A unit floor under a 0.2 × 0.2 emitter at height 1 (centred over the floor, facing down)
/// and a black blocker at height 0.5 covering x < 0.5: the floor's penumbra is the band
/// 0.4 < x < 0.6 (`x = 1 − x_light`), its umbra is black (nothing reflects into it).
fn shadow_scene() -> PathBuf {
    let path = temp_dir("refine-shadow").join("shadow.toml");
    std::fs::write(
        &path,
        r#"name = "shadow"

[[material]]
name = "floor"
reflectance = [0.5, 0.5, 0.5]

[[material]]
name = "black"
reflectance = [0.0, 0.0, 0.0]

[[material]]
name = "light"
reflectance = [0.0, 0.0, 0.0]
radiance = [1.0, 1.0, 1.0]

[[surface]]
name = "floor"
material = "floor"
polygons = [[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]]

[[surface]]
name = "light"
material = "light"
polygons = [[[0.4, 0.4, 1.0], [0.4, 0.6, 1.0], [0.6, 0.6, 1.0], [0.6, 0.4, 1.0]]]

[[surface]]
name = "blocker"
material = "black"
polygons = [[[-0.5, -0.5, 0.5], [-0.5, 1.5, 0.5], [0.5, 1.5, 0.5], [0.5, -0.5, 0.5]]]
"#,
    )
    .unwrap();
    path
}

const H: f64 = 1.0 / 16.0;

fn settings(refine: Option<f64>, threads: usize) -> BakeSettings {
    BakeSettings {
        element_size: Some(H),
        patch_size: Some(0.25),
        samples: 4,
        threads: Some(threads),
        refine,
        ..BakeSettings::default()
    }
}

fn baked(scene: &Scene, s: &BakeSettings) -> Baked {
    bake(scene, s, &Progress::hidden()).unwrap()
}

fn floor_elements(b: &Baked) -> Vec<&lrr_precompute::mesh::Element> {
    let floor = b.surfaces.iter().position(|s| s == "floor").unwrap() as u32;
    b.mesh
        .elements
        .iter()
        .filter(|e| e.surface == floor)
        .collect()
}

#[test]
fn refinement_splits_the_penumbra_and_nothing_else() {
    let scene = lrr_precompute::scene::load(&shadow_scene()).unwrap();
    let base = baked(&scene, &settings(None, 2));
    let refined = baked(&scene, &settings(Some(0.2), 2));
    refined.mesh.validate().unwrap();
    let (n0, n) = (base.n(), refined.n());
    assert_eq!(floor_elements(&base).len(), 256);
    // The budget: at most 0.2 · n0 elements added, and it is used.
    assert!(n > n0 && n - n0 <= n0 / 5, "n0 = {n0}, n = {n}");
    assert_eq!(refined.k(), base.k(), "patches are unchanged");
    assert_eq!(refined.mesh.meshing.refined, (n - n0) / 3, "2×2 splits");
    // Every split floor element (a quarter of the base area) lies in the penumbra or within
    // one element of it (a child's centroid is a quarter element inside its parent): none in
    // the umbra (x < 0.3) or the lit floor (x > 0.7).
    let small: Vec<_> = floor_elements(&refined)
        .into_iter()
        .filter(|e| e.polygon.area() < 0.5 * H * H)
        .collect();
    assert_eq!(small.len(), n - n0 + refined.mesh.meshing.refined);
    for e in &small {
        let x = e.polygon.centroid().x;
        assert!(
            (0.4 - 1.5 * H..=0.6 + 1.5 * H).contains(&x),
            "a split element at x = {x}, outside the penumbra 0.4..0.6"
        );
    }
    // ... along its whole length, not in one spot.
    let ys: Vec<f64> = small.iter().map(|e| e.polygon.centroid().y).collect();
    let spread =
        ys.iter().cloned().fold(f64::MIN, f64::max) - ys.iter().cloned().fold(1.0, f64::min);
    assert!(
        spread > 0.5,
        "split elements span only {spread} of the penumbra's length"
    );
    // `--element-size` stays the upper bound.
    for e in &refined.mesh.elements {
        assert!(e.polygon.size() <= H * (1.0 + 1e-9), "{}", e.polygon.size());
    }
}

#[test]
fn refinement_is_deterministic_across_thread_counts() {
    let scene = lrr_precompute::scene::load(&shadow_scene()).unwrap();
    let bytes = |threads| {
        let b = baked(&scene, &settings(Some(0.5), threads));
        lrr_precompute::write::operator_file(&b).unwrap().to_bytes()
    };
    assert_eq!(bytes(1), bytes(2), "--refine depends on the thread count");
}

/// The file's metadata records the budget and the elements split (`lrr info` prints them).
#[test]
fn the_metadata_records_the_refinement() {
    let out = temp_dir("refine-info").join("c.lrr");
    crate::util::bake(&cornell(), &out, &["--element-size", "96", "--refine"]).unwrap();
    let info = crate::util::lrr(&["info", out.to_str().unwrap()]).unwrap();
    assert!(info.contains("refine: 0.5"), "{info}");
    assert!(info.contains("refined_elements: "), "{info}");
}

/// A budget of 0 changes nothing: the bytes of an unrefined bake.
#[test]
fn a_zero_budget_is_the_unrefined_bake() {
    let scene = lrr_precompute::scene::load(&shadow_scene()).unwrap();
    let bytes = |refine| {
        let b = baked(&scene, &settings(refine, 2));
        lrr_precompute::write::operator_file(&b).unwrap().to_bytes()
    };
    assert_eq!(bytes(Some(0.0)), bytes(None));
}

/// Bad budgets are refused with the flag's name, with and without shards.
#[test]
fn bad_budgets_are_refused_clearly() {
    let dir = temp_dir("refine-refused");
    for extra in [
        vec!["--refine=-1"],
        vec!["--refine", "NaN"],
        vec!["--refine=-1", "--shard", "0/2"],
    ] {
        let out = dir.join("part-{i}.bin");
        let e = crate::util::bake(&cornell(), &out, &extra).unwrap_err();
        assert!(e.contains("--refine must be"), "{extra:?}: {e}");
    }
    let e = crate::util::lrr(&[
        "plan",
        cornell().to_str().unwrap(),
        "-o",
        dir.join("p.plan").to_str().unwrap(),
        "--refine=-1",
    ])
    .unwrap_err();
    assert!(e.contains("--refine must be"), "{e}");
}

/// Shards refine as the single bake does (the first pass is part of the mesh stage), with and
/// without a plan: their merge is the single bake's bytes.
#[test]
fn sharded_refined_bakes_merge_into_the_bytes_of_a_single_bake() {
    let dir = temp_dir("refine-shards");
    let extra = ["--element-size", "96", "--refine", "0.5"];
    let single = dir.join("single.lrr");
    crate::util::bake(&cornell(), &single, &extra).unwrap();
    let plan = dir.join("p.plan");
    let scene = cornell();
    let mut args = vec![
        "plan",
        scene.to_str().unwrap(),
        "-o",
        plan.to_str().unwrap(),
        "-q",
    ];
    args.extend_from_slice(&extra);
    crate::util::lrr(&args).unwrap();
    for with_plan in [false, true] {
        let mut parts = Vec::new();
        for i in 0..3 {
            let part = dir.join(format!("part-{with_plan}-{i}.bin"));
            let spec = format!("{i}/3");
            let mut flags = vec!["--shard", spec.as_str()];
            flags.extend_from_slice(&extra);
            if with_plan {
                flags.extend_from_slice(&["--plan", plan.to_str().unwrap()]);
            }
            crate::util::bake(&cornell(), &part, &flags).unwrap();
            parts.push(part);
        }
        let merged = dir.join(format!("merged-{with_plan}.lrr"));
        let mut args = vec!["merge"];
        args.extend(parts.iter().map(|p| p.to_str().unwrap()));
        args.extend_from_slice(&["-o", merged.to_str().unwrap(), "-q"]);
        crate::util::lrr(&args).unwrap();
        assert!(
            std::fs::read(&merged).unwrap() == std::fs::read(&single).unwrap(),
            "plan {with_plan}: the merged refined bake differs from the single one"
        );
    }
    let info = crate::util::lrr(&["info", single.to_str().unwrap()]).unwrap();
    assert!(info.contains("refine: 0.5"), "{info}");
}
