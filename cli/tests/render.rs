//! `lrr render` end to end on a file made in memory (a grid of unit squares with the testkit's
//! BVH and a camera): the EXR holds `B/π` of the element under each pixel, the PNG is the
//! image's size, `--explain` says why, `--reconstruct` picks smooth or flat shading, and the
//! refusals are clear.

use std::f32::consts::PI;
use std::path::Path;

use lrr_formats::{Camera, OperatorFile};
use lrr_runtime::{Layout, Operator, Precision, testkit};

/// A 64-element grid (8 × 8 unit squares at z = 0) with a BVH and a camera looking down at it.
fn write_file(path: &Path, bvh: bool) -> OperatorFile {
    let mut file = testkit::synthetic::file(64, 8, 3, Precision::F32, Layout::Factored, 3).unwrap();
    if bvh {
        file.display.bvh = Some(testkit::bvh::build(&file.geometry));
    }
    file.display.cameras.push(Camera {
        name: "top".into(),
        eye: [4.0, 4.0, 6.0],
        target: [4.0, 4.0, 0.0],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 60.0,
    });
    file.write(path).unwrap();
    file
}

fn read_exr(path: &Path, w: usize, h: usize) -> Vec<[f32; 3]> {
    let image = exr::prelude::read_first_rgba_layer_from_file(
        path,
        move |_, _| vec![[0.0f32; 3]; w * h],
        move |px: &mut Vec<[f32; 3]>, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * w + pos.x()] = [r, g, b];
        },
    )
    .unwrap();
    image.layer_data.channel_data.pixels
}

fn run(args: &[&str]) -> anyhow::Result<String> {
    let mut out = Vec::new();
    let mut argv = vec!["lrr", "render"];
    argv.extend_from_slice(args);
    lrr_cli::run(argv, &mut out)?;
    Ok(String::from_utf8(out).unwrap())
}

#[test]
fn the_exr_holds_b_over_pi_and_the_png_is_the_image() {
    let dir = std::env::temp_dir().join(format!("lrr-render-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let lrr = dir.join("grid.lrr");
    write_file(&lrr, true);
    let op = Operator::load(&lrr).unwrap();
    let b = op.evaluate_baked();
    let exr = dir.join("grid.exr");
    let text = run(&[
        lrr.to_str().unwrap(),
        "--size",
        "41x41",
        "--exr-samples",
        "float",
        "--explain",
        "-o",
        exr.to_str().unwrap(),
    ])
    .unwrap();
    assert!(text.contains("secondary rays: off"), "{text}");
    assert!(
        text.contains("1681 primary, 0 shadow, 0 secondary"),
        "{text}"
    );
    let image = exr::prelude::read_first_rgba_layer_from_file(
        &exr,
        |size, _| vec![[0.0f32; 3]; size.width() * size.height()],
        |px: &mut Vec<[f32; 3]>, pos, (r, g, b_, _a): (f32, f32, f32, f32)| {
            px[pos.y() * 41 + pos.x()] = [r, g, b_];
        },
    )
    .unwrap();
    let pixels = &image.layer_data.channel_data.pixels;
    // The centre pixel looks straight down at (4, 4): the square at x in [4, 5), y in [4, 5),
    // file position 4 * 8 + 4 of the grid, whose original id the file's order gives.
    let file = OperatorFile::read(&lrr).unwrap();
    let id = file.order[4 * 8 + 4] as usize;
    // The ray through the centre pixel hits (4, 4) exactly, a corner: pixel (21, 19), one
    // right and one up, looks at x ≈ y ≈ 4.17, inside the square.
    let got = pixels[19 * 41 + 21];
    for c in 0..3 {
        let want = b[id][c] / PI;
        assert!(
            (got[c] - want).abs() <= 1e-6 * want.abs().max(1e-6),
            "{got:?} vs {:?}",
            b[id]
        );
    }
    let png = dir.join("grid.png");
    let text = run(&[
        lrr.to_str().unwrap(),
        "--size",
        "32x20",
        "-o",
        png.to_str().unwrap(),
    ])
    .unwrap();
    assert!(text.contains("exposure:"), "{text}");
    let decoder = png::Decoder::new(std::fs::File::open(&png).unwrap());
    let reader = decoder.read_info().unwrap();
    assert_eq!((reader.info().width, reader.info().height), (32, 20));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn refusals_are_clear() {
    let dir = std::env::temp_dir().join(format!("lrr-render-refusals-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let with = dir.join("with.lrr");
    let without = dir.join("without.lrr");
    write_file(&with, true);
    write_file(&without, false);
    let out = dir.join("x.png");
    let (with, without, out) = (
        with.to_str().unwrap(),
        without.to_str().unwrap(),
        out.to_str().unwrap(),
    );
    let err = |args: &[&str]| run(args).unwrap_err().to_string();
    let e = err(&[without, "-o", out]);
    assert!(e.contains("no BVH") && e.contains("re-bake"), "{e}");
    let e = err(&[with, "--camera", "side", "-o", out]);
    assert!(e.contains("no such camera") && e.contains("'top'"), "{e}");
    let e = err(&[with, "-o", "x.jpg"]);
    assert!(e.contains(".png") && e.contains(".exr"), "{e}");
    let e = err(&[with, "--group", "nope=2", "-o", out]);
    assert!(e.contains("no light group 'nope'"), "{e}");
    let e = err(&[with, "--up", "0,0,1", "-o", out]);
    assert!(e.contains("parallel"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--reconstruct`: smooth by default when the file has SMOOTH weights (`--explain` says so,
/// and the image is not the flat one), flat when asked; smooth on a file without the weights
/// is a clear error.
#[test]
fn reconstruct_chooses_smooth_or_flat_shading() {
    let dir = std::env::temp_dir().join(format!("lrr-render-smooth-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let plain = dir.join("plain.lrr");
    let mut file = write_file(&plain, true);
    file.display.smooth = Some(testkit::faces::smooth_by_position(&file.geometry, &|e| {
        e as u32
    }));
    let smooth = dir.join("smooth.lrr");
    file.write(&smooth).unwrap();
    let (plain, smooth) = (plain.to_str().unwrap(), smooth.to_str().unwrap());
    let mut images = Vec::new();
    for how in [None, Some("flat")] {
        let exr = dir.join("out.exr");
        let mut args = vec![
            smooth,
            "--size",
            "40x30",
            "--exr-samples",
            "float",
            "--explain",
        ];
        if let Some(how) = how {
            args.extend(["--reconstruct", how]);
        }
        args.extend(["-o", exr.to_str().unwrap()]);
        let text = run(&args).unwrap();
        let want = match how {
            None => "smooth radiosity: on",
            _ => "smooth radiosity: off (flat asked for",
        };
        assert!(text.contains(want), "{text}");
        images.push(read_exr(&exr, 40, 30));
    }
    let differ = images[0]
        .iter()
        .zip(&images[1])
        .filter(|(a, b)| (0..3).any(|c| (a[c] - b[c]).abs() > 1e-4 * b[c].abs()))
        .count();
    assert!(differ > 40 * 30 / 2, "{differ} pixels differ from flat");
    let out = dir.join("x.png");
    let out = out.to_str().unwrap();
    let text = run(&[plain, "--size", "8x6", "--explain", "-o", out]).unwrap();
    assert!(text.contains("no SMOOTH section; flat"), "{text}");
    let e = run(&[plain, "--reconstruct", "smooth", "-o", out])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("SMOOTH") && e.contains("--reconstruct flat"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--device gpu` (the wgpu evaluator's radiosity traced by the WGSL tracer without readback)
/// against the CPU: the same decision and ray counts, and every pixel within 2e-5 relative (the
/// GPU evaluator agrees with the CPU's to 1e-5; the tracers to a few ulp, see
/// runtime/tests/gpu_trace.rs).
#[test]
#[ignore = "needs a Vulkan adapter: scripts/test runs it with --ignored where lavapipe is installed"]
fn render_on_the_gpu_matches_the_cpu() {
    let dir = std::env::temp_dir().join(format!("lrr-render-gpu-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let lrr = dir.join("grid.lrr");
    write_file(&lrr, true);
    let mut images = Vec::new();
    let mut texts = Vec::new();
    for device in ["cpu", "gpu"] {
        let exr = dir.join(format!("{device}.exr"));
        let text = run(&[
            lrr.to_str().unwrap(),
            "--size",
            "64x48",
            "--exr-samples",
            "float",
            "--explain",
            "--device",
            device,
            "-o",
            exr.to_str().unwrap(),
        ])
        .unwrap();
        images.push(read_exr(&exr, 64, 48));
        texts.push(decision_lines(&text));
    }
    assert_eq!(texts[0], texts[1]);
    let mut lit = 0;
    for (c, g) in images[0].iter().zip(&images[1]) {
        for ch in 0..3 {
            assert!(
                (c[ch] - g[ch]).abs() <= 2e-5 * c[ch].abs(),
                "cpu {c:?} gpu {g:?}"
            );
        }
        lit += usize::from(c[0] > 0.0);
    }
    assert!(
        lit > 64 * 48 / 2,
        "the grid fills the view: {lit} lit pixels"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Lights that are not surfaces on `--device gpu`: the direct pass on the CPU, the GPU
/// evaluator's radiosity read back once to take their part out, the WGSL tracer shading them
/// per hit: the same decision, direct-pass line and ray counts as the CPU, every pixel within
/// 2e-5 relative (the GPU evaluator's 1e-5 and the tracers' few ulp).
#[test]
#[ignore = "needs a Vulkan adapter: scripts/test runs it with --ignored where lavapipe is installed"]
fn lights_on_the_gpu_match_the_cpu() {
    let dir = std::env::temp_dir().join(format!("lrr-render-gpu-lights-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let lrr = dir.join("grid.lrr");
    write_file(&lrr, true);
    let mut images = Vec::new();
    let mut texts = Vec::new();
    for device in ["cpu", "gpu"] {
        let exr = dir.join(format!("{device}.exr"));
        let text = run(&[
            lrr.to_str().unwrap(),
            "--size",
            "64x48",
            "--exr-samples",
            "float",
            "--explain",
            "--point-light",
            "3,5,1.5:4,3,2",
            "--spot-light",
            "6,2,3:0,0,-1:5,5,5:20,35",
            "--sun",
            "0.3,0.2,-1:0.5,0.5,0.5",
            "--device",
            device,
            "-o",
            exr.to_str().unwrap(),
        ])
        .unwrap();
        images.push(read_exr(&exr, 64, 48));
        texts.push(decision_lines(&text));
    }
    assert_eq!(texts[0], texts[1]);
    assert!(
        texts[0]
            .iter()
            .any(|l| l.starts_with("direct pass: 3 lights")),
        "{:?}",
        texts[0]
    );
    for (c, g) in images[0].iter().zip(&images[1]) {
        for ch in 0..3 {
            assert!(
                (c[ch] - g[ch]).abs() <= 2e-5 * c[ch].abs().max(1e-3),
                "cpu {c:?} gpu {g:?}"
            );
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The decision and ray-count lines of `lrr render` output (the seconds differ run to run).
fn decision_lines(text: &str) -> Vec<String> {
    text.lines()
        .filter(|l| !l.starts_with("wrote") && !l.starts_with("exposure"))
        .map(|l| l.split_once(" s: ").map_or(l, |(_, rays)| rays).to_owned())
        .collect()
}

/// A file from `lrr bake` (the Cornell box with a glass block, a mirror and a point light, its
/// SMOOTH weights as the bake makes them: negative on surface boundaries) rendered on the GPU
/// shades smooth by default, as the CPU does: `--explain` says so, the decision and ray counts
/// are the CPU's, and every pixel agrees with the CPU's within 2e-5 of its value (floor: 1e-3
/// of the image's mean), as flat images do (the GPU evaluator's B agrees with the CPU's to 1e-5;
/// the f32 reconstruction adds a few 1e-6, runtime/tests/gpu_trace.rs; measured on lavapipe:
/// 1.1e-6 smooth, 5.2e-7 flat); `--reconstruct flat` on the GPU is the CPU's flat image;
/// `lrr bench render --device gpu` checks its smooth frame and times it against flat.
#[test]
#[ignore = "needs a Vulkan adapter: scripts/test runs it with --ignored where lavapipe is installed"]
fn a_baked_file_renders_smooth_on_the_gpu_as_on_the_cpu() {
    let dir = std::env::temp_dir().join(format!("lrr-render-gpu-smooth-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (toml, lrr) = (dir.join("cg.toml"), dir.join("cg.lrr"));
    let (toml, lrr) = (toml.to_str().unwrap(), lrr.to_str().unwrap());
    let mut sink = Vec::new();
    lrr_cli::run(["lrr", "scene", "cornell-glass", "-o", toml], &mut sink).unwrap();
    let bake = [
        "lrr",
        "bake",
        toml,
        "-o",
        lrr,
        "-q",
        "--element-size",
        "120",
        "--samples",
        "4",
    ];
    lrr_cli::run(bake, &mut sink).unwrap();
    let file = OperatorFile::read(Path::new(lrr)).unwrap();
    let smooth = file
        .display
        .smooth
        .as_ref()
        .expect("lrr bake writes SMOOTH");
    assert!(
        smooth.weights.iter().any(|&w| w < 0.0),
        "boundary vertices extrapolate"
    );
    let (w, h) = (96, 72);
    let render = |device: &str, how: &str| {
        let exr = dir.join(format!("{device}-{how}.exr"));
        let text = run(&[
            lrr,
            "--size",
            "96x72",
            "--exr-samples",
            "float",
            "--explain",
            "--device",
            device,
            "--reconstruct",
            how,
            "-o",
            exr.to_str().unwrap(),
        ])
        .unwrap();
        (decision_lines(&text), read_exr(&exr, w, h))
    };
    let (cpu_text, cpu) = render("cpu", "smooth");
    let (gpu_text, gpu) = render("gpu", "smooth");
    assert_eq!(cpu_text, gpu_text);
    assert!(
        gpu_text
            .iter()
            .any(|l| l.starts_with("smooth radiosity: on")),
        "{gpu_text:?}"
    );
    let mean = cpu.iter().flatten().map(|&c| f64::from(c)).sum::<f64>() / (3 * w * h) as f64;
    let worst = |a: &[[f32; 3]], b: &[[f32; 3]]| {
        a.iter()
            .zip(b)
            .flat_map(|(p, q)| (0..3).map(move |c| (p[c], q[c])))
            .map(|(g, c)| f64::from((g - c).abs()) / f64::from(c.abs()).max(1e-3 * mean))
            .fold(0.0, f64::max)
    };
    let smooth_worst = worst(&gpu, &cpu);
    let (_, cpu_flat) = render("cpu", "flat");
    let (_, gpu_flat) = render("gpu", "flat");
    let flat_worst = worst(&gpu_flat, &cpu_flat);
    let changed = gpu
        .iter()
        .zip(&gpu_flat)
        .filter(|(s, f)| (0..3).any(|c| (s[c] - f[c]).abs() > 1e-3 * f[c].abs()))
        .count();
    eprintln!(
        "baked cornell-glass, GPU against CPU: smooth worst {smooth_worst:.2e}, flat worst \
         {flat_worst:.2e} (relative, floor 1e-3 of the mean); {changed} of {} pixels smooth != flat",
        w * h
    );
    assert!(smooth_worst <= 2e-5 && flat_worst <= 2e-5);
    assert!(changed > w * h / 4, "{changed}");
    // `lrr bench render --device gpu` on it: the smooth frame against the CPU twin's, and
    // against its flat twin's time.
    let mut out = Vec::new();
    let bench = ["lrr", "bench", "render", "--device", "gpu", "--file", lrr];
    let args = bench.into_iter().chain(["--size", "64x48", "--runs", "1"]);
    lrr_cli::run(args, &mut out).unwrap();
    let text = String::from_utf8(out).unwrap();
    assert!(
        text.contains("against the CPU twin: 0 of 3072 pixels differ"),
        "{text}"
    );
    for frame in ["primary only", "decided"] {
        assert!(
            text.contains(&format!("smooth shading ({frame}:")),
            "{text}"
        );
    }
    assert!(text.contains("decided, flat"), "{text}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `lrr bench render` of the dense scene at `size`, one round on one thread, with `extra` flags.
fn bench_render(size: &str, extra: &[&str]) -> String {
    let mut out = Vec::new();
    let mut argv = vec![
        "lrr",
        "bench",
        "render",
        "--size",
        size,
        "--runs",
        "1",
        "--threads",
        "1",
    ];
    argv.extend_from_slice(extra);
    lrr_cli::run(argv, &mut out).unwrap();
    String::from_utf8(out).unwrap()
}

/// `lrr bench render` on the CPU traces the tree a bake stores by default: its SAH cost is the
/// lower by far (docs/PERFORMANCE.md: 26.4 against the testkit builder's 69.3 on the dense
/// scene), every ray kind is timed, and without Embree in the build it says how to add it.
#[test]
fn bench_render_traces_the_bakes_tree_by_default() {
    let bench = |tree: &str| bench_render("48x27", &["--tree", tree]);
    let sah = |text: &str| -> f64 {
        let at = text.find("SAH cost ").expect(text) + "SAH cost ".len();
        text[at..]
            .split_whitespace()
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    let (bake, testkit) = (bench("bake"), bench("testkit"));
    assert!(bake.contains("the bake's BVH (327760 triangles)"), "{bake}");
    assert!(testkit.contains("testkit SAH BVH"), "{testkit}");
    let (a, b) = (sah(&bake), sah(&testkit));
    assert!(a > 20.0 && a < 0.5 * b, "SAH cost: bake {a}, testkit {b}");
    for kind in ["primary", "shadow", "secondary"] {
        let row = bake
            .lines()
            .find(|l| l.starts_with(kind))
            .unwrap_or_else(|| panic!("no {kind} row: {bake}"));
        let rate: f64 = row.split_whitespace().nth(2).unwrap().parse().unwrap();
        assert!(rate > 0.0, "{row}");
    }
    if !cfg!(feature = "embree") {
        assert!(bake.contains("embree: not in this build"), "{bake}");
    }
    // Another view of the same scene: the flags move the camera (the frames' rays differ).
    let moved = bench_render(
        "48x27",
        &[
            "--eye",
            "0.5,0.9,0.5",
            "--target",
            "0.5,0.0,0.5",
            "--up",
            "0,0,1",
        ],
    );
    let primary = moved.lines().find(|l| l.starts_with("primary")).unwrap();
    assert_eq!(primary.split_whitespace().nth(1), Some("1296"), "{moved}");
    let shadow = |t: &str| {
        t.lines()
            .find(|l| l.starts_with("shadow"))
            .map(str::to_owned)
    };
    assert_ne!(shadow(&moved), shadow(&bake), "the view did not move");
    let mut out = Vec::new();
    let err = lrr_cli::run(["lrr", "bench", "render", "--camera", "x"], &mut out).unwrap_err();
    assert!(err.to_string().contains("no named cameras"), "{err}");
}

/// With Embree in the build (`--features embree`; scripts/test runs the tests named after it):
/// Embree times the same rays, its rate and the ratio are numbers, and the two disagree on at
/// most 1e-4 of the rays (docs/PERFORMANCE.md: 1 / 0 / 0 of 2 073 600 on this scene), each
/// time with the f64 brute force on the tracer's side.
#[cfg(feature = "embree")]
#[test]
fn bench_render_times_embree_on_the_same_rays() {
    let text = bench_render("192x108", &[]);
    assert!(text.contains("embree: build quality High"), "{text}");
    for kind in ["primary", "shadow", "secondary"] {
        let row: Vec<&str> = text
            .lines()
            .find(|l| l.starts_with(kind))
            .unwrap_or_else(|| panic!("no {kind} row: {text}"))
            .split_whitespace()
            .collect();
        let rays: f64 = row[1].parse().unwrap();
        let embree: f64 = row[3].parse().expect(&text);
        let ratio: f64 = row[4].parse().expect(&text);
        // ... ratio (range) disagree "T tr / E em": the f64 brute force's verdicts.
        let disagree: f64 = row[6].parse().expect(&text);
        let with_tracer: f64 = row[7].parse().expect(&text);
        assert!(embree > 0.0 && ratio > 0.0, "{text}");
        assert!(
            disagree <= 1e-4 * rays,
            "{kind}: {disagree} of {rays}: {text}"
        );
        // Where they differ, the tracer's watertight test is the one f64 agrees with
        // (docs/PERFORMANCE.md round 5: every disagreement on three scenes).
        assert_eq!(with_tracer, disagree, "{text}");
    }
}
