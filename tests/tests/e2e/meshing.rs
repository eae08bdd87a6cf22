//! Patch methods: 2MSC (adaptive patches) and clustered patches of dense meshes, measured
//! against the exact solve on the same fine mesh.

use crate::util::{bake, cornell, generated_scene, lrr, lrr_json, solve_elements, temp_dir};
use lrr_precompute::radiosity::relative_l2;

fn radiosity(scene: &std::path::Path, extra: &[&str]) -> Vec<[f64; 3]> {
    solve_elements(scene, extra)
        .into_iter()
        .map(|e| e.2)
        .collect()
}

/// `k` of a low-rank solve with these flags.
fn k_of(scene: &std::path::Path, extra: &[&str]) -> usize {
    let mut args = vec!["solve", scene.to_str().unwrap(), "--json", "--quiet"];
    args.extend_from_slice(extra);
    lrr_json(&args)["k"].as_u64().unwrap() as usize
}

#[test]
fn two_msc_on_the_cornell_box_against_the_exact_solve() {
    let scene = cornell();
    let exact = radiosity(&scene, &["--exact"]);
    let flags = ["--method", "2msc"];
    let low_rank = radiosity(&scene, &flags);
    let k = k_of(&scene, &flags);
    assert_eq!(exact.len(), low_rank.len());
    let error = relative_l2(&low_rank, &exact);
    println!(
        "2MSC (default threshold): n = {}, k = {k}, relative L2 error {error:.4}",
        exact.len()
    );
    // Bound: the only approximation is an element seeing all of a patch alike; 2MSC places its
    // patches where that errs most. Measured 0.00093 with k = 333 at the default threshold 3e-5
    // (0.0015 with k = 154 at 1e-4, the default before; 2MF at the default patch size: 0.0018
    // with k = 242; docs/MESHING.md). 1% fails for a wrong mesh or operator (a patch not holding
    // its elements gives > 10%); k < n/4 fails if refinement runs away.
    assert!(error < 0.01, "relative L2 error {error}");
    assert!(k < exact.len() / 4, "k = {k}");
}

#[test]
fn two_msc_refuses_bad_parameters() {
    let dir = temp_dir("msc-bad");
    let out = dir.join("x.lrr");
    let scene = cornell();
    for (flag, value, expect) in [
        ("--threshold", "0", "--threshold must be a positive number"),
        (
            "--threshold",
            "-0.5",
            "--threshold must be a positive number",
        ),
        (
            "--threshold",
            "NaN",
            "--threshold must be a positive number",
        ),
        (
            "--threshold",
            "inf",
            "--threshold must be a positive number",
        ),
        (
            "--min-patch-area",
            "-1",
            "--min-patch-area must be an area of zero or more",
        ),
        (
            "--min-patch-area",
            "NaN",
            "--min-patch-area must be an area of zero or more",
        ),
    ] {
        let arg = format!("{flag}={value}");
        let err = bake(&scene, &out, &["--method", "2msc", &arg]).unwrap_err();
        assert!(err.contains(expect), "{arg}: {err}");
        assert!(!out.exists());
    }
}

#[test]
fn dense_sphere_bakes_with_clustered_patches() {
    let dir = temp_dir("dense");
    let scene = generated_scene(&dir, "sphere", &["dense-sphere", "--subdivisions", "3"]);
    let exact = radiosity(&scene, &["--exact"]);
    for flags in [&["--method", "2mf"][..], &["--method", "2msc"][..]] {
        let low_rank = radiosity(&scene, flags);
        let k = k_of(&scene, flags);
        let error = relative_l2(&low_rank, &exact);
        println!(
            "{flags:?}: n = {}, k = {k}, relative L2 error {error:.4}",
            exact.len()
        );
        // 1 280 sphere triangles and ~390 room elements: without clustering every triangle
        // would be a patch (k > 1 280).
        assert!(k < 400, "k = {k}");
        // Bound: measured 0.0038 (2MF, k = 121) and 0.0048 (2MSC, k = 115); 3% fails for a
        // cluster whose form factors are wrong (a missing or doubled part moves the light the
        // sphere reflects by that part's share).
        assert!(error < 0.03, "{flags:?}: relative L2 error {error}");
    }
}

#[test]
fn dense_sphere_subdivisions_are_bounded() {
    let dir = temp_dir("dense-bad");
    let err = lrr(&[
        "scene",
        "dense-sphere",
        "--subdivisions",
        "9",
        "-o",
        dir.join("x.toml").to_str().unwrap(),
    ])
    .unwrap_err();
    assert!(err.contains("--subdivisions 9 is too fine"), "{err}");
}

#[test]
fn two_msc_bakes_are_identical_across_thread_counts() {
    let dir = temp_dir("msc-threads");
    let scene = cornell();
    let mut files = Vec::new();
    for threads in ["1", "2"] {
        let out = dir.join(format!("t{threads}.lrr"));
        let text = bake(
            &scene,
            &out,
            &[
                "--method",
                "2msc",
                "--element-size",
                "100",
                "--threads",
                threads,
            ],
        )
        .unwrap();
        assert!(text.contains("patches"), "{text}");
        files.push(std::fs::read(&out).unwrap());
    }
    // The refinement decides one FIFO generation in parallel; every decision depends on its
    // node only, so the patches (and the file) do not depend on the thread count.
    assert!(
        files[0] == files[1],
        "2MSC bakes differ between 1 and 2 threads"
    );
    let info = lrr(&["info", dir.join("t2.lrr").to_str().unwrap()]).unwrap();
    assert!(
        info.contains("method: \"2msc\"") && info.contains("threshold: 0.00003"),
        "{info}"
    );
}
