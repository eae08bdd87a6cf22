//! Issue #31's goal across tessellations, held where `scripts/bench-tessellation` measures it
//! (docs/PERFORMANCE.md, "Bake across tessellations"): the same surface at 1×, 16× and 256×
//! its triangles, baked with the default flags, has at most 1.5× the 1× bake's elements, and
//! its radiosity at the path-traced reference's points differs from the 1× bake's by at most
//! 1 % at the median. Bake time, the goal's other half, is a speed figure: it lives in the
//! benchmark, not here.
//!
//! The difference of a point is the script's: the mean over R, G, B of `|x − y| / max(|y|, f)`,
//! `f` = 1e-3 of the median of the 1× values, points at or below `f` left out.

use crate::reference::{load_reference, quantile};
use crate::util::{bake, generated_scene, lrr, probe, root, temp_dir};

// Both bounds are issue #31's goals as filed ("across 1×…256× tessellations: n … within 1.5×
// of the 1× bake; radiosity median difference ≤ 1 %"), set before this test ran, not from its
// output. Measured when it was added (9fcab1b): the Cornell box n 2 539 / 2 364 / 2 059
// (0.93× and 0.81×), medians 0.25 % and 0.30 %; the sphere from 320 triangles n 567 / 569 /
// 567, medians 0.34 % and 0.44 %.

/// The goal's bound on the median difference from the 1× bake.
const MEDIAN: f64 = 0.01;
/// The goal's bound on n against the 1× bake's.
const ELEMENTS: f64 = 1.5;

/// Bakes `scene` with the default flags (two threads) and probes it at `points` (the smooth
/// reconstruction, `lrr probe`'s default): n and the radiosity at each point.
fn bake_and_probe(
    scene: &std::path::Path,
    points: &[([f64; 3], [f64; 3])],
) -> (usize, Vec<[f64; 3]>) {
    let out = scene.with_extension("lrr");
    bake(scene, &out, &["--threads", "2"]).unwrap();
    let info = lrr(&["info", out.to_str().unwrap(), "--json"]).unwrap();
    let info: serde_json::Value = serde_json::from_str(&info).unwrap();
    let n = info["n"].as_u64().unwrap() as usize;
    let values = probe(&out, points);
    (n, values)
}

/// The reference `name`'s points: position and normal.
fn reference_points(name: &str) -> Vec<([f64; 3], [f64; 3])> {
    let (_, points) = load_reference(name);
    points.iter().map(|p| (p.position, p.normal)).collect()
}

/// Median of the per-point relative difference of `values` from `base` (the module's docs).
fn median_difference(values: &[[f64; 3]], base: &[[f64; 3]]) -> f64 {
    let mut lum: Vec<f64> = base.iter().map(|b| b.iter().sum::<f64>() / 3.0).collect();
    lum.sort_by(f64::total_cmp);
    let floor = 1e-3 * quantile(&lum, 0.5);
    let rel: Vec<f64> = values
        .iter()
        .zip(base)
        .filter(|(_, b)| b.iter().sum::<f64>() / 3.0 > floor)
        .map(|(v, b)| {
            (0..3)
                .map(|c| (v[c] - b[c]).abs() / b[c].abs().max(floor))
                .sum::<f64>()
                / 3.0
        })
        .collect();
    quantile(&rel, 0.5)
}

/// Bakes each of `scenes` (1× first) and holds n and the median difference from the 1× bake
/// to the goal.
fn holds_the_goal(
    label: &str,
    scenes: &[(u32, std::path::PathBuf)],
    points: &[([f64; 3], [f64; 3])],
) {
    let (n1, base) = bake_and_probe(&scenes[0].1, points);
    println!("{label} 1×: n = {n1}");
    for (multiple, scene) in &scenes[1..] {
        let (n, values) = bake_and_probe(scene, points);
        let median = median_difference(&values, &base);
        println!(
            "{label} {multiple}×: n = {n} ({:.2}× the 1× bake's), median difference {:.2}%",
            n as f64 / n1 as f64,
            100.0 * median
        );
        assert!(
            n as f64 <= ELEMENTS * n1 as f64,
            "{label} at {multiple}× its triangles: n = {n} against {n1} at 1×"
        );
        assert!(
            median <= MEDIAN,
            "{label} at {multiple}× its triangles: median difference {:.2}% from the 1× bake",
            100.0 * median
        );
    }
}

/// The Cornell box with every quad cut into 1 × 1, 4 × 4 and 16 × 16 grids of triangle pairs.
#[test]
fn cornell_box_tessellations_bake_alike() {
    let dir = temp_dir("tessellation-cornell");
    let base = root().join("scenes/cornell-box/cornell-box.toml");
    let scenes: Vec<(u32, std::path::PathBuf)> = [(1, 1), (4, 16), (16, 256)]
        .iter()
        .map(|&(grid, multiple)| {
            let path = dir.join(format!("cornell-g{grid}.toml"));
            lrr(&[
                "scene",
                "triangulate",
                base.to_str().unwrap(),
                "--grid",
                &grid.to_string(),
                "-o",
                path.to_str().unwrap(),
            ])
            .unwrap();
            (multiple, path)
        })
        .collect();
    holds_the_goal("Cornell box", &scenes, &reference_points("cornell-box"));
}

/// The dense sphere in its room at 320, 5 120 and 81 920 triangles (`--subdivisions 2, 4, 6`),
/// polyhedra within 1.9 % of each other's area. The 80-face polyhedron (`--subdivisions 1`,
/// the benchmark's first 1×) is 7 % smaller than the sphere, a geometric difference from the
/// finer ones that tessellation does not explain (1.4–1.5 % at the median; docs/PERFORMANCE.md).
#[test]
fn dense_sphere_tessellations_bake_alike() {
    let dir = temp_dir("tessellation-sphere");
    let scenes: Vec<(u32, std::path::PathBuf)> = [(2, 1), (4, 16), (6, 256)]
        .iter()
        .map(|&(s, multiple)| {
            let name = format!("sphere-s{s}");
            let args = ["dense-sphere", "--subdivisions", &s.to_string()];
            (multiple, generated_scene(&dir, &name, &args))
        })
        .collect();
    holds_the_goal("dense sphere", &scenes, &reference_points("dense-sphere"));
}
