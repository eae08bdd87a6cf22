//! The `lrr` binary itself: exit codes and the one-line error. (Its presence here also makes
//! `cargo test` build `target/<profile>/lrr`, which the end-to-end tests run as a process.)

use std::process::Command;

#[test]
fn failure_exits_non_zero_with_one_line() {
    let out = Command::new(env!("CARGO_BIN_EXE_lrr"))
        .args(["info", "/nonexistent.lrr"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("lrr: error: /nonexistent.lrr"), "{err}");
}

#[test]
fn help_and_version_succeed() {
    for args in [
        &["--help"][..],
        &["--version"],
        &["bake", "--help"],
        &["probe", "--help"],
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_lrr"))
            .args(args)
            .output()
            .unwrap();
        assert!(out.status.success(), "{args:?}");
        assert!(!out.stdout.is_empty());
    }
}

/// Runs `lrr ARGS…` with extra environment variables; returns (status, stdout, stderr).
fn lrr(args: &[&str], env: &[(&str, &str)]) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_lrr"))
        .args(args)
        .envs(env.iter().copied())
        .output()
        .unwrap();
    let text = |b: Vec<u8>| String::from_utf8(b).unwrap();
    (out.status.code(), text(out.stdout), text(out.stderr))
}

/// A baked furnace and a few probe points in a fresh folder.
fn furnace_and_points(name: &str) -> (std::path::PathBuf, std::path::PathBuf) {
    let dir = std::env::temp_dir().join(format!("lrr-cli-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (scene, file, points) = (dir.join("f.toml"), dir.join("f.lrr"), dir.join("p.json"));
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    let (code, _, err) = lrr(&["scene", "furnace", "-o", &s(&scene)], &[]);
    assert_eq!(code, Some(0), "{err}");
    let (code, _, err) = lrr(&["bake", &s(&scene), "-o", &s(&file), "-q"], &[]);
    assert_eq!(code, Some(0), "{err}");
    std::fs::write(
        &points,
        r#"[{"position":[0.5,0.5,0.0],"normal":[0,0,1]},{"position":[0.25,0.0,0.75],"normal":[0,1,0]}]"#,
    )
    .unwrap();
    (file, points)
}

fn radiosity(json: &str) -> Vec<f64> {
    let v: serde_json::Value = serde_json::from_str(json).unwrap();
    v.as_array()
        .unwrap()
        .iter()
        .flat_map(|p| p["radiosity"].as_array().unwrap().clone())
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// Hides every Vulkan driver from wgpu (and every other backend), whatever the machine has.
const NO_ADAPTER: [(&str, &str); 3] = [
    ("WGPU_BACKEND", "vulkan"),
    ("VK_ICD_FILENAMES", "/nonexistent/icd.json"),
    ("VK_DRIVER_FILES", "/nonexistent/icd.json"),
];

#[test]
fn probe_without_an_adapter_fails_for_gpu_and_falls_back_for_auto() {
    let (file, points) = furnace_and_points("no-adapter");
    let (f, p) = (file.to_str().unwrap(), points.to_str().unwrap());
    let (code, cpu, err) = lrr(&["probe", f, "--points", p, "--json"], &[]);
    assert_eq!(code, Some(0), "{err}");
    let (code, _, err) = lrr(&["probe", f, "--points", p, "--device", "gpu"], &NO_ADAPTER);
    assert_eq!(code, Some(1));
    let last = err.lines().last().unwrap_or("");
    assert!(last.starts_with("lrr: error: --device gpu: "), "{err}");
    assert!(
        last.contains("apt-get install mesa-vulkan-drivers"),
        "{err}"
    );
    let (code, auto, err) = lrr(
        &["probe", f, "--points", p, "--json", "--device", "auto"],
        &NO_ADAPTER,
    );
    assert_eq!(code, Some(0), "{err}");
    assert!(
        err.contains("lrr: note: --device auto: evaluating on the CPU"),
        "{err}"
    );
    assert_eq!(auto, cpu);
}

/// A bake carries smooth weights, so `lrr probe` reconstructs smooth by default; in the furnace
/// the radiosity is the same everywhere, so smooth and flat agree within f32 rounding.
#[test]
fn probe_reconstructs_smooth_by_default_and_flat_when_asked() {
    let (file, points) = furnace_and_points("reconstruct");
    let (f, p) = (file.to_str().unwrap(), points.to_str().unwrap());
    let probe = |extra: &[&str]| {
        let mut args = vec!["probe", f, "--points", p, "--json"];
        args.extend_from_slice(extra);
        let (code, out, err) = lrr(&args, &[]);
        assert_eq!(code, Some(0), "{err}");
        assert!(!err.contains("no smooth weights"), "{err}");
        out
    };
    let (default, smooth, flat) = (
        probe(&[]),
        probe(&["--reconstruct", "smooth"]),
        probe(&["--reconstruct", "flat"]),
    );
    assert_eq!(default, smooth);
    let (rs, rf) = (radiosity(&smooth), radiosity(&flat));
    assert_eq!(rs.len(), 6);
    for (a, b) in rs.iter().zip(&rf) {
        assert!((a - b).abs() <= 1e-5 * b, "smooth {rs:?}, flat {rf:?}");
    }
    let (code, _, err) = lrr(&["probe", f, "--points", p, "--reconstruct", "cubic"], &[]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("possible values: flat, smooth"), "{err}");
}

#[test]
#[ignore = "needs a Vulkan adapter: scripts/test runs it with --ignored where lavapipe is installed"]
fn probe_on_the_gpu_matches_the_cpu() {
    let (file, points) = furnace_and_points("gpu");
    let (f, p) = (file.to_str().unwrap(), points.to_str().unwrap());
    let (code, cpu, err) = lrr(&["probe", f, "--points", p, "--json"], &[]);
    assert_eq!(code, Some(0), "{err}");
    let (code, gpu, err) = lrr(
        &["probe", f, "--points", p, "--json", "--device", "gpu"],
        &[],
    );
    assert_eq!(code, Some(0), "{err}");
    if let Ok(expected) = std::env::var("LRR_EXPECT_ADAPTER") {
        assert!(err.contains(&format!("evaluating on {expected}")), "{err}");
    }
    let (cpu, gpu) = (radiosity(&cpu), radiosity(&gpu));
    assert_eq!(cpu.len(), gpu.len());
    for (c, g) in cpu.iter().zip(&gpu) {
        assert!((c - g).abs() <= 1e-5 * c.abs(), "cpu {c} gpu {g}");
    }
}

#[test]
fn bench_runtime_without_an_adapter_fails_for_gpu_and_falls_back_for_auto() {
    let args = |device: &'static str| {
        [
            "bench",
            "runtime",
            "--sizes",
            "600x20",
            "--precisions",
            "f32",
            "--no-cornell",
            "--rounds",
            "1",
            "--seconds",
            "0.01",
            "--device",
            device,
        ]
    };
    let (code, _, err) = lrr(&args("gpu"), &NO_ADAPTER);
    assert_eq!(code, Some(1), "{err}");
    let last = err.lines().last().unwrap_or("");
    assert!(last.starts_with("lrr: error: --device gpu: "), "{err}");
    let (code, out, err) = lrr(&args("auto"), &NO_ADAPTER);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        err.contains("lrr: note: --device auto: benchmarking the CPU"),
        "{err}"
    );
    assert!(out.contains("600"), "the CPU table: {out}");
}

#[test]
#[ignore = "needs a Vulkan adapter: scripts/test runs it with --ignored where lavapipe is installed"]
fn bench_runtime_on_the_gpu_reports_every_column() {
    let (code, out, err) = lrr(
        &[
            "bench",
            "runtime",
            "--device",
            "gpu",
            "--sizes",
            "3000x40",
            "--precisions",
            "f32,f16",
            "--no-cornell",
            "--frames",
            "2",
            "--bounds-checks",
            "--json",
        ],
        &[],
    );
    assert_eq!(code, Some(0), "{err}");
    let rows: serde_json::Value = serde_json::from_str(&out).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 2, "{out}");
    for (row, precision) in rows.iter().zip(["f32", "f16"]) {
        assert_eq!(row["precision"], precision);
        assert_eq!(
            (row["n"].as_u64(), row["k"].as_u64()),
            (Some(3000), Some(40))
        );
        if let Ok(expected) = std::env::var("LRR_EXPECT_ADAPTER") {
            let adapter = row["adapter"].as_str().unwrap().to_lowercase();
            assert!(adapter.contains(&expected.to_lowercase()), "{row}");
        }
        for column in [
            "end_to_end_fps",
            "cpu_fps",
            "speedup_end_to_end",
            "pipelined_fps",
            "hybrid_end_to_end_fps",
            "hybrid_pipelined_fps",
            "hybrid_gain",
            "bounds_check_cost",
        ] {
            let v = row[column].as_f64();
            assert!(
                v.is_some_and(|v| v > 0.0 && v.is_finite()),
                "{column}: {row}"
            );
        }
        // Rows of 40 entries padded to 40 (a multiple of 8), 4 or 2 bytes each.
        let size = if precision == "f32" { 4 } else { 2 };
        assert_eq!(row["matrix_bytes"].as_u64(), Some(3000 * 40 * size));
    }
}
