//! Helpers: paths, running `lrr` in-process, temporary folders.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};

/// The repository root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// The project's Cornell box description.
pub fn cornell() -> PathBuf {
    root().join("scenes/cornell-box/cornell-box.toml")
}

/// The public Cornell box OBJ in ../shared (used by path, never copied).
pub fn shared_cornell_obj() -> PathBuf {
    root().join("../shared/scenes/cornell-box/CornellBox-Original.obj")
}

/// A fresh temporary folder for one test.
pub fn temp_dir(name: &str) -> PathBuf {
    static COUNTER: AtomicU32 = AtomicU32::new(0);
    let dir = std::env::temp_dir().join(format!(
        "lrr-e2e-{}-{name}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs `lrr ARGS…` in-process; returns its standard output, or the error chain.
pub fn lrr(args: &[&str]) -> Result<String, String> {
    let mut out = Vec::new();
    let argv = std::iter::once("lrr").chain(args.iter().copied());
    match lrr_cli::run(argv, &mut out) {
        Ok(()) => Ok(String::from_utf8(out).unwrap()),
        Err(e) => Err(e
            .chain()
            .map(|c| c.to_string())
            .collect::<Vec<_>>()
            .join(": ")),
    }
}

/// Runs `lrr bake SCENE -o OUT -q EXTRA…` in-process.
pub fn bake(scene: &Path, out: &Path, extra: &[&str]) -> Result<String, String> {
    let mut args = vec![
        "bake",
        scene.to_str().expect("UTF-8 path"),
        "-o",
        out.to_str().expect("UTF-8 path"),
        "-q",
    ];
    args.extend_from_slice(extra);
    lrr(&args)
}

/// Runs `lrr` and parses its JSON output.
pub fn lrr_json(args: &[&str]) -> serde_json::Value {
    let text = lrr(args).unwrap_or_else(|e| panic!("lrr {args:?} failed: {e}"));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("lrr {args:?}: bad JSON ({e}): {text}"))
}

/// Writes a generated scene (`lrr scene …`) into `dir` and returns its path.
pub fn generated_scene(dir: &Path, name: &str, args: &[&str]) -> PathBuf {
    let path = dir.join(format!("{name}.toml"));
    let mut argv = vec!["scene"];
    argv.extend_from_slice(args);
    argv.extend_from_slice(&["-o", path.to_str().unwrap()]);
    lrr(&argv).unwrap();
    path
}

/// `F_ij` from a view-factors JSON by surface names.
pub fn factor(vf: &serde_json::Value, from: &str, to: &str) -> f64 {
    let names: Vec<&str> = vf["surfaces"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s.as_str().unwrap())
        .collect();
    let i = names.iter().position(|n| *n == from).unwrap();
    let j = names.iter().position(|n| *n == to).unwrap();
    vf["matrix"][i][j].as_f64().unwrap()
}

/// The `lrr` binary of this build (built by `cargo test`, or here if missing).
pub fn lrr_binary() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let dir = exe.parent().unwrap().parent().unwrap(); // target/<profile>/deps/.. → target/<profile>
    let bin = dir.join("lrr");
    if !bin.exists() {
        let profile = dir.file_name().unwrap().to_str().unwrap().to_string();
        let mut cmd = std::process::Command::new(env!("CARGO"));
        cmd.args(["build", "--bin", "lrr", "--manifest-path"])
            .arg(root().join("Cargo.toml"));
        if profile == "release" {
            cmd.arg("--release");
        }
        cmd.env("CARGO_TARGET_DIR", dir.parent().unwrap());
        assert!(cmd.status().unwrap().success(), "building lrr failed");
    }
    bin
}

/// Per element from `lrr solve SCENE --json EXTRA…`: (surface, centroid, radiosity).
pub fn solve_elements(scene: &Path, extra: &[&str]) -> Vec<(String, [f64; 3], [f64; 3])> {
    let mut args = vec!["solve", scene.to_str().unwrap(), "--json", "--quiet"];
    args.extend_from_slice(extra);
    let v = lrr_json(&args);
    let triple = |x: &serde_json::Value| -> [f64; 3] {
        let a = x.as_array().unwrap();
        [
            a[0].as_f64().unwrap(),
            a[1].as_f64().unwrap(),
            a[2].as_f64().unwrap(),
        ]
    };
    v["elements"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| {
            (
                e["surface"].as_str().unwrap().to_string(),
                triple(&e["centroid"]),
                triple(&e["radiosity"]),
            )
        })
        .collect()
}
