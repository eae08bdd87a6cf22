//! Operator files end to end: reports, info, probes, corrupt bytes, atomic replacement.

use lrr_runtime::Operator;

use crate::util::{bake, generated_scene, lrr, lrr_json, temp_dir};

/// A small real bake (a coarse furnace) and its bytes.
fn small_bake(dir: &std::path::Path) -> std::path::PathBuf {
    let scene = generated_scene(dir, "small", &["furnace", "--reflectance", "0.7"]);
    let out = dir.join("small.lrr");
    bake(
        &scene,
        &out,
        &["--element-size", "0.5", "--patch-size", "1"],
    )
    .unwrap();
    out
}

#[test]
fn every_prefix_and_flipped_byte_of_a_baked_file_is_an_error_not_a_panic() {
    let dir = temp_dir("corrupt");
    let bytes = std::fs::read(small_bake(&dir)).unwrap();
    let good = Operator::from_bytes(&bytes).unwrap();
    assert!(good.n() > 0);
    for len in 0..bytes.len() {
        assert!(
            Operator::from_bytes(&bytes[..len]).is_err(),
            "prefix {len} accepted"
        );
    }
    let mut detected = 0;
    for i in 0..bytes.len() {
        let mut b = bytes.clone();
        b[i] ^= 0x5a;
        match Operator::from_bytes(&b) {
            Err(_) => detected += 1,
            // Only padding may be flipped without consequence, and then nothing changed.
            Ok(op) => assert_eq!(
                op.file(),
                good.file(),
                "byte {i} changed the content silently"
            ),
        }
    }
    println!(
        "{detected} of {} flipped bytes detected (the rest are padding)",
        bytes.len()
    );
    assert!(detected > bytes.len() / 2);
}

#[test]
fn report_info_and_probe_agree() {
    let dir = temp_dir("report");
    let scene = generated_scene(&dir, "f", &["furnace", "--reflectance", "0.5"]);
    let out = dir.join("f.lrr");
    let report = dir.join("r.json");
    // 2MF: its k is known in advance (2MSC sees a uniform furnace as a few coherent patches).
    bake(
        &scene,
        &out,
        &["--report", report.to_str().unwrap(), "--method", "2mf"],
    )
    .unwrap();
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let (n, k) = (r["n"].as_u64().unwrap(), r["k"].as_u64().unwrap());
    assert_eq!((n, k), (384, 96));
    let condition = r["condition"].as_f64().unwrap();
    assert!(condition >= 1.0 && condition.is_finite());
    for stage in ["mesh", "visibility", "form factors", "operator", "write"] {
        assert!(
            r["stages"][stage].as_f64().unwrap() >= 0.0,
            "stage {stage} missing"
        );
    }
    let info = lrr_json(&["info", out.to_str().unwrap(), "--json"]);
    assert_eq!(info["n"].as_u64(), Some(n));
    assert_eq!(info["k"].as_u64(), Some(k));
    assert_eq!(info["channels"].as_u64(), Some(1));
    let points = dir.join("p.json");
    std::fs::write(&points, r#"[{"position":[0.3,0.6,0.0],"normal":[0,0,1]},{"position":[0.3,0.6,1.0],"normal":[0,0,-1]}]"#)
        .unwrap();
    let p = lrr_json(&[
        "probe",
        out.to_str().unwrap(),
        "--points",
        points.to_str().unwrap(),
        "--json",
        // the element's value, compared with the evaluation per element below
        "--reconstruct",
        "flat",
    ]);
    let op = Operator::load(&out).unwrap();
    let b = op.evaluate_baked();
    for probe in p.as_array().unwrap() {
        let id = probe["element"].as_u64().unwrap() as usize;
        let r = probe["radiosity"].as_array().unwrap();
        assert_eq!(r[0].as_f64().unwrap() as f32, b[id][0]);
        assert_eq!(probe["position"].as_array().unwrap().len(), 3);
    }
    // The floor point and the ceiling point above it are different elements (normals differ).
    assert_ne!(p[0]["element"], p[1]["element"]);
}

#[test]
fn a_failed_bake_leaves_the_previous_file_intact() {
    let dir = temp_dir("atomic");
    let out = small_bake(&dir);
    let before = std::fs::read(&out).unwrap();
    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        "[[material]]\nname = \"m\"\nreflectance = [0.5, 0.5, 2.0]\n",
    )
    .unwrap();
    let err = bake(&bad, &out, &[]).unwrap_err();
    assert!(
        err.contains("bad.toml") && err.contains("reflectance"),
        "{err}"
    );
    assert_eq!(std::fs::read(&out).unwrap(), before);
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .collect();
    assert!(
        leftovers
            .iter()
            .all(|e| !e.file_name().to_string_lossy().contains(".tmp")),
        "temp files left"
    );
}

#[test]
fn bad_arguments_get_one_line_errors() {
    let err = lrr(&["bake", "/nonexistent/scene.obj", "-o", "/tmp/x.lrr"]).unwrap_err();
    assert!(err.contains("/nonexistent/scene.obj"), "{err}");
    let err = lrr(&["info", "/nonexistent.lrr"]).unwrap_err();
    assert!(err.contains("/nonexistent.lrr"), "{err}");
    let err = lrr(&["bake"]).unwrap_err();
    assert!(err.contains("SCENE") || err.contains("scene"), "{err}");
    assert!(lrr(&["--help"]).unwrap().contains("bake"));
    assert!(lrr(&["bake", "--help"]).unwrap().contains("--element-size"));
}
