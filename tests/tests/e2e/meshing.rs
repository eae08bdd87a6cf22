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
        "2MSC (default threshold): n = {}, k = {k}, relative L2 error {error:.2e}",
        exact.len()
    );
    // The only approximation is an element seeing all of a patch alike; 2MSC joins elements
    // where that errs least. Measured 1.16e-3 with k = 162 at the default threshold 7e-5 (the
    // split rule's default: 9.3e-4 with k = 333; 2MF at the default patch size: 1.8e-3 with
    // k = 242; docs/MESHING.md): asserted within 1.25× of both, so a change of the rule that
    // costs accuracy or patches is seen.
    assert!(error < 1.25 * 1.16e-3, "relative L2 error {error}");
    assert!(
        k as f64 <= 1.25 * 162.0 && k as f64 >= 162.0 / 1.25,
        "k = {k}"
    );
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
        for method in ["2msc", "2msc-split"] {
            if flag == "--min-patch-area" && method == "2msc" {
                continue; // refused whatever its value: below
            }
            let err = bake(&scene, &out, &["--method", method, &arg]).unwrap_err();
            assert!(err.contains(expect), "{method} {arg}: {err}");
            assert!(!out.exists());
        }
    }
    // The merge rule has no smallest patch area: the flag is refused, naming the rule it
    // belongs to.
    let err = bake(
        &scene,
        &out,
        &["--method", "2msc", "--min-patch-area", "100"],
    )
    .unwrap_err();
    assert!(
        err.contains("--min-patch-area 100 applies to --method 2msc-split only"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn dense_sphere_bakes_with_clustered_patches() {
    let dir = temp_dir("dense");
    let scene = generated_scene(&dir, "sphere", &["dense-sphere", "--subdivisions", "3"]);
    let exact = radiosity(&scene, &["--exact"]);
    for flags in [
        &["--method", "2mf"][..],
        &["--method", "2msc"][..],
        &["--method", "2msc-split"][..],
    ] {
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
    for (method, threshold) in [("2msc", "0.00007"), ("2msc-split", "0.00003")] {
        let mut files = Vec::new();
        for threads in ["1", "2"] {
            let out = dir.join(format!("{method}-t{threads}.lrr"));
            let text = bake(
                &scene,
                &out,
                &[
                    "--method",
                    method,
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
        // Split: the refinement decides one FIFO generation in parallel and every decision
        // depends on its node only. Merge: the costs are computed in parallel, the joins
        // taken one at a time in order of (cost, ids). Either way the patches (and the file)
        // do not depend on the thread count.
        assert!(
            files[0] == files[1],
            "{method} bakes differ between 1 and 2 threads"
        );
        let info = lrr(&[
            "info",
            dir.join(format!("{method}-t2.lrr")).to_str().unwrap(),
        ])
        .unwrap();
        assert!(
            info.contains(&format!("method: \"{method}\""))
                && info.contains(&format!("threshold: {threshold}")),
            "{info}"
        );
    }
}
