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

/// The project's Cornell box as OBJ (+ MTL beside it), generated from [`cornell()`] by
/// [`description_to_obj`] (`cornell::write_cornell_obj`; a test checks the files are current).
pub fn cornell_obj() -> PathBuf {
    root().join("scenes/cornell-box/cornell-box.obj")
}

/// The public archive Cornell box OBJ (public domain, committed unchanged with its MTL in
/// `tests/data/cornell-box-archive/`, see its README).
pub fn archive_cornell_obj() -> PathBuf {
    root().join("tests/data/cornell-box-archive/CornellBox-Original.obj")
}

/// A scene description written as Wavefront OBJ and MTL text, returned as `(obj, mtl)`.
///
/// Each surface becomes a group (`g NAME`, `usemtl MATERIAL`, one `f` per polygon in the
/// description's vertex order, so the counter-clockwise front is kept); each distinct vertex is
/// written once, in order of first use, with `scale` applied. Materials keep their order: `Kd`
/// is the reflectance, `Ke` the radiance (written only when non-zero). Numbers are Rust's
/// shortest round-trip decimals, so the OBJ importer reads back exactly the description's
/// coordinates. `mtl_name` is what `mtllib` names; `header` (comment lines) opens both files.
/// Boxes, OBJ includes and mesh hints have no OBJ form: a description with any is refused.
pub fn description_to_obj(
    desc: &lrr_precompute::scene::description::SceneDescription,
    mtl_name: &str,
    header: &str,
) -> (String, String) {
    use std::fmt::Write;
    assert!(
        desc.boxes.is_empty() && desc.includes.is_empty(),
        "boxes and includes have no OBJ form"
    );
    assert!(
        desc.mesh.element_size.is_none() && desc.mesh.patch_size.is_none(),
        "mesh hints have no OBJ form"
    );
    let mut mtl = header.to_string();
    for m in &desc.materials {
        let [r, g, b] = m.reflectance;
        write!(mtl, "\nnewmtl {}\nKd {r} {g} {b}\n", m.name).unwrap();
        if m.radiance.iter().any(|&x| x != 0.0) {
            let [r, g, b] = m.radiance;
            writeln!(mtl, "Ke {r} {g} {b}").unwrap();
        }
    }
    let mut vertices: Vec<[f64; 3]> = Vec::new();
    let mut ids = std::collections::HashMap::new();
    let mut groups = String::new();
    for surface in &desc.surfaces {
        write!(
            groups,
            "\ng {}\nusemtl {}\n",
            surface.name, surface.material
        )
        .unwrap();
        for polygon in &surface.polygons {
            groups.push('f');
            for p in polygon {
                let v = p.map(|x| x * desc.scale);
                let id = *ids.entry(v.map(f64::to_bits)).or_insert_with(|| {
                    vertices.push(v);
                    vertices.len()
                });
                write!(groups, " {id}").unwrap();
            }
            groups.push('\n');
        }
    }
    let mut obj = format!("{header}mtllib {mtl_name}\n\n");
    for [x, y, z] in vertices {
        writeln!(obj, "v {x} {y} {z}").unwrap();
    }
    obj.push_str(&groups);
    (obj, mtl)
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

/// The `lrr` binary of the sources under test: `cargo build --bin lrr` of this profile and
/// target directory, once per test process (a no-op when `cargo test` has just built it), so a
/// stale binary left in `target/` is never what a test runs. (Cargo gives `CARGO_BIN_EXE_lrr`
/// only to the tests of the package that owns the binary, `cli/tests`.)
pub fn lrr_binary() -> PathBuf {
    static BUILT: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    BUILT
        .get_or_init(|| {
            let exe = std::env::current_exe().unwrap();
            let dir = exe.parent().unwrap().parent().unwrap(); // target/<profile>/deps/.. → target/<profile>
            let profile = dir.file_name().unwrap().to_str().unwrap().to_string();
            let mut cmd = std::process::Command::new(env!("CARGO"));
            cmd.args(["build", "--quiet", "--bin", "lrr", "--manifest-path"])
                .arg(root().join("Cargo.toml"));
            if profile == "release" {
                cmd.arg("--release");
            }
            cmd.env("CARGO_TARGET_DIR", dir.parent().unwrap());
            assert!(cmd.status().unwrap().success(), "building lrr failed");
            let bin = dir.join("lrr");
            assert!(bin.exists(), "cargo build left no {}", bin.display());
            bin
        })
        .clone()
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

/// `lrr probe FILE --points … --json` at `points` (position, normal): the radiosity at each
/// (the smooth reconstruction, `lrr probe`'s default).
pub fn probe(file: &Path, points: &[([f64; 3], [f64; 3])]) -> Vec<[f64; 3]> {
    let dir = temp_dir("probe");
    let path = dir.join("points.json");
    let json: Vec<serde_json::Value> = points
        .iter()
        .map(|(p, n)| serde_json::json!({"position": p, "normal": n}))
        .collect();
    std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();
    let v = lrr_json(&[
        "probe",
        file.to_str().unwrap(),
        "--points",
        path.to_str().unwrap(),
        "--json",
    ]);
    v.as_array()
        .unwrap()
        .iter()
        .map(|p| {
            let r = p["radiosity"].as_array().unwrap();
            [0, 1, 2].map(|c| r[c].as_f64().unwrap())
        })
        .collect()
}
