//! Meshing real-world triangles (issue 18): the Cornell box written as triangles meshes and
//! lights like its quads, and a messy scene bakes with counts bounded by its area and its
//! repairs listed.

#[path = "e2e/util.rs"]
#[allow(dead_code)]
mod util;

use std::path::Path;

use util::{bake, cornell, generated_scene, lrr, solve_elements, temp_dir};

type Elements = Vec<(String, [f64; 3], [f64; 3])>;

/// Relative L2 difference of `x`'s radiosity against `reference`, each element of `x` compared
/// with the reference element of its surface nearest to its centroid (all channels).
fn difference(x: &Elements, reference: &Elements) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (s, c, b) in x {
        let (_, _, r) = reference
            .iter()
            .filter(|e| &e.0 == s)
            .min_by(|a, b| dist(&a.1, c).total_cmp(&dist(&b.1, c)))
            .expect("the surface is in the reference");
        for ch in 0..3 {
            num += (b[ch] - r[ch]).powi(2);
            den += r[ch].powi(2);
        }
    }
    (num / den).sqrt()
}

fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt()
}

/// Two triangles per quad, and fans over rim points with slivers at every corner: at most
/// 1.2× the quads' elements, and radiosity as far from a twice finer quad mesh as the quads
/// themselves are (the discretisation error), within 10% of it.
#[test]
fn cornell_box_as_triangles_meshes_like_its_quads() {
    let dir = temp_dir("cornell-triangles");
    let source = cornell();
    let pairs = dir.join("pairs.toml");
    let fans = dir.join("fans.toml");
    let s = source.to_str().unwrap();
    lrr(&["scene", "triangulate", s, "-o", pairs.to_str().unwrap()]).unwrap();
    lrr(&[
        "scene",
        "triangulate",
        s,
        "--fans",
        "-o",
        fans.to_str().unwrap(),
    ])
    .unwrap();
    let coarse = ["--exact", "--element-size", "96", "--threads", "2"];
    let reference = solve_elements(
        &source,
        &["--exact", "--element-size", "48", "--threads", "2"],
    );
    let quads = solve_elements(&source, &coarse);
    let discretisation = difference(&quads, &reference);
    for (name, scene) in [("pairs", &pairs), ("fans", &fans)] {
        let tris = solve_elements(scene, &coarse);
        let error = difference(&tris, &reference);
        let against_quads = difference(&tris, &quads);
        println!(
            "{name}: n = {} (quads {}), error {error:.4} against the quads' {discretisation:.4}, \
             {against_quads:.4} from the quads",
            tris.len(),
            quads.len()
        );
        assert!(tris.len() as f64 <= 1.2 * quads.len() as f64, "{name}");
        assert!(
            error <= 1.1 * discretisation,
            "{name}: {error} vs {discretisation}"
        );
    }
}

/// Total area and perimeter of a scene's faces.
fn area_and_perimeter(scene: &lrr_precompute::scene::Scene) -> (f64, f64) {
    scene.faces.iter().fold((0.0, 0.0), |(a, p), f| {
        let v = f.polygon.vertices();
        let per: f64 = (0..v.len())
            .map(|i| (v[(i + 1) % v.len()] - v[i]).length())
            .sum();
        (a + f.polygon.area(), p + per)
    })
}

/// The messy scene: every repair warned about and counted, n within 2 (A / h² + P / h).
#[test]
fn messy_scene_bakes_with_bounded_counts_and_its_repairs_listed() {
    let dir = temp_dir("messy");
    let path = generated_scene(&dir, "messy", &["messy"]);
    let scene = lrr_precompute::scene::load(&path).unwrap();
    for w in &scene.warnings {
        println!("warning: {w}");
    }
    let has = |s: &str| scene.warnings.iter().filter(|w| w.contains(s)).count();
    assert_eq!(has("degenerate face"), 1);
    assert_eq!(has("duplicates face"), 1);
    assert_eq!(has("non-planar polygon"), 1);
    let out = dir.join("messy.lrr");
    let report = dir.join("report.json");
    let text = bake(
        &path,
        &out,
        &["--threads", "2", "--report", report.to_str().unwrap()],
    )
    .unwrap();
    println!("{text}");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let m = &r["meshing"];
    assert_eq!(m["degenerate_dropped"], 1);
    assert_eq!(m["duplicates_dropped"], 1);
    assert_eq!(m["non_planar_split"], 1);
    assert!(
        m["interpenetrations_imprinted"].as_u64().unwrap() >= 3,
        "{m}"
    );
    assert!(m["grid_regions"].as_u64().unwrap() >= 2, "{m}"); // the rug, the far quad
    assert!(
        text.contains("geometry: 1 degenerate and 1 duplicate"),
        "{text}"
    );
    let h = r["element_size"].as_f64().unwrap();
    let (area, perimeter) = area_and_perimeter(&scene);
    let n = r["n"].as_f64().unwrap();
    let bound = 2.0 * (area / (h * h) + perimeter / h);
    println!(
        "n = {n}, A/h² = {:.0}, P/h = {:.0}",
        area / (h * h),
        perimeter / h
    );
    assert!(n <= bound && n >= area / (h * h), "n = {n}, bound {bound}");
    let stages = m["stages"].as_array().unwrap();
    assert_eq!(stages.len(), 5, "{m}"); // regions, grid, imprint, subdivide, group
}

/// A needle of one square metre at 1 mm: refused with the surface, its area and a size that
/// fits; at that size it meshes.
#[test]
fn a_refusal_by_area_names_a_size_that_fits() {
    let dir = temp_dir("needle-refusal");
    let path = dir.join("needle.toml");
    std::fs::write(
        &path,
        "[[material]]\nname = \"m\"\nreflectance = [0.5, 0.5, 0.5]\nradiance = [1, 1, 1]\n\
         [[surface]]\nname = \"strip\"\nmaterial = \"m\"\n\
         polygons = [[[0, 0, 0], [2000, 0, 0], [1000, 0.001, 0]]]\n",
    )
    .unwrap();
    let out = dir.join("n.lrr");
    let e = bake(&path, &out, &["--element-size", "0.00001"]).unwrap_err();
    assert!(e.contains("surface 'strip' (area 1.0000)"), "{e}");
    let fits = e
        .rsplit("--element-size ")
        .next()
        .and_then(|s| s.split_whitespace().next())
        .unwrap()
        .to_string();
    let scene = lrr_precompute::scene::load(Path::new(&path)).unwrap();
    let h: f64 = fits.parse().unwrap();
    assert!(
        lrr_precompute::mesh::estimate_elements(&scene, h) <= 2e7,
        "{e}"
    );
}
