//! `lrr export`: lightmaps texel by texel against the runtime, no black texel in a chart,
//! glTF vertex colours against the runtime, group layers summing to the whole; and (ignored
//! unless scripts/setup-exports.sh has run, as scripts/test does) the files checked by readers
//! this project did not write (scripts/check-exports.py: OpenEXR, the Khronos glTF validator).

// Indexed loops over texels and RGB channels read like the checks they make.
#![allow(clippy::needless_range_loop)]

use std::path::{Path, PathBuf};

use exr::prelude::*;
use glam::{DVec2, DVec3};
use lrr_precompute::display::atlas::{self, Layout, Sizing};
use lrr_precompute::display::charts::{self, Chart};
use lrr_runtime::{Lightmap, LightmapValues, Operator, Reconstruction};

/// The runtime's lightmap of `b` over `charts` packed as `layout` (what `lrr export` fills
/// when its flags pack charts again) and the texels it fills.
fn filled(
    op: &Operator,
    b: &[[f32; 3]],
    charts: &[Chart],
    layout: &Layout,
    values: LightmapValues,
) -> (Lightmap, Vec<[f32; 3]>) {
    let g = op.file().faces().geometry;
    let uv = lrr_precompute::display::chart_uvs(g, charts, layout);
    let (w, h) = (layout.width, layout.height);
    let mut map =
        Lightmap::with_coordinates(op.file(), &uv, w, h, layout.padding, Some(values)).unwrap();
    let mut texels = vec![[0.0f32; 3]; w * h];
    map.fill(b, &mut texels).unwrap();
    (map, texels)
}

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lrr-exports-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn lrr(args: &[&str]) -> String {
    let mut out = Vec::new();
    let mut all = vec!["lrr"];
    all.extend_from_slice(args);
    if let Err(e) = lrr_cli::run(all, &mut out) {
        panic!("lrr {}: {e:#}", args.join(" "));
    }
    String::from_utf8(out).unwrap()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A 1×1 floor (ρ = 0.5) under lamps 1 above it (emitted radiance per lamp given).
fn lit_quad(d: &Path, lamps: &[(&str, [f64; 3], f64)]) -> PathBuf {
    let mut toml = String::from(
        "name = \"lit-quad\"\n\n[[material]]\nname = \"floor\"\nreflectance = [0.5, 0.5, 0.5]\n\n\
         [[surface]]\nname = \"floor\"\nmaterial = \"floor\"\n\
         polygons = [[[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 0.0, 0.0]]]\n",
    );
    for (name, radiance, x) in lamps {
        toml += &format!(
            "\n[[material]]\nname = \"{name}\"\nreflectance = [0.5, 0.5, 0.5]\nradiance = {radiance:?}\n\n\
             [[surface]]\nname = \"{name}\"\nmaterial = \"{name}\"\n\
             polygons = [[[{x0}, 1.0, 0.25], [{x1}, 1.0, 0.25], [{x1}, 1.0, 0.75], [{x0}, 1.0, 0.75]]]\n",
            x0 = x,
            x1 = x + 0.3,
        );
    }
    let scene = d.join("lit-quad.toml");
    std::fs::write(&scene, toml).unwrap();
    let file = d.join("lit-quad.lrr");
    lrr(&[
        "bake",
        s(&scene),
        "-o",
        s(&file),
        "-q",
        "--element-size",
        "0.1",
    ]);
    file
}

fn cornell(d: &Path) -> PathBuf {
    let scene =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box/cornell-box.toml");
    let file = d.join("cornell.lrr");
    lrr(&["bake", s(&scene), "-o", s(&file), "-q"]);
    file
}

/// The layers of an EXR file: name → (width, height, RGB pixels), read through the exr crate.
fn read_exr(path: &Path) -> Vec<(String, usize, usize, Vec<[f32; 3]>)> {
    let image = read_all_flat_layers_from_file(path).unwrap();
    let layer = &image.layer_data[0];
    let (w, h) = (layer.size.0, layer.size.1);
    let mut names: Vec<String> = layer
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .filter_map(|n| n.strip_suffix('R').map(str::to_string))
        .collect();
    names.sort();
    names
        .into_iter()
        .map(|prefix| {
            let channel = |c: &str| {
                let name = format!("{prefix}{c}");
                let ch = layer
                    .channel_data
                    .list
                    .iter()
                    .find(|x| x.name.to_string() == name)
                    .unwrap();
                ch.sample_data.values_as_f32().collect::<Vec<f32>>()
            };
            let (r, g, b) = (channel("R"), channel("G"), channel("B"));
            let pixels = (0..w * h).map(|i| [r[i], g[i], b[i]]).collect();
            (prefix.trim_end_matches('.').to_string(), w, h, pixels)
        })
        .collect()
}

/// The runtime's smooth reconstruction of one frame (the files baked here carry SMOOTH): B/π
/// at a point of the display face `locate_face` finds, or of a given face.
struct Runtime<'f> {
    op: &'f Operator,
    smooth: Reconstruction<'f>,
    vertices: Vec<[f32; 3]>,
}

impl<'f> Runtime<'f> {
    fn new(op: &'f Operator, b: &[[f32; 3]]) -> Self {
        let smooth = Reconstruction::new(op.file()).unwrap();
        let mut vertices = vec![[0.0f32; 3]; smooth.vertex_count()];
        smooth.vertex_values(b, &mut vertices).unwrap();
        Self {
            op,
            smooth,
            vertices,
        }
    }

    /// B/π at `point` of display face `s`.
    fn at(&self, s: usize, point: DVec3) -> [f32; 3] {
        let p = [point.x as f32, point.y as f32, point.z as f32];
        self.smooth
            .at(&self.vertices, s, p)
            .map(|v| v / std::f32::consts::PI)
    }

    /// B/π at `point`, on the display face the runtime locates there.
    fn locate(&self, point: DVec3, normal: DVec3) -> [f32; 3] {
        let p = [point.x as f32, point.y as f32, point.z as f32];
        let n = [normal.x as f32, normal.y as f32, normal.z as f32];
        self.at(self.op.locate_face(p, n).unwrap(), point)
    }
}

#[test]
fn the_lightmap_of_a_lit_quad_matches_the_runtime_texel_by_texel() {
    let d = dir("quad");
    let file = lit_quad(&d, &[("lamp", [4.0, 2.0, 1.0], 0.35)]);
    let exr_path = d.join("quad.exr");
    lrr(&[
        "export",
        s(&file),
        "-o",
        s(&exr_path),
        "--texel-density",
        "40",
        "--samples",
        "float",
    ]);
    let layers = read_exr(&exr_path);
    assert_eq!(layers.len(), 1);
    let (name, w, h, pixels) = &layers[0];
    assert_eq!(name, "");

    let op = Operator::load(&file).unwrap();
    let b = op.evaluate_baked();
    let runtime = Runtime::new(&op, &b);
    let charts = charts::charts(op.file().faces().geometry);
    assert_eq!(charts.len(), 2, "the floor and the lamp");
    let layout = atlas::pack(&charts, Sizing::Density(40.0), 2).unwrap();
    assert_eq!((layout.width, layout.height), (*w, *h));
    let floor = charts.iter().position(|c| c.u.cross(c.v).y > 0.5).unwrap();
    let r = layout.rects[floor];
    let (mut inside, mut border) = (0, 0);
    for y in r[1]..r[3] {
        for x in r[0]..r[2] {
            let t = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
            let q = layout.chart_point(floor, t);
            let got = pixels[y * w + x];
            let size = charts[floor].size;
            if q.x > 0.0 && q.y > 0.0 && q.x < size.x && q.y < size.y {
                let want = runtime.locate(charts[floor].lift(q), DVec3::Y);
                for c in 0..3 {
                    assert!(
                        (got[c] - want[c]).abs() <= 1e-6 * want[c],
                        "texel ({x}, {y}) channel {c}: {} against the runtime's {}",
                        got[c],
                        want[c]
                    );
                }
                inside += 1;
            } else {
                assert!(
                    got.iter().all(|&v| v > 0.0),
                    "border texel ({x}, {y}) is black"
                );
                border += 1;
            }
        }
    }
    // 1 unit at 40 texels per unit, 2 texels of padding each side.
    assert_eq!(inside, 40 * 40);
    assert_eq!(border, 44 * 44 - 40 * 40);
    // The radiosity varies over the floor: a flat export would not pass by accident.
    let values: Vec<f32> = pixels[r[1] * w..r[3] * w]
        .iter()
        .map(|p| p[0])
        .filter(|&v| v > 0.0)
        .collect();
    let (lo, hi) = values
        .iter()
        .fold((f32::MAX, 0.0f32), |(a, b), &v| (a.min(v), b.max(v)));
    assert!(hi > 1.5 * lo, "{lo} .. {hi}");
    // --reconstruct flat: each inside texel is its element's value.
    let flat_path = d.join("flat.exr");
    lrr(&[
        "export",
        s(&file),
        "-o",
        s(&flat_path),
        "--texel-density",
        "40",
        "--samples",
        "float",
        "--reconstruct",
        "flat",
    ]);
    let flat = &read_exr(&flat_path)[0].3;
    // Each sample is its face's element's value; the sample's point is the texel centre's
    // point of the floor, and (away from element edges, where a centre is a tie) that
    // element is the one the runtime locates there.
    let (map, texels) = filled(&op, &b, &charts, &layout, LightmapValues::Flat);
    assert_eq!(&texels, flat);
    let file = op.file();
    let mut flat_differs = 0;
    let mut located = 0;
    for sample in map.samples() {
        let (x, y) = (sample.texel % w, sample.texel / w);
        if !(x >= r[0] && x < r[2] && y >= r[1] && y < r[3]) {
            continue;
        }
        let e = file.order[file.faces().element(sample.face)] as usize;
        let want = b[e].map(|v| v / std::f32::consts::PI);
        assert_eq!(flat[sample.texel], want, "flat texel ({x}, {y})");
        let q = layout.chart_point(floor, DVec2::new(x as f64 + 0.5, y as f64 + 0.5));
        let p = charts[floor].lift(q);
        let point = DVec3::from_array(sample.point.map(f64::from));
        assert!(
            point.distance(p) < 1e-5,
            "texel ({x}, {y}): {point} against {p}"
        );
        let p32 = [p.x as f32, p.y as f32, p.z as f32];
        let at = |q: [f32; 3]| op.locate(q, [0.0, 1.0, 0.0]).unwrap() as usize;
        let here = at(p32);
        let d = 1e-4;
        let on_edge = [[d, 0.0], [-d, 0.0], [0.0, d], [0.0, -d]]
            .iter()
            .any(|[dx, dz]| at([p32[0] + dx, p32[1], p32[2] + dz]) != here);
        if !on_edge {
            assert_eq!(here, e, "texel ({x}, {y})");
            located += 1;
        }
        flat_differs += usize::from(flat[sample.texel] != pixels[sample.texel]);
    }
    assert!(located > 1000, "{located}");
    assert!(
        flat_differs > 1000,
        "smooth and flat differ: {flat_differs}"
    );
    // Outside every chart's rectangle the atlas is black.
    let in_rect = |x: usize, y: usize| {
        layout
            .rects
            .iter()
            .any(|r| x >= r[0] && x < r[2] && y >= r[1] && y < r[3])
    };
    for y in 0..*h {
        for x in 0..*w {
            if !in_rect(x, y) {
                assert_eq!(pixels[y * w + x], [0.0; 3]);
            }
        }
    }
}

#[test]
fn no_texel_the_cornell_box_shows_is_black_and_samples_match_the_runtime() {
    let d = dir("cornell");
    let file = cornell(&d);
    let op = Operator::load(&file).unwrap();
    let b = op.evaluate_baked();
    let charts = charts::charts(op.file().faces().geometry);
    let layout = atlas::pack(&charts, Sizing::Size(256), 2).unwrap();
    let (map, texels) = filled(&op, &b, &charts, &layout, LightmapValues::Smooth);
    let runtime = Runtime::new(&op, &b);
    let g = op.file().faces().geometry;
    let mut checked = 0;
    let mut shown = vec![false; texels.len()];
    for s in map.samples() {
        shown[s.texel] = true;
        let v = texels[s.texel];
        assert!(v.iter().sum::<f32>() > 0.0, "sample {s:?} is black");
        if s.texel % 3 == 0 {
            let p = DVec3::from_array(s.point.map(f64::from));
            let n = DVec3::from_array([0, 1, 2].map(|c| f64::from(g.normals[3 * s.face + c])));
            let want = runtime.locate(p, n);
            for k in 0..3 {
                assert!(
                    (v[k] - want[k]).abs() <= 1e-6 * want[k].max(1e-6),
                    "sample {s:?}: {v:?} against {want:?}"
                );
            }
            checked += 1;
        }
    }
    // Every texel within the padding (2 rings) of a sample is filled.
    let w = layout.width;
    for (i, _) in shown.iter().enumerate().filter(|(_, s)| **s) {
        let (x, y) = ((i % w) as i64, (i / w) as i64);
        for dy in -2..=2 {
            for dx in -2..=2 {
                let (nx, ny) = (x + dx, y + dy);
                if nx >= 0 && ny >= 0 && nx < w as i64 && ny < layout.height as i64 {
                    let t = texels[ny as usize * w + nx as usize];
                    assert!(
                        t.iter().sum::<f32>() > 0.0,
                        "({nx}, {ny}) near a sample is black"
                    );
                }
            }
        }
    }
    let atlas_pixels = texels;
    assert!(checked > 5000, "{checked}");
    // Through the command, the same atlas as half floats.
    let exr_path = d.join("cornell.exr");
    lrr(&["export", s(&file), "-o", s(&exr_path), "--size", "256"]);
    let layers = read_exr(&exr_path);
    let (_, w, h, pixels) = &layers[0];
    assert_eq!((*w, *h), (256, 256));
    for (got, want) in pixels.iter().zip(&atlas_pixels) {
        for k in 0..3 {
            assert!(
                (got[k] - want[k]).abs() <= want[k] * 2f32.powi(-11) + 6e-8,
                "{got:?} {want:?}"
            );
        }
    }
}

#[test]
fn glb_vertex_colours_equal_the_runtimes_values() {
    let d = dir("glb");
    let file = cornell(&d);
    let glb = d.join("cornell.glb");
    lrr(&["export", s(&file), "-o", s(&glb), "--group", "light=0.5"]);
    let op = Operator::load(&file).unwrap();
    let mut b = vec![[0.0f32; 3]; op.n()];
    op.evaluate_groups(&[0.5], lrr_runtime::RgbMut::triples(&mut b))
        .unwrap();

    let bytes = std::fs::read(&glb).unwrap();
    let gltf = gltf::Gltf::from_slice(&bytes).unwrap();
    let blob = gltf.blob.clone().unwrap();
    let exposure = gltf.document.as_json().asset.extras.as_ref().map(|e| {
        let v: serde_json::Value = serde_json::from_str(e.get()).unwrap();
        v["lrr"]["exposure"].as_f64().unwrap() as f32
    });
    let exposure = exposure.unwrap();
    let mesh = gltf.meshes().next().unwrap();
    let prim = mesh.primitives().next().unwrap();
    let reader = prim.reader(|_| Some(&blob));
    let positions: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
    let colours: Vec<[f32; 3]> = reader.read_colors(0).unwrap().into_rgb_f32().collect();
    let indices: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
    assert_eq!(indices.len() / 3, op.file().faces().triangle_count());
    // Triangles come in the order of the display triangles: each names its face, and the
    // runtime's value on that face at the vertex is the vertex's (every use of a shared
    // vertex is checked, so sharing across faces with other values would fail).
    let runtime = Runtime::new(&op, &b);
    let mut seen = vec![false; positions.len()];
    let mut clamped = 0;
    for (tri, (s, _)) in indices.chunks(3).zip(op.file().faces().triangles()) {
        for &v in tri {
            let at = DVec3::from_array(positions[v as usize].map(f64::from));
            let want = runtime
                .at(s as usize, at)
                .map(|x| (x * exposure).clamp(0.0, 1.0));
            let got = colours[v as usize];
            if !std::mem::replace(&mut seen[v as usize], true) {
                clamped += usize::from(want.contains(&1.0));
            }
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() <= 1e-6,
                    "vertex {v} on element {s}: {got:?} against {want:?}"
                );
            }
        }
    }
    // Shared vertices: far fewer than the elements' corners.
    assert!(
        positions.len() < indices.len() / 3,
        "{} vertices",
        positions.len()
    );
    assert!(seen.iter().all(|&s| s));
    assert!(
        clamped < positions.len() / 10,
        "{clamped} of {}",
        positions.len()
    );
}

#[test]
fn group_layers_sum_to_the_all_groups_map_and_scale_with_their_intensity() {
    let d = dir("groups");
    let file = lit_quad(
        &d,
        &[
            ("warm", [4.0, 2.0, 1.0], 0.1),
            ("cool", [1.0, 2.0, 5.0], 0.6),
        ],
    );
    let (all, groups, scaled) = (
        d.join("all.exr"),
        d.join("groups.exr"),
        d.join("scaled.exr"),
    );
    let common = ["--size", "128", "--samples", "float"];
    lrr(&[&["export", s(&file), "-o", s(&all)][..], &common].concat());
    lrr(&[
        &["export", s(&file), "-o", s(&groups), "--layers", "groups"][..],
        &common,
    ]
    .concat());
    lrr(&[
        &[
            "export",
            s(&file),
            "-o",
            s(&scaled),
            "--layers",
            "groups",
            "--group",
            "cool=3",
        ][..],
        &common,
    ]
    .concat());
    let all = read_exr(&all);
    let groups = read_exr(&groups);
    let scaled = read_exr(&scaled);
    let names: Vec<&str> = groups.iter().map(|l| l.0.as_str()).collect();
    assert_eq!(names, ["cool", "warm"]);
    let total = &all[0].3;
    let mut differs = 0;
    for i in 0..total.len() {
        for c in 0..3 {
            let sum = groups[0].3[i][c] + groups[1].3[i][c];
            assert!(
                (sum - total[i][c]).abs() <= 1e-6 * total[i][c].max(1e-3),
                "texel {i}: {sum} against {}",
                total[i][c]
            );
            // Each layer is its group alone: `cool` triples with --group cool=3, `warm` stays.
            assert!(
                (scaled[0].3[i][c] - 3.0 * groups[0].3[i][c]).abs()
                    <= 1e-6 * groups[0].3[i][c].max(1e-3)
            );
            assert_eq!(scaled[1].3[i][c], groups[1].3[i][c]);
            differs +=
                usize::from((groups[0].3[i][c] - groups[1].3[i][c]).abs() > 1e-3 * total[i][c]);
        }
    }
    assert!(
        differs > total.len(),
        "the two groups light the floor differently"
    );
}

#[test]
fn bad_export_flags_are_errors_that_name_them() {
    let d = dir("flags");
    let file = lit_quad(&d, &[("lamp", [1.0, 1.0, 1.0], 0.35)]);
    let err = |args: &[&str]| {
        let mut all = vec!["lrr", "export", s(&file)];
        all.extend_from_slice(args);
        format!("{:#}", lrr_cli::run(all, &mut Vec::new()).unwrap_err())
    };
    let out = |n: &str| d.join(n).to_str().unwrap().to_string();
    assert!(err(&["-o", &out("x.png")]).contains(".exr (lightmap), .glb or .gltf"));
    assert!(err(&["-o", &out("x.exr"), "--lightmap"]).contains("--lightmap is for glTF"));
    assert!(
        err(&["-o", &out("x.glb"), "--layers", "groups"]).contains("--layers groups is for EXR")
    );
    assert!(err(&["-o", &out("x.glb"), "--size", "64"]).contains("add --lightmap"));
    assert!(
        err(&["-o", &out("x.exr"), "--group", "nope=1"])
            .contains("no light group 'nope' (it has: lamp)")
    );
    assert!(err(&["-o", &out("x.exr"), "--group", "lamp=-1"]).contains("finite number >= 0"));
    assert!(err(&["-o", &out("x.exr"), "--size", "2"]).contains("do not fit"));
    assert!(err(&["-o", &out("x.glb"), "--exposure", "0"]).contains("--exposure 0"));
    assert!(!d.join("x.exr").exists() && !d.join("x.glb").exists());
}

#[test]
fn exports_are_deterministic() {
    let d = dir("determinism");
    let file = lit_quad(&d, &[("lamp", [1.0, 1.0, 1.0], 0.35)]);
    for name in ["a.exr", "a.glb", "a.gltf"] {
        let (one, two) = (d.join(format!("1{name}")), d.join(format!("2{name}")));
        let lightmap: &[&str] = if name.ends_with(".exr") {
            &[]
        } else {
            &["--lightmap"]
        };
        lrr(&[&["export", s(&file), "-o", s(&one)][..], lightmap].concat());
        lrr(&[&["export", s(&file), "-o", s(&two)][..], lightmap].concat());
        assert_eq!(
            std::fs::read(&one).unwrap(),
            std::fs::read(&two).unwrap(),
            "{name}"
        );
    }
}

/// OpenEXR (PyPI) and the Khronos glTF validator (npm) on the exports of a Cornell bake:
/// scripts/check-exports.py. Ignored by default (it needs scripts/setup-exports.sh);
/// scripts/test runs it with `--ignored` when .exports/ is there.
#[test]
#[ignore]
fn readers_we_did_not_write_accept_the_exports() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let python = root.join(".exports/venv/bin/python");
    assert!(
        python.exists(),
        "{} is missing: run scripts/setup-exports.sh",
        python.display()
    );
    let d = dir("readers");
    let file = cornell(&d);
    let out = std::process::Command::new(python)
        .arg(root.join("scripts/check-exports.py"))
        .args([env!("CARGO_BIN_EXE_lrr"), s(&file), s(&d.join("check"))])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    println!("{text}");
    assert!(
        out.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains(" passed, 0 failed"), "{text}");
}

#[test]
fn relight_writes_a_lightmap_per_frame_following_the_keyframes() {
    let d = dir("relight");
    let file = lit_quad(
        &d,
        &[
            ("warm", [4.0, 2.0, 1.0], 0.1),
            ("cool", [1.0, 2.0, 5.0], 0.6),
        ],
    );
    let anim = d.join("anim.toml");
    std::fs::write(
        &anim,
        "fps = 2.0\n[[group]]\nname = \"cool\"\nkeys = [\n  { time = 0.0, intensity = 1.0 },\n  \
         { time = 1.0, intensity = 0.5, colour = [1.0, 0.0, 2.0] },\n]\n",
    )
    .unwrap();
    let frames = d.join("frames");
    let common = ["--size", "64", "--samples", "float"];
    let text = lrr(&[
        &[
            "relight",
            s(&file),
            "--animation",
            s(&anim),
            "-o",
            s(&frames),
            "-q",
        ][..],
        &common,
    ]
    .concat());
    assert!(
        text.contains("wrote 3 frames") && text.contains("frames/s"),
        "{text}"
    );
    // Each frame against exports of the groups alone: warm stays at 1, cool follows its keys
    // (t = 0.5 s: halfway between intensity 1 colour 1 and intensity 0.5 colour (1, 0, 2)).
    let groups = d.join("groups.exr");
    lrr(&[
        &["export", s(&file), "-o", s(&groups), "--layers", "groups"][..],
        &common,
    ]
    .concat());
    let groups = read_exr(&groups);
    let (cool, warm) = (&groups[0].3, &groups[1].3);
    for (f, scale) in [
        (0, [1.0, 1.0, 1.0]),
        (1, [0.75, 0.5, 1.0]),
        (2, [0.5, 0.0, 1.0]),
    ] {
        let frame = read_exr(&frames.join(format!("lightmap-{f:05}.exr")));
        for (i, got) in frame[0].3.iter().enumerate() {
            for c in 0..3 {
                let want = warm[i][c] + scale[c] * cool[i][c];
                assert!(
                    (got[c] - want).abs() <= 1e-5 * want.max(1e-3),
                    "frame {f} texel {i}: {got:?} against {want}"
                );
            }
        }
    }
    // Bad animations are errors naming the file and the problem.
    std::fs::write(
        &anim,
        "fps = 2.0\n[[group]]\nname = \"nope\"\nkeys = [{ time = 0.0, intensity = 1.0 }]\n",
    )
    .unwrap();
    let mut sink = Vec::new();
    let e = lrr_cli::run(
        [
            "lrr",
            "relight",
            s(&file),
            "--animation",
            s(&anim),
            "-o",
            s(&frames),
        ],
        &mut sink,
    )
    .unwrap_err();
    assert!(
        format!("{e:#}")
            .contains("group 'nope' is not a light group of the file (it has: warm, cool)"),
        "{e:#}"
    );
    std::fs::write(&anim, "fps = 2.0\n[[group]]\nname = \"cool\"\nkeys = [{ time = 1.0, intensity = 1.0 }, { time = 1.0, intensity = 2.0 }]\n").unwrap();
    let e = lrr_cli::run(
        [
            "lrr",
            "relight",
            s(&file),
            "--animation",
            s(&anim),
            "-o",
            s(&frames),
        ],
        &mut sink,
    )
    .unwrap_err();
    assert!(format!("{e:#}").contains("times must increase"), "{e:#}");
}

/// A file drawn through display faces (section FACES, format 1.4; `testkit::faces`: two
/// elements drawn as interleaved triangles over proxy quads): `lrr info` counts the faces, the
/// glTF mesh is the faces (each vertex the value of its face's element flat, the runtime's
/// smooth value on that face), and every lightmap texel shows the element of the face under it,
/// not the element whose GEOMETRY proxy lies there.
#[test]
fn exports_of_a_file_with_display_faces_follow_the_faces() {
    use lrr_runtime::testkit::faces::{EMISSION, element_at, interleaved};
    let d = dir("faces");
    let path = d.join("faces.lrr");
    interleaved().write(&path).unwrap();
    let info = lrr(&["info", s(&path)]);
    assert!(
        info.contains("4 display faces for the 2 elements"),
        "{info}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&lrr(&["info", s(&path), "--json"])).unwrap();
    assert_eq!(json["display"]["faces"], 4, "{}", json["display"]);

    // `lrr probe`: (0.2, 0.4) lies on element 0's proxy but on a face of element 1 (original
    // id 0); (0.9, 0.6) the other way round.
    let points = d.join("points.json");
    let json = r#"[{"position":[0.2,0.4,0.0],"normal":[0,0,1]},{"position":[0.9,0.6,0.0],"normal":[0,0,1]}]"#;
    std::fs::write(&points, json).unwrap();
    let probe = lrr(&[
        "probe",
        s(&path),
        "--points",
        s(&points),
        "--json",
        "--reconstruct",
        "flat",
    ]);
    let probe: serde_json::Value = serde_json::from_str(&probe).unwrap();
    for (i, (id, e)) in [(0, 1), (1, 0)].into_iter().enumerate() {
        assert_eq!(probe[i]["element"], id, "{probe}");
        let got: Vec<f64> = serde_json::from_value(probe[i]["radiosity"].clone()).unwrap();
        let want = EMISSION[e].map(f64::from);
        assert!((0..3).all(|c| (got[c] - want[c]).abs() < 1e-6), "{probe}");
    }

    let op = Operator::load(&path).unwrap();
    let b = op.evaluate_baked();
    let runtime = Runtime::new(&op, &b);
    let flat_value =
        |p: DVec3| EMISSION[element_at(p.x as f32, p.y as f32)].map(|v| v / std::f32::consts::PI);
    for reconstruct in ["flat", "smooth"] {
        let glb = d.join(format!("faces-{reconstruct}.glb"));
        lrr(&[
            "export",
            s(&path),
            "-o",
            s(&glb),
            "--exposure",
            "1",
            "--reconstruct",
            reconstruct,
        ]);
        let gltf = gltf::Gltf::from_slice(&std::fs::read(&glb).unwrap()).unwrap();
        let blob = gltf.blob.clone().unwrap();
        let prim = gltf.meshes().next().unwrap().primitives().next().unwrap();
        let reader = prim.reader(|_| Some(&blob));
        let positions: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
        let colours: Vec<[f32; 3]> = reader.read_colors(0).unwrap().into_rgb_f32().collect();
        let indices: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
        // One triangle per face, in face order, with the face's corners (not GEOMETRY's).
        assert_eq!(indices.len(), 3 * 4, "{reconstruct}");
        let faces: Vec<_> = op.file().faces().triangles().collect();
        for (face, tri) in indices.chunks(3).enumerate() {
            let corners: Vec<[f32; 3]> = tri.iter().map(|&v| positions[v as usize]).collect();
            assert_eq!(
                (faces[face].0 as usize, &corners[..]),
                (face, &faces[face].1[..])
            );
            let p: Vec<DVec3> = corners
                .iter()
                .map(|c| DVec3::from_array(c.map(f64::from)))
                .collect();
            let centroid = (p[0] + p[1] + p[2]) / 3.0;
            for (&v, &at) in tri.iter().zip(&p) {
                let want = match reconstruct {
                    "flat" => flat_value(centroid),
                    _ => runtime.at(face, at),
                };
                let got = colours[v as usize];
                assert!(
                    (0..3).all(|c| (got[c] - want[c]).abs() <= 1e-6),
                    "{reconstruct}: face {face} vertex {v}: {got:?} against {want:?}"
                );
            }
        }
    }

    // The lightmap, flat, over generated charts: one chart of the 4 coplanar faces.
    let exr = d.join("faces.exr");
    lrr(&[
        "export",
        s(&path),
        "-o",
        s(&exr),
        "--size",
        "32",
        "--reconstruct",
        "flat",
        "--samples",
        "float",
    ]);
    let layers = read_exr(&exr);
    let (_, w, h, pixels) = &layers[0];
    let charts = charts::charts(op.file().faces().geometry);
    assert_eq!(charts.len(), 1);
    let layout = atlas::pack(&charts, Sizing::Size(32), 2).unwrap();
    assert_eq!((layout.width, layout.height), (*w, *h));
    let (map, texels) = filled(&op, &b, &charts, &layout, LightmapValues::Flat);
    assert_eq!(&texels, pixels);
    let inside: std::collections::HashSet<usize> = map.samples().map(|s| s.texel).collect();
    let (mut inside_count, mut off_proxy) = (0, 0);
    for y in 0..*h {
        for x in 0..*w {
            if !inside.contains(&(y * w + x)) {
                continue;
            }
            let q = layout.chart_point(0, DVec2::new(x as f64 + 0.5, y as f64 + 0.5));
            let p = charts[0].lift(q);
            let diagonal = (p.y - (p.x - p.x.floor().clamp(0.0, 1.0))).abs();
            if diagonal < 1e-6 {
                continue;
            }
            assert_eq!(pixels[y * w + x], flat_value(p), "texel ({x}, {y}) at {p}");
            let e = element_at(p.x as f32, p.y as f32);
            off_proxy += usize::from(e != usize::from(p.y > 0.5));
            inside_count += 1;
        }
    }
    assert!(
        inside_count > 100 && off_proxy > inside_count / 8,
        "{inside_count} {off_proxy}"
    );
}
