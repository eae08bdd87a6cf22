//! The C interface end to end: bake the Cornell box, build liblrr_capi (static and shared),
//! compile `runtime/capi/examples/relight.c` with the system C compiler against each, run it on
//! probe points and compare with `lrr probe --json`: the same elements, the same floats. The
//! library is the C interface's default build, which compiles no ray tracer (checked below).

#![cfg(target_os = "linux")]

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::util::{bake, cornell, lrr_json, root, temp_dir};

/// Points on the Cornell box's surfaces (millimetres, y up): floor, ceiling, light, back wall,
/// red and green walls, the top of the short block.
const POINTS: [([f32; 3], [f32; 3]); 7] = [
    ([278.0, 0.0, 280.0], [0.0, 1.0, 0.0]),
    ([100.0, 548.8, 100.0], [0.0, -1.0, 0.0]),
    ([278.0, 548.8, 280.0], [0.0, -1.0, 0.0]),
    ([278.0, 274.0, 559.2], [0.0, 0.0, -1.0]),
    ([555.0, 274.0, 280.0], [-1.0, 0.0, 0.0]),
    ([0.0, 274.0, 280.0], [1.0, 0.0, 0.0]),
    ([185.0, 165.0, 169.0], [0.0, 1.0, 0.0]),
];

/// Builds lrr-capi in release with the cargo running these tests (same target directory, from
/// the same environment) and returns the paths of `liblrr_capi.a` and `liblrr_capi.so`, read
/// from cargo's JSON messages so that CARGO_TARGET_DIR or a build-dir setting changes nothing.
fn build_libraries() -> (PathBuf, PathBuf) {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let output = Command::new(cargo)
        .args([
            "build",
            "--release",
            "-p",
            "lrr-capi",
            "--message-format=json",
        ])
        .current_dir(root())
        .output()
        .expect("cannot run cargo");
    assert!(
        output.status.success(),
        "cargo build -p lrr-capi failed:\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let mut files = Vec::new();
    for line in String::from_utf8(output.stdout).unwrap().lines() {
        let Ok(msg) = serde_json::from_str::<serde_json::Value>(line) else {
            continue;
        };
        if msg["reason"] == "compiler-artifact" && msg["target"]["name"] == "lrr_capi" {
            let names = msg["filenames"].as_array().unwrap();
            files.extend(names.iter().map(|f| PathBuf::from(f.as_str().unwrap())));
        }
    }
    let find = |ext: &str| {
        files
            .iter()
            .find(|f| f.extension().is_some_and(|e| e == ext))
            .unwrap_or_else(|| panic!("no liblrr_capi.{ext} among {files:?}"))
            .clone()
    };
    (find("a"), find("so"))
}

/// Runs the system C compiler; a missing compiler is a failure with a clear message.
fn cc(args: &[&str]) {
    let out = Command::new("cc")
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("the C interface tests need a C compiler `cc` on PATH ({e})"));
    assert!(
        out.status.success(),
        "cc {args:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Compiles relight.c into `exe`, linked with `link` (library arguments).
fn compile_relight(exe: &Path, link: &[&str]) {
    let capi = root().join("runtime/capi");
    let source = capi.join("examples/relight.c");
    let include = capi.join("include");
    let mut args = vec![
        "-std=c99",
        "-Wall",
        "-Wextra",
        "-pedantic",
        "-Werror",
        "-O1",
        source.to_str().unwrap(),
        "-I",
        include.to_str().unwrap(),
        "-o",
        exe.to_str().unwrap(),
    ];
    args.extend_from_slice(link);
    cc(&args);
}

/// Runs relight and parses its lines `ELEMENT R G B`.
fn relight(exe: &Path, args: &[&str]) -> Vec<(u32, [f32; 3])> {
    let out = Command::new(exe).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "relight {args:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|line| {
            let w: Vec<&str> = line.split_whitespace().collect();
            assert_eq!(w.len(), 4, "bad line: {line}");
            let f = |s: &str| s.parse::<f32>().unwrap();
            (w[0].parse().unwrap(), [f(w[1]), f(w[2]), f(w[3])])
        })
        .collect()
}

/// A Portable Float Map as the C example writes it (RGB, little-endian, rows bottom to top),
/// rows top to bottom.
fn read_pfm(path: &Path) -> (usize, usize, Vec<[f32; 3]>) {
    let bytes = std::fs::read(path).unwrap();
    let mut lines = bytes.splitn(4, |&b| b == b'\n');
    assert_eq!(lines.next(), Some(&b"PF"[..]));
    let size = std::str::from_utf8(lines.next().unwrap()).unwrap();
    let (w, h) = size.split_once(' ').unwrap();
    let (w, h): (usize, usize) = (w.parse().unwrap(), h.parse().unwrap());
    assert_eq!(lines.next(), Some(&b"-1.0"[..]));
    let data = lines.next().unwrap();
    assert_eq!(data.len(), 12 * w * h);
    let floats: Vec<f32> = data
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    let mut rows = Vec::with_capacity(w * h);
    for y in (0..h).rev() {
        for x in 0..w {
            let i = 3 * (y * w + x);
            rows.push([floats[i], floats[i + 1], floats[i + 2]]);
        }
    }
    (w, h, rows)
}

/// Floats equal to f32 precision: within 2 units of the last place (both sides run the same
/// evaluation; the margin only allows a future reordering of one sum).
fn same(a: f32, b: f32) -> bool {
    (a - b).abs() <= 2.0 * f32::EPSILON * a.abs().max(b.abs())
}

#[test]
fn c_program_prints_what_lrr_probe_prints() {
    let dir = temp_dir("capi");
    let baked = dir.join("cornell.lrr");
    let scene = cornell();
    bake(&scene, &baked, &[]).unwrap();
    let json: Vec<serde_json::Value> = POINTS
        .iter()
        .map(|(p, n)| serde_json::json!({"position": p, "normal": n}))
        .collect();
    let points_json = dir.join("points.json");
    std::fs::write(&points_json, serde_json::to_string(&json).unwrap()).unwrap();
    let probe = lrr_json(&[
        "probe",
        baked.to_str().unwrap(),
        "--points",
        points_json.to_str().unwrap(),
        "--json",
        // the element's value, what the C interface's locate + evaluate gives
        "--reconstruct",
        "flat",
    ]);
    let expected: Vec<(u32, [f32; 3])> = probe
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            let b = &p["radiosity"];
            let c = |i: usize| b[i].as_f64().unwrap() as f32;
            (p["element"].as_u64().unwrap() as u32, [c(0), c(1), c(2)])
        })
        .collect();

    // The first points from a file, the last two on the command line.
    let text: String = POINTS[..5]
        .iter()
        .map(|(p, n)| {
            format!(
                "{} {} {}  {} {} {}  # point\n",
                p[0], p[1], p[2], n[0], n[1], n[2]
            )
        })
        .collect();
    let points_txt = dir.join("points.txt");
    std::fs::write(&points_txt, text).unwrap();
    let argv: Vec<String> = POINTS[5..]
        .iter()
        .flat_map(|(p, n)| p.iter().chain(n).map(|x| x.to_string()))
        .collect();
    let mut args = vec![
        baked.to_str().unwrap(),
        "--points",
        points_txt.to_str().unwrap(),
    ];
    args.extend(argv.iter().map(String::as_str));

    let (static_lib, shared_lib) = build_libraries();
    let check = |got: &[(u32, [f32; 3])], scale: f32, what: &str| {
        assert_eq!(got.len(), expected.len(), "{what}");
        for ((ge, gb), (ee, eb)) in got.iter().zip(&expected) {
            assert_eq!(ge, ee, "{what}: element ids differ");
            for c in 0..3 {
                assert!(
                    same(gb[c], scale * eb[c]),
                    "{what}: element {ge}: C {gb:?} vs {scale} × lrr probe {eb:?}"
                );
            }
        }
        println!("{what}: {} points agree with lrr probe", got.len());
    };

    let exe = dir.join("relight-static");
    compile_relight(
        &exe,
        &[static_lib.to_str().unwrap(), "-lpthread", "-ldl", "-lm"],
    );
    check(&relight(&exe, &args), 1.0, "static library");
    // Radiosity is linear in the emission; scaling by 2 is exact in binary floating point.
    let mut scaled = args.clone();
    scaled.extend(["--scale", "2"]);
    check(&relight(&exe, &scaled), 2.0, "static library, emission × 2");

    // The lightmap the C program fills is `lrr export`'s EXR, texel for texel (the radiosity
    // of both sides agrees to 2 ulps, see `same`).
    let pfm = dir.join("lightmap.pfm");
    let mut with_map = args.clone();
    with_map.extend(["--lightmap", pfm.to_str().unwrap()]);
    relight(&exe, &with_map);
    let (w, h, c_texels) = read_pfm(&pfm);
    let exr = dir.join("lightmap.exr");
    crate::util::lrr(&[
        "export",
        baked.to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
        "--samples",
        "float",
    ])
    .unwrap();
    let (ew, eh, exported) = crate::scene_lightmap::read_rgb(&exr);
    assert_eq!((w, h), (ew, eh));
    let mut lit = 0;
    for (i, (c, e)) in c_texels.iter().zip(&exported).enumerate() {
        for k in 0..3 {
            assert!(
                (c[k] - e[k]).abs() <= 4.0 * f32::EPSILON * e[k].abs(),
                "texel {i}: C {c:?} against lrr export {e:?}"
            );
        }
        lit += usize::from(e[0] > 0.0);
    }
    assert!(lit > w * h / 4, "{lit} of {} texels lit", w * h);

    // The shared library, found at run time through the rpath.
    let libdir = dir.join("lib");
    std::fs::create_dir_all(&libdir).unwrap();
    std::fs::copy(&shared_lib, libdir.join("liblrr_capi.so")).unwrap();
    let exe = dir.join("relight-shared");
    let rpath = format!("-Wl,-rpath,{}", libdir.display());
    compile_relight(
        &exe,
        &["-L", libdir.to_str().unwrap(), "-llrr_capi", &rpath],
    );
    check(&relight(&exe, &args), 1.0, "shared library");
}

#[test]
fn header_compiles_as_c_and_cpp() {
    let header = root().join("runtime/capi/include/lrr.h");
    for lang in ["c", "c++"] {
        cc(&[
            "-fsyntax-only",
            "-Wall",
            "-Wextra",
            "-pedantic",
            "-Werror",
            "-x",
            lang,
            header.to_str().unwrap(),
        ]);
    }
}

#[test]
fn c_program_reports_errors() {
    let dir = temp_dir("capi-errors");
    let (static_lib, _) = build_libraries();
    let exe = dir.join("relight");
    compile_relight(
        &exe,
        &[static_lib.to_str().unwrap(), "-lpthread", "-ldl", "-lm"],
    );
    let garbage = dir.join("garbage.lrr");
    std::fs::write(&garbage, b"not an operator").unwrap();
    let out = Command::new(&exe)
        .args([garbage.to_str().unwrap(), "0", "0", "0", "0", "1", "0"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("garbage.lrr") && stderr.contains("not an lrr operator file"),
        "{stderr}"
    );
}

/// The C interface's default build compiles no ray tracer: lrr-capi leaves the runtime's feature
/// `trace` off (issue #34), so the static library that `relight.c` links, which holds every
/// object of the runtime it was built from, names nothing in `lrr_runtime::trace`. It does name
/// the direct pass in `lrr_runtime::lights` that `lrr_direct_*` call, which shows that the names
/// are spelled the way this test looks for them. Both of Rust's symbol manglings (legacy
/// `_ZN11lrr_runtime6lights…`, v0 `…_11lrr_runtime6lights…`) write a path as its identifiers
/// each after its length. (`cargo build -p lrr-capi --features lrr-runtime/trace` puts
/// `11lrr_runtime5trace` into the library, and this test fails on it.)
#[test]
fn c_library_compiles_no_ray_tracer() {
    let (static_lib, _) = build_libraries();
    let bytes = std::fs::read(&static_lib).unwrap();
    let names = |path: &str| bytes.windows(path.len()).any(|w| w == path.as_bytes());
    assert!(
        names("11lrr_runtime6lights"),
        "{} names nothing in lrr_runtime::lights: the symbols are not spelled as this test \
         expects, so it cannot tell whether the tracer is in",
        static_lib.display()
    );
    assert!(
        !names("11lrr_runtime5trace"),
        "{} holds code of lrr_runtime::trace: the C interface's default build must not turn on \
         the runtime's feature `trace`",
        static_lib.display()
    );
}
