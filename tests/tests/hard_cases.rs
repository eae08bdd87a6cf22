//! Hard numerical cases (issue: "hard cases stay numerically stable"): reflectance near 1,
//! edge-sharing elements, slivers and tiny elements, huge and tiny scales, thin walls.

#[path = "e2e/util.rs"]
#[allow(dead_code)]
mod util;

use lrr_runtime::Operator;
use util::{bake, cornell, factor, generated_scene, lrr_json, temp_dir};

fn solve(scene: &std::path::Path, extra: &[&str]) -> Vec<(String, [f64; 3], [f64; 3])> {
    util::solve_elements(scene, extra)
}

#[test]
fn reflectance_near_one_exact_and_low_rank() {
    let dir = temp_dir("rho-near-one");
    for rho in [0.999, 0.9999] {
        let r = rho.to_string();
        let scene = generated_scene(&dir, &format!("f{r}"), &["furnace", "--reflectance", &r]);
        let expected = std::f64::consts::PI / (1.0 - rho);
        let exact = solve(&scene, &["--exact"]);
        let worst_exact = exact
            .iter()
            .map(|e| (e.2[0] - expected).abs() / expected)
            .fold(0.0, f64::max);
        let out = dir.join(format!("f{r}.lrr"));
        let report = dir.join(format!("f{r}.json"));
        bake(&scene, &out, &["--report", report.to_str().unwrap()]).unwrap();
        let op = Operator::load(&out).unwrap();
        let b = op.evaluate_baked();
        let worst_lrr = b
            .iter()
            .map(|x| (f64::from(x[0]) - expected).abs() / expected)
            .fold(0.0, f64::max);
        let r: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
        let kappa = r["condition"].as_f64().unwrap();
        println!(
            "rho {rho}: exact worst {worst_exact:.2e}, low-rank worst {worst_lrr:.2e}, condition of I - VᵀU {kappa:.4e}"
        );
        // README: exact 4e-14 / 3e-13, low-rank 1.2e-7 / 8.6e-8; each held within 10x.
        let (exact_limit, lrr_limit) = if rho < 0.9995 {
            (4e-13, 1.2e-6)
        } else {
            (3e-12, 8.6e-7)
        };
        assert!(
            worst_exact < exact_limit && worst_lrr < lrr_limit,
            "rho {rho}: exact {worst_exact:.2e} (limit {exact_limit:.0e}), low-rank \
             {worst_lrr:.2e} (limit {lrr_limit:.0e})"
        );
        // A closed scene's V^T U is stochastic times rho: its condition is (1 + rho) / (1 - rho)
        // at most, and at least 1 / (1 - rho).
        assert!(
            kappa >= 0.99 / (1.0 - rho) && kappa <= 1.01 * (1.0 + rho) / (1.0 - rho),
            "{kappa}"
        );
    }
}

#[test]
fn edge_sharing_squares_refined_to_many_elements() {
    let dir = temp_dir("edge-sharing");
    let scene = generated_scene(&dir, "perp", &["perpendicular"]);
    for size in ["0.05", "0.01"] {
        let vf = lrr_json(&[
            "view-factors",
            scene.to_str().unwrap(),
            "--json",
            "-q",
            "--element-size",
            size,
        ]);
        let f = factor(&vf, "base", "wall");
        println!("element size {size}: F = {f:.6} (closed form 0.200044)");
        // README: 0.200043 and 0.200044 against 0.200044 (6 digits): within 1e-5.
        assert!((f - 0.200044).abs() < 1e-5, "{f}");
    }
}

/// A closed unit cube whose floor is tiled by slivers (aspect 1e4) and tiny triangles
/// (area 1e-8 of the scene's).
fn sliver_cube(dir: &std::path::Path, rho: f64) -> std::path::PathBuf {
    let t = 1e-4; // sliver thickness
    let s = (6.0f64 * 1e-8 * 2.0).sqrt(); // tiny right triangles of area 6e-8 (the scene's is 6)
    let tri = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        format!(
            "[[{}, {}, 0], [{}, {}, 0], [{}, {}, 0]]",
            a[0], a[1], b[0], b[1], c[0], c[1]
        )
    };
    let quad = |x0: f64, y0: f64, x1: f64, y1: f64| {
        format!("[[{x0}, {y0}, 0], [{x1}, {y0}, 0], [{x1}, {y1}, 0], [{x0}, {y1}, 0]]")
    };
    let floor = [
        // a strip of two slivers along y = 0 (aspect 1e4)
        tri([0.0, 0.0], [1.0, 0.0], [1.0, t]),
        tri([0.0, 0.0], [1.0, t], [0.0, t]),
        // a tiny square of two tiny triangles in the corner above the strip
        tri([0.0, t], [s, t], [s, t + s]),
        tri([0.0, t], [s, t + s], [0.0, t + s]),
        // the rest: a thin rectangle right of the tiny square, and the bulk
        quad(s, t, 1.0, t + s),
        quad(0.0, t + s, 1.0, 1.0),
    ];
    let text = format!(
        "[[material]]\nname = \"w\"\nreflectance = [{rho}, {rho}, {rho}]\nradiance = [1, 1, 1]\n\
         [[box]]\nname = \"cube\"\nmaterial = \"w\"\nmin = [0, 0, 0]\nmax = [1, 1, 1]\ninward = true\nomit = [\"-z\"]\n\
         [[surface]]\nname = \"floor\"\nmaterial = \"w\"\npolygons = [{}]\n\
         [mesh]\nelement_size = 0.125\npatch_size = 0.25\n",
        floor.join(", ")
    );
    let path = dir.join("slivers.toml");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn slivers_and_tiny_elements_stay_finite_and_conserve_energy() {
    let dir = temp_dir("slivers");
    let scene = sliver_cube(&dir, 0.9);
    let vf = lrr_json(&["view-factors", scene.to_str().unwrap(), "--json", "-q"]);
    for (i, row) in vf["matrix"].as_array().unwrap().iter().enumerate() {
        let sum: f64 = row
            .as_array()
            .unwrap()
            .iter()
            .map(|f| f.as_f64().unwrap())
            .sum();
        println!("{}: row sum {sum:.9}", vf["surfaces"][i]);
        assert!(
            sum.is_finite() && (1.0 - 1e-8..=1.0 + 1e-8).contains(&sum),
            "row {i}: {sum}"
        );
    }
    let out = dir.join("slivers.lrr");
    bake(&scene, &out, &[]).unwrap();
    let op = Operator::load(&out).unwrap(); // the reader validates every value is finite
    let expected = std::f64::consts::PI / (1.0 - 0.9);
    let b = op.evaluate_baked();
    let worst = b
        .iter()
        .flatten()
        .map(|x| (f64::from(*x) - expected).abs() / expected)
        .fold(0.0, f64::max);
    println!(
        "furnace with slivers: n = {}, worst relative error {worst:.2e}",
        op.n()
    );
    // README: furnace error 1.4e-7 with slivers; held within 10x.
    assert!(worst < 1.4e-6, "{worst}");
}

/// The Cornell box description with `scale = s` prepended.
fn scaled_cornell(dir: &std::path::Path, s: f64) -> std::path::PathBuf {
    let text = std::fs::read_to_string(cornell()).unwrap();
    let path = dir.join(format!("cornell-{s}.toml"));
    std::fs::write(&path, format!("scale = {s:e}\n{text}")).unwrap();
    path
}

/// A scaled scene meshes identically, joins the same patches and gives the same radiosity per
/// element within 1e-5 relative (issue #31), by 2MF and by the default 2MSC. Before #31 2MSC's
/// view rays were seeded by the raw coordinates' bits: at scale 1e4 the patches joined in
/// another order and single elements moved by 11–14%; the seeds now hash scene-relative
/// coordinates (`coherence::view_seed`), and the difference measured 0 at 1e-3 and 1e4.
#[test]
fn scaled_cornell_box_gives_the_same_radiosity() {
    let dir = temp_dir("scale");
    for method in [&["--method", "2mf"][..], &[][..]] {
        let base = solve(&scaled_cornell(&dir, 1.0), method);
        for s in [1e-3, 1e4] {
            let scaled = solve(&scaled_cornell(&dir, s), method);
            assert_eq!(
                scaled.len(),
                base.len(),
                "default sizes must mesh a scaled scene identically"
            );
            let mut worst = 0.0f64;
            for (a, b) in scaled.iter().zip(&base) {
                for c in 0..3 {
                    worst = worst.max((a.2[c] - b.2[c]).abs() / b.2[c].abs().max(1e-3));
                }
                let d = (a.1[0] / s - b.1[0]).abs();
                assert!(d < 1e-6 * 556.0, "element centroids must scale exactly");
            }
            println!("{method:?} scale {s:e}: worst element {worst:.2e}");
            assert!(worst < 1e-5, "{method:?} scale {s}: {worst}");
        }
    }
}

/// The default bake (2MSC and the refinement where light changes) of the Cornell box at
/// scales 1e-3 and 1e4: the same n and k, the same surfaces' mean radiosity within 1e-5.
#[test]
fn scaled_cornell_box_bakes_the_same() {
    let dir = temp_dir("scale-bake");
    let baked = |s: f64| {
        let out = dir.join(format!("cornell-{s}.lrr"));
        bake(&scaled_cornell(&dir, s), &out, &[]).unwrap();
        lrr_json(&["info", out.to_str().unwrap(), "--json"])
    };
    same_at_other_scales(&baked);
}

/// `baked(s)` (the `lrr info --json` of the bake at scale `s`) at 1e-3 and 1e4 against 1: the
/// same n and k and every surface's mean radiosity within 1e-5.
fn same_at_other_scales(baked: &dyn Fn(f64) -> serde_json::Value) {
    let means = |i: &serde_json::Value| -> Vec<f64> {
        i["surfaces"]
            .as_array()
            .unwrap()
            .iter()
            .flat_map(|x| (0..3).map(|c| x["mean_radiosity"][c].as_f64().unwrap()))
            .collect()
    };
    let base = baked(1.0);
    for s in [1e-3, 1e4] {
        let info = baked(s);
        assert_eq!(info["n"], base["n"], "scale {s}");
        assert_eq!(info["k"], base["k"], "scale {s}");
        for (a, b) in means(&info).iter().zip(means(&base)) {
            assert!(
                (a - b).abs() <= 1e-5 * b.abs().max(1e-3),
                "scale {s}: {a} vs {b}"
            );
        }
    }
}

/// The dense sphere at 5 120 triangles, its small faces grouped into elements (issue #31), at
/// scales 1e-3 and 1e4: the same n and k and the same surfaces' mean radiosity within 1e-5.
/// Before, bisection compared raw coordinates and the symmetric room's ties fell otherwise at
/// another scale (n 562 / 783 / 563 at 1, 1e-3, 1e4, the room 8 element sizes wide split once
/// more at 1e-3); the bisection now compares positions on a grid of 2⁻²⁴ of each set's range
/// and size tests allow rounding (measured: identical n, k and means).
#[test]
fn scaled_dense_sphere_groups_and_bakes_the_same() {
    let dir = temp_dir("scale-dense");
    let text = std::fs::read_to_string(generated_scene(
        &dir,
        "sphere",
        &["dense-sphere", "--subdivisions", "4"],
    ))
    .unwrap();
    let baked = |s: f64| {
        let path = dir.join(format!("sphere-{s}.toml"));
        std::fs::write(&path, format!("scale = {s:e}\n{text}")).unwrap();
        let out = dir.join(format!("sphere-{s}.lrr"));
        bake(&path, &out, &[]).unwrap();
        lrr_json(&["info", out.to_str().unwrap(), "--json"])
    };
    same_at_other_scales(&baked);
}

/// Two rooms along x, sharing a wall from x = 1 to x = 1 + thickness (none: zero thickness,
/// two coincident faces back to back). Floor, ceiling and side walls run under and over the
/// wall as single faces, the worst case for leaks. A lamp hangs in the first room.
fn two_rooms(dir: &std::path::Path, thickness: Option<f64>) -> std::path::PathBuf {
    let x1 = 1.0 + thickness.unwrap_or(0.0);
    let x2 = x1 + 1.0;
    let wall = match thickness {
        Some(t) => format!(
            "[[box]]\nname = \"wall\"\nmaterial = \"w\"\nmin = [1, 0, 0]\nmax = [{}, 1, 1]\n",
            1.0 + t
        ),
        None => "[[surface]]\nname = \"wall-dark\"\nmaterial = \"w\"\npolygons = [[[1, 0, 0], [1, 1, 0], [1, 1, 1], [1, 0, 1]]]\n\
                 [[surface]]\nname = \"wall-lit\"\nmaterial = \"w\"\npolygons = [[[1, 0, 0], [1, 0, 1], [1, 1, 1], [1, 1, 0]]]\n"
            .to_string(),
    };
    let text = format!(
        "[[material]]\nname = \"w\"\nreflectance = [0.8, 0.8, 0.8]\n\
         [[material]]\nname = \"lamp\"\nreflectance = [0.5, 0.5, 0.5]\nradiance = [10, 10, 10]\n\
         [[box]]\nname = \"hall\"\nmaterial = \"w\"\nmin = [0, 0, 0]\nmax = [{x2}, 1, 1]\ninward = true\n\
         {wall}\
         [[surface]]\nname = \"lamp\"\nmaterial = \"lamp\"\n\
         polygons = [[[0.4, 0.4, 0.95], [0.4, 0.6, 0.95], [0.6, 0.6, 0.95], [0.6, 0.4, 0.95]]]\n\
         [mesh]\nelement_size = 0.1\npatch_size = 0.3\n"
    );
    let name = match thickness {
        Some(t) => format!("rooms-{t}.toml"),
        None => "rooms-0.toml".into(),
    };
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// Mean radiosity of elements in the lit room and the largest in the dark one.
fn lit_and_dark(
    elements: &[(String, [f64; 3], [f64; 3])],
    dark: impl Fn(&str, [f64; 3]) -> bool,
) -> (f64, f64) {
    let lit: Vec<f64> = elements
        .iter()
        .filter(|e| !dark(&e.0, e.1) && e.0 != "lamp")
        .map(|e| e.2[0])
        .collect();
    let dark_max = elements
        .iter()
        .filter(|e| dark(&e.0, e.1))
        .map(|e| e.2[0])
        .fold(0.0, f64::max);
    (lit.iter().sum::<f64>() / lit.len() as f64, dark_max)
}

#[test]
fn thin_and_zero_thickness_walls_do_not_leak() {
    walls_do_not_leak("obvhs", &[&[], &["--exact"]]);
}

/// The same walls with Embree answering the occlusion queries; low-rank bakes only, to keep
/// CI short (the exact solves take minutes and ask the same occluder; measured once: dark
/// max 0 with `--exact` too).
#[cfg(feature = "embree")]
#[test]
fn thin_and_zero_thickness_walls_do_not_leak_embree() {
    walls_do_not_leak("embree", &[&[]]);
}

fn walls_do_not_leak(visibility: &str, solves: &[&[&str]]) {
    let dir = temp_dir(&format!("thin-walls-{visibility}"));
    for thickness in [Some(0.01), None] {
        let scene = two_rooms(&dir, thickness);
        let x_dark = 1.0 + thickness.unwrap_or(0.0);
        for &extra in solves {
            let mut extra = extra.to_vec();
            extra.extend(["--visibility", visibility]);
            let e = solve(&scene, &extra);
            // The dark room: everything beyond the wall, and the wall's face towards it.
            let (lit, dark) = lit_and_dark(&e, |name, c| {
                c[0] > x_dark + 1e-9 || name == "wall.+x" || name == "wall-dark"
            });
            println!("wall {thickness:?} {extra:?}: lit mean {lit:.4e}, dark max {dark:.3e}");
            assert!(
                lit > 0.0 && dark <= 1e-6 * lit,
                "light leaks: dark {dark} vs lit {lit}"
            );
        }
    }
}

/// Nothing leaks into the dark room (≤ 1e-6 of the lit mean; measured 0) with 2MF, the exact
/// solve and the default, 2MSC. 2MSC leaked 1.1e-5 until pairs whose sampled segments all
/// graze stopped falling back to a centroid ray that exchanges no light (it crossed the
/// coincident walls, whose faces the own-face rule skips; `formfactor::visible`).
#[test]
fn concave_corner_does_not_leak() {
    corner_does_not_leak(
        "obvhs",
        &[
            (&["--method", "2mf"], 1e-6),
            (&["--exact"], 1e-6),
            (&[], 1e-6),
        ],
    );
}

/// The same corner with Embree answering the occlusion queries (low-rank only, as above).
#[cfg(feature = "embree")]
#[test]
fn concave_corner_does_not_leak_embree() {
    corner_does_not_leak("embree", &[(&["--method", "2mf"], 1e-6), (&[], 1e-6)]);
}

fn corner_does_not_leak(visibility: &str, solves: &[(&[&str], f64)]) {
    // An L-shaped room around a closed dark room sitting in its notch: the L's inner walls
    // and the dark room's walls coincide back to back, and meet at a concave corner.
    let dir = temp_dir(&format!("corner-{visibility}"));
    let text = "[[material]]\nname = \"w\"\nreflectance = [0.8, 0.8, 0.8]\n\
        [[material]]\nname = \"lamp\"\nreflectance = [0.5, 0.5, 0.5]\nradiance = [10, 10, 10]\n\
        [[surface]]\nname = \"l-floor\"\nmaterial = \"w\"\n\
        polygons = [[[0, 0, 0], [2, 0, 0], [2, 1, 0], [1, 1, 0], [1, 2, 0], [0, 2, 0]]]\n\
        [[surface]]\nname = \"l-ceiling\"\nmaterial = \"w\"\n\
        polygons = [[[0, 0, 1], [0, 2, 1], [1, 2, 1], [1, 1, 1], [2, 1, 1], [2, 0, 1]]]\n\
        [[surface]]\nname = \"l-walls\"\nmaterial = \"w\"\npolygons = [\n\
          [[0, 0, 0], [0, 0, 1], [2, 0, 1], [2, 0, 0]],\n\
          [[2, 0, 0], [2, 0, 1], [2, 1, 1], [2, 1, 0]],\n\
          [[2, 1, 0], [2, 1, 1], [1, 1, 1], [1, 1, 0]],\n\
          [[1, 1, 0], [1, 1, 1], [1, 2, 1], [1, 2, 0]],\n\
          [[1, 2, 0], [1, 2, 1], [0, 2, 1], [0, 2, 0]],\n\
          [[0, 2, 0], [0, 2, 1], [0, 0, 1], [0, 0, 0]]]\n\
        [[box]]\nname = \"dark\"\nmaterial = \"w\"\nmin = [1, 1, 0]\nmax = [2, 2, 1]\ninward = true\n\
        [[surface]]\nname = \"lamp\"\nmaterial = \"lamp\"\n\
        polygons = [[[1.4, 0.4, 0.95], [1.4, 0.6, 0.95], [1.6, 0.6, 0.95], [1.6, 0.4, 0.95]]]\n\
        [mesh]\nelement_size = 0.1\npatch_size = 0.3\n";
    let scene = dir.join("corner.toml");
    std::fs::write(&scene, text).unwrap();
    for &(extra, bound) in solves {
        let mut extra = extra.to_vec();
        extra.extend(["--visibility", visibility]);
        let e = solve(&scene, &extra);
        let (lit, dark) = lit_and_dark(&e, |name, _| name.starts_with("dark"));
        println!("corner {extra:?}: lit mean {lit:.4e}, dark max {dark:.3e}");
        assert!(
            lit > 0.0 && dark <= bound * lit,
            "{extra:?}: light leaks: dark {dark} vs lit {lit}"
        );
    }
}
