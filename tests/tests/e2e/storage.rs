//! Storage options of a bake (f16, plain Y_k), light groups and albedo edits, end to end.

use lrr_runtime::{Operator, RgbMut};

use crate::util::{cornell, lrr, temp_dir};

fn bake(dir: &std::path::Path, name: &str, scene: &std::path::Path, extra: &[&str]) -> Operator {
    let out = dir.join(format!("{name}.lrr"));
    crate::util::bake(scene, &out, extra).unwrap();
    Operator::load(&out).unwrap()
}

fn relative_l2(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let wide = |v: &[[f32; 3]]| v.iter().map(|x| x.map(f64::from)).collect::<Vec<_>>();
    lrr_precompute::radiosity::relative_l2(&wide(a), &wide(b))
}

#[test]
fn f16_plain_layout_and_light_groups_agree_with_the_default_file() {
    let dir = temp_dir("storage");
    let scene = cornell();
    let f32_op = bake(&dir, "f32", &scene, &[]);
    let reference = f32_op.evaluate_baked();
    let plain = bake(&dir, "plain", &scene, &["--layout", "plain"]).evaluate_baked();
    let half = bake(&dir, "f16", &scene, &["--precision", "f16"]).evaluate_baked();
    let (e_plain, e_half) = (
        relative_l2(&plain, &reference),
        relative_l2(&half, &reference),
    );
    println!(
        "Cornell box: plain Y_k vs factored {e_plain:.2e}, f16 vs f32 {e_half:.2e} (relative L2)"
    );
    assert!(e_plain < 1e-5, "{e_plain}");
    // f16 rounds each F_k entry by at most 2^-11 relative; errors average over k terms.
    assert!(e_half < 2f64.powi(-11), "{e_half}");
    // One light group per emitting surface: intensity 1 reproduces the baked frame.
    let groups: Vec<&str> = f32_op.light_groups().collect();
    assert_eq!(groups, vec!["light"]);
    let mut out = vec![[0.0f32; 3]; f32_op.n()];
    f32_op
        .evaluate_groups(&[1.0], RgbMut::triples(&mut out))
        .unwrap();
    assert!(relative_l2(&out, &reference) < 1e-5);
    f32_op
        .evaluate_groups(&[2.0], RgbMut::triples(&mut out))
        .unwrap();
    let doubled: Vec<[f32; 3]> = reference.iter().map(|b| b.map(|x| 2.0 * x)).collect();
    assert!(relative_l2(&out, &doubled) < 1e-5);
}

#[test]
fn an_albedo_edit_equals_a_fresh_bake() {
    let dir = temp_dir("albedo");
    // A mesh that does not depend on the materials: 2MSC's patches and the refinement where
    // light changes (the default) follow the light, so a fresh bake of the edited scene may mesh
    // otherwise (measured: 4.0e-3 relative L2 with the default flags); an edit keeps the mesh.
    let flags = ["--method", "2mf", "--refine", "0"];
    let original = bake(&dir, "original", &cornell(), &flags);
    // The same scene with a blue right wall and greyer floor.
    let text = std::fs::read_to_string(cornell()).unwrap();
    let edited = text
        .replace(
            "reflectance = [0.63, 0.065, 0.05]",
            "reflectance = [0.05, 0.1, 0.7]",
        )
        .replace(
            "reflectance = [0.725, 0.71, 0.68]",
            "reflectance = [0.5, 0.5, 0.5]",
        );
    assert_ne!(edited, text);
    let scene = dir.join("edited.toml");
    std::fs::write(&scene, edited).unwrap();
    let fresh = bake(&dir, "fresh", &scene, &flags);
    let mut op = original.clone();
    op.set_reflectance(&fresh.reflectance()).unwrap();
    let (a, b) = (op.evaluate_baked(), fresh.evaluate_baked());
    let e = relative_l2(&a, &b);
    println!("albedo edit vs fresh bake: relative L2 {e:.2e}");
    assert!(e < 1e-5, "{e}");
    assert!(
        relative_l2(&original.evaluate_baked(), &b) > 1e-2,
        "the edit must change the result"
    );
}

#[test]
fn bench_runtime_prints_the_promised_json_rows() {
    let text = lrr(&[
        "bench",
        "runtime",
        "--sizes",
        "96x8,200x20",
        "--seconds",
        "0.01",
        "--rounds",
        "1",
        "--no-cornell",
        "--json",
    ])
    .unwrap();
    let rows: serde_json::Value = serde_json::from_str(&text).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 4, "two sizes × f32, f16");
    for r in rows {
        for key in [
            "n",
            "k",
            "precision",
            "fps",
            "roofline_ratio",
            "speedup_vs_dense",
            "fps_dense",
            "bytes_per_frame",
            "dense_bytes_per_frame",
            "byte_ratio",
            "fps_dense_read",
            "dense_roofline_ratio",
        ] {
            assert!(!r[key].is_null(), "{key} missing in {r}");
        }
        assert!(r["fps"].as_f64().unwrap() > 0.0 && r["roofline_ratio"].as_f64().unwrap() > 0.0);
        assert!(r["dense_roofline_ratio"].as_f64().unwrap() > 0.0);
        // The baseline reads V_k and three Y_c in the operator's precision: 4 × the bytes of F_k.
        let (a, c) = (
            r["bytes_per_frame"].as_u64(),
            r["dense_bytes_per_frame"].as_u64(),
        );
        let (n, k) = (r["n"].as_u64().unwrap(), r["k"].as_u64().unwrap());
        let size = if r["precision"] == "f16" { 2 } else { 4 };
        assert_eq!(a, Some(n * k * size), "{r}");
        assert_eq!(c, Some(4 * n * k * size), "{r}");
        assert_eq!(r["byte_ratio"].as_f64(), Some(4.0), "{r}");
    }
    let err = lrr(&["bench", "runtime", "--sizes", "10x20"]).unwrap_err();
    assert!(err.contains("k <= n"), "{err}");
}
