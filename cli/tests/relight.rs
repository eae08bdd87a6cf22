//! `lrr relight --images`: a rendered frame of the sequence is `lrr render` of the same
//! lighting pixel for pixel, PNG sequences keep one exposure, lightmaps and images together,
//! and the refusals name what to fix.

use std::path::{Path, PathBuf};

use lrr_runtime::{Layout, Operator, Precision, testkit};

/// A folder of its own for each test.
fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lrr-relight-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn lrr(args: &[&str]) -> anyhow::Result<String> {
    let mut out = Vec::new();
    let mut all = vec!["lrr"];
    all.extend_from_slice(args);
    lrr_cli::run(all, &mut out)?;
    Ok(String::from_utf8(out).unwrap())
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A closed 2 m room with a red block, two ceiling lamps (groups `warm` and `cool`) and a
/// camera `corner`, baked.
fn room(d: &Path) -> PathBuf {
    let lamp = |name: &str, x0: f64, radiance: [f64; 3]| {
        let x1 = x0 + 0.4;
        format!(
            "[[material]]\nname = \"{name}\"\nreflectance = [0.5, 0.5, 0.5]\nradiance = {radiance:?}\n\
             [[surface]]\nname = \"{name}\"\nmaterial = \"{name}\"\n\
             polygons = [[[{x0}, 1.99, 0.6], [{x1}, 1.99, 0.6], [{x1}, 1.99, 1.0], [{x0}, 1.99, 1.0]]]\n"
        )
    };
    let toml = format!(
        "name = \"room\"\n\
         [[material]]\nname = \"wall\"\nreflectance = [0.6, 0.6, 0.6]\n\
         [[material]]\nname = \"red\"\nreflectance = [0.7, 0.2, 0.2]\n\
         [[box]]\nname = \"room\"\nmaterial = \"wall\"\nmin = [0, 0, 0]\nmax = [2, 2, 2]\ninward = true\n\
         [[box]]\nname = \"block\"\nmaterial = \"red\"\nmin = [0.3, 0, 0.3]\nmax = [0.9, 0.8, 0.9]\n\
         {}{}\
         [[camera]]\nname = \"corner\"\neye = [1.8, 1.4, 1.8]\ntarget = [0.5, 0.5, 0.5]\nfov_y_deg = 70\n",
        lamp("warm", 0.4, [4.0, 3.0, 2.0]),
        lamp("cool", 1.2, [1.0, 2.0, 4.0]),
    );
    let scene = d.join("room.toml");
    std::fs::write(&scene, toml).unwrap();
    let file = d.join("room.lrr");
    lrr(&[
        "bake",
        s(&scene),
        "-o",
        s(&file),
        "-q",
        "--element-size",
        "0.25",
        "--samples",
        "4",
    ])
    .unwrap();
    file
}

/// Linear RGB pixels of an EXR image.
fn read_exr(path: &Path) -> (usize, Vec<[f32; 3]>) {
    let image = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |size, _| {
            (
                size.width(),
                vec![[0.0f32; 3]; size.width() * size.height()],
            )
        },
        |(w, px): &mut (usize, Vec<[f32; 3]>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = [r, g, b];
        },
    )
    .unwrap();
    image.layer_data.channel_data.pixels
}

/// The 8-bit RGB samples of a PNG.
fn read_png(path: &Path) -> Vec<u8> {
    let decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    buf
}

#[test]
fn a_rendered_frame_is_lrr_render_of_the_same_lighting_pixel_for_pixel() {
    let d = dir("equal");
    let file = room(&d);
    let anim = d.join("anim.toml");
    // Frame 1 (t = 0.5 s): warm at 0.75, cool at 0.5, both white; frame 2: cool coloured.
    std::fs::write(
        &anim,
        "fps = 2.0\n[[group]]\nname = \"warm\"\nkeys = [{ time = 0.0, intensity = 1.0 }, { time = 1.0, intensity = 0.5 }]\n\
         [[group]]\nname = \"cool\"\nkeys = [{ time = 0.0, intensity = 0.0 }, { time = 1.0, intensity = 1.0 }, \
         { time = 2.0, intensity = 2.0, colour = [1.0, 0.5, 0.0] }]\n",
    )
    .unwrap();
    let frames = d.join("frames");
    // Two threads, where `lrr render` evaluates on one (`Operator::evaluate`): a frame is the
    // same bits at any thread count (`runtime/tests/evaluator.rs`). Until 2026-12-01 frame 1
    // of the test below differed here by 1 ulp in one pixel at 2 threads: the segment sums
    // summed a patch in pieces where a chunk of rows began. The frames are compared with the
    // render bit for bit.
    let text = lrr(&[
        "relight",
        s(&file),
        "--animation",
        s(&anim),
        "-o",
        s(&frames),
        "-q",
        "--images",
        "exr",
        "--image-size",
        "48x32",
        "--samples",
        "float",
        "--threads",
        "2",
    ])
    .unwrap();
    assert!(text.contains("camera 'corner'"), "{text}");
    assert!(text.contains("wrote 5 frames (48x32 EXR images)"), "{text}");
    assert!(
        text.contains("tracing") && text.contains("writing"),
        "{text}"
    );
    assert!(
        !frames.join("lightmap-00000.exr").exists(),
        "lightmaps only with --lightmaps"
    );
    let render = |extra: &[&str], out: &Path| {
        let args = [
            &[
                "render",
                s(&file),
                "--size",
                "48x32",
                "--exr-samples",
                "float",
                "-o",
                s(out),
            ],
            extra,
        ]
        .concat();
        lrr(&args).unwrap();
        read_exr(out).1
    };
    let want = render(
        &["--group", "warm=0.75", "--group", "cool=0.5"],
        &d.join("t05.exr"),
    );
    let (w, got) = read_exr(&frames.join("frame-00001.exr"));
    assert_eq!((w, got.len()), (48, 48 * 32));
    assert!(want.iter().any(|p| p[0] > 0.0));
    assert_eq!(
        got, want,
        "frame 1 against lrr render --group warm=0.75 --group cool=0.5"
    );
    // A coloured frame (t = 1.5 s: cool (1.5, 1, 0.5) halfway from white 1 to (2, 1, 0), warm 0.5) against `lrr render
    // --emission` of the same per-element emission.
    let op = Operator::load(&file).unwrap();
    let mut e = vec![[0.0f32; 3]; op.n()];
    for (g, scale) in [
        (op.light_group("warm").unwrap(), [0.5f32; 3]),
        (op.light_group("cool").unwrap(), [1.5, 1.0, 0.5]),
    ] {
        let lights = &op.file().lights[g];
        for (i, &p) in lights.positions.iter().enumerate() {
            let id = op.file().order[p as usize] as usize;
            for c in 0..3 {
                e[id][c] += scale[c] * lights.emission[3 * i + c];
            }
        }
    }
    let emission = d.join("e.json");
    std::fs::write(&emission, serde_json::to_string(&e).unwrap()).unwrap();
    let want = render(&["--emission", s(&emission)], &d.join("t15.exr"));
    assert_eq!(
        read_exr(&frames.join("frame-00003.exr")).1,
        want,
        "frame 3 against lrr render --emission"
    );
    std::fs::remove_dir_all(&d).unwrap();
}

/// A light of the animation's own, moving: a frame is `lrr render` of the same groups with a
/// `--point-light` where the track puts it, pixel for pixel, and the light moves the image.
#[test]
fn a_moving_point_light_is_lrr_render_with_that_light_pixel_for_pixel() {
    let d = dir("torch");
    let file = room(&d);
    let anim = d.join("anim.toml");
    std::fs::write(
        &anim,
        "fps = 2.0\n[[group]]\nname = \"cool\"\nkeys = [{ time = 0.0, intensity = 0.0 }]\n\
         [[light]]\nname = \"torch\"\nkind = \"point\"\nkeys = [\n\
         { time = 0.0, position = [0.5, 1.5, 1.5], intensity = [2.0, 2.0, 2.0] },\n\
         { time = 1.0, position = [1.5, 1.5, 1.5], intensity = [2.0, 2.0, 2.0] }]\n",
    )
    .unwrap();
    let frames = d.join("frames");
    // Two threads, against a render's one (see the test above).
    lrr(&[
        "relight",
        s(&file),
        "--animation",
        s(&anim),
        "-o",
        s(&frames),
        "-q",
        "--images",
        "exr",
        "--image-size",
        "48x32",
        "--samples",
        "float",
        "--threads",
        "2",
    ])
    .unwrap();
    let out = d.join("t05.exr");
    lrr(&[
        "render",
        s(&file),
        "--size",
        "48x32",
        "--exr-samples",
        "float",
        "--group",
        "cool=0",
        "--point-light",
        "1,1.5,1.5:2,2,2",
        "-o",
        s(&out),
    ])
    .unwrap();
    let want = read_exr(&out).1;
    assert_eq!(
        read_exr(&frames.join("frame-00001.exr")).1,
        want,
        "frame 1 (t = 0.5 s) against lrr render --point-light 1,1.5,1.5:2,2,2"
    );
    assert_ne!(
        read_exr(&frames.join("frame-00000.exr")).1,
        read_exr(&frames.join("frame-00002.exr")).1,
        "the torch moved"
    );
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn a_png_sequence_keeps_the_first_lit_frames_exposure() {
    let d = dir("png");
    let file = room(&d);
    let anim = d.join("anim.toml");
    // Frame 0 dark, frame 1 full, frame 2 at half intensity (only the warm lamp lights).
    std::fs::write(
        &anim,
        "fps = 1.0\n[[group]]\nname = \"warm\"\nkeys = [{ time = 0.0, intensity = 0.0 }, { time = 0.5, intensity = 0.0 }, \
         { time = 1.0, intensity = 1.0 }, { time = 2.0, intensity = 0.5 }]\n\
         [[group]]\nname = \"cool\"\nkeys = [{ time = 0.0, intensity = 0.0 }]\n",
    )
    .unwrap();
    let frames = d.join("frames");
    let text = lrr(&[
        "relight",
        s(&file),
        "--animation",
        s(&anim),
        "-o",
        s(&frames),
        "-q",
        "--images",
        "png",
        "--image-size",
        "40x30",
        "--lightmaps",
        "--size",
        "64",
    ])
    .unwrap();
    assert_eq!(text.matches("exposure:").count(), 1, "{text}");
    assert!(
        text.contains("64x64 lightmaps and 40x30 PNG images"),
        "{text}"
    );
    assert!(frames.join("lightmap-00002.exr").exists());
    // The printed exposure is what `lrr render` chooses for the first lit frame.
    let one = d.join("one.png");
    let rendered = lrr(&[
        "render",
        s(&file),
        "--size",
        "40x30",
        "--group",
        "cool=0",
        "-o",
        s(&one),
    ])
    .unwrap();
    let ev = |t: &str| {
        t.lines()
            .find(|l| l.starts_with("exposure:"))
            .unwrap()
            .split(" (")
            .next()
            .unwrap()
            .to_string()
    };
    assert_eq!(ev(&text), ev(&rendered), "{text}\n{rendered}");
    assert_eq!(read_png(&frames.join("frame-00001.png")), read_png(&one));
    assert!(
        read_png(&frames.join("frame-00000.png"))
            .iter()
            .all(|&v| v == 0)
    );
    // Half the light, half the linear value: darker, not re-normalised.
    let (full, half) = (
        read_png(&frames.join("frame-00001.png")),
        read_png(&frames.join("frame-00002.png")),
    );
    let linear = |v: u8| {
        let s = v as f64 / 255.0;
        if s <= 0.04045 {
            s / 12.92
        } else {
            ((s + 0.055) / 1.055).powf(2.4)
        }
    };
    let mut compared = 0;
    for (&a, &b) in full.iter().zip(&half) {
        if (20..250).contains(&a) {
            // 8-bit rounding: half a step of each sample, in linear terms.
            let step = |v: u8| (linear(v.saturating_add(1)) - linear(v.saturating_sub(1))) / 2.0;
            assert!(
                (linear(b) - 0.5 * linear(a)).abs() <= step(a) / 2.0 + step(b),
                "{a} {b}"
            );
            compared += 1;
        }
    }
    assert!(compared > 1000, "{compared}");
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn refusals_name_what_to_fix() {
    let d = dir("refusals");
    let anim = d.join("anim.toml");
    std::fs::write(&anim, "fps = 1.0\n").unwrap();
    // A file without a BVH (the testkit's synthetic operator).
    let bare = d.join("bare.lrr");
    testkit::synthetic::file(64, 8, 3, Precision::F32, Layout::Factored, 3)
        .unwrap()
        .write(&bare)
        .unwrap();
    let out = d.join("out");
    let err = |args: &[&str]| {
        let args = [
            &["relight", s(&bare), "--animation", s(&anim), "-o", s(&out)],
            args,
        ]
        .concat();
        format!("{:#}", lrr(&args).unwrap_err())
    };
    let e = err(&["--images", "png"]);
    assert!(e.contains("no BVH") && e.contains("re-bake"), "{e}");
    let e = err(&["--camera", "front"]);
    assert!(e.contains("--images png"), "{e}");
    let e = err(&["--exposure", "1"]);
    assert!(e.contains("--images png"), "{e}");
    let e = err(&["--lightmaps"]);
    assert!(e.contains("--images"), "{e}");
    let e = err(&["--images", "jpg"]);
    assert!(e.contains("png") && e.contains("exr"), "{e}");
    assert!(!out.exists(), "nothing written before the refusals");
    let file = room(&d);
    let args = [
        "relight",
        s(&file),
        "--animation",
        s(&anim),
        "-o",
        s(&out),
        "--images",
        "png",
        "--camera",
        "side",
    ];
    let e = format!("{:#}", lrr(&args).unwrap_err());
    assert!(
        e.contains("no such camera") && e.contains("'corner'"),
        "{e}"
    );
    std::fs::remove_dir_all(&d).unwrap();
}
