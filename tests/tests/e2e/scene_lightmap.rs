//! The scene's own lightmap coordinates (glTF `TEXCOORD_1`) kept by the bake (section
//! LIGHTMAP) and used by `lrr export`: texels of the EXR equal the runtime's `B/π` at the point
//! whose coordinates are the texel centre, the gutters around charts are dilated, nothing else
//! is written; the glTF export's lightmap UVs are the scene's.

use std::path::Path;

use glam::DVec2;
use serde_json::json;

use super::gltf::Builder;
use crate::util::{bake, lrr, temp_dir};
use lrr_runtime::{Operator, Reconstruction};

/// The floor's lightmap coordinates: an affine map (rotated, sheared, scaled) of its plane.
fn floor_uv(p: DVec2) -> DVec2 {
    DVec2::new(
        0.05 + 0.25 * p.x - 0.025 * p.y,
        0.6 + 0.025 * p.x - 0.25 * p.y,
    )
}

/// Its inverse: the floor point of lightmap coordinates `t`.
fn floor_point(t: DVec2) -> DVec2 {
    let (a, b, c, d) = (0.25, -0.025, 0.025, -0.25);
    let r = t - DVec2::new(0.05, 0.6);
    let det = a * d - b * c;
    DVec2::new((d * r.x - b * r.y) / det, (a * r.y - c * r.x) / det)
}

fn uv_accessor(b: &mut Builder, uv: &[[f64; 2]]) -> usize {
    let bytes: Vec<u8> = uv
        .iter()
        .flatten()
        .flat_map(|x| (*x as f32).to_le_bytes())
        .collect();
    let view = b.view(&bytes, None);
    b.accessor(
        json!({"bufferView": view, "componentType": 5126, "count": uv.len(), "type": "VEC2"}),
    )
}

/// A 2 × 2 floor at z = 0 and a lamp above it, both with TEXCOORD_1.
pub fn lit_floor() -> Builder {
    let mut b = Builder::default();
    let corners = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
    let floor = b.positions(&corners.map(|[x, y]| [x as f32, y as f32, 0.0]));
    let uv: Vec<[f64; 2]> = corners
        .iter()
        .map(|&[x, y]| floor_uv(DVec2::new(x, y)).to_array())
        .collect();
    let floor_uv = uv_accessor(&mut b, &uv);
    let idx = b.indices(&[0, 1, 2, 0, 2, 3]);
    let lamp = b.positions(&[
        [0.5, 0.5, 1.0],
        [0.5, 1.5, 1.0],
        [1.5, 1.5, 1.0],
        [1.5, 0.5, 1.0],
    ]);
    let lamp_uv = uv_accessor(
        &mut b,
        &[[0.7, 0.7], [0.7, 0.95], [0.95, 0.95], [0.95, 0.7]],
    );
    let lamp_idx = b.indices(&[0, 1, 2, 0, 2, 3]);
    b.push(
        "materials",
        json!({"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.6, 0.5, 1.0],
        "metallicFactor": 0.0}}),
    );
    b.push(
        "materials",
        json!({"name": "lamp", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0],
        "metallicFactor": 0.0}, "emissiveFactor": [1.0, 0.9, 0.8]}),
    );
    b.push(
        "meshes",
        json!({"name": "floor", "primitives": [{"attributes": {"POSITION": floor,
        "TEXCOORD_1": floor_uv}, "indices": idx, "material": 0}]}),
    );
    b.push(
        "meshes",
        json!({"name": "lamp", "primitives": [{"attributes": {"POSITION": lamp,
        "TEXCOORD_1": lamp_uv}, "indices": lamp_idx, "material": 1}]}),
    );
    b.push("nodes", json!({"name": "floor", "mesh": 0}));
    b.push("nodes", json!({"name": "lamp", "mesh": 1}));
    b.push("scenes", json!({"nodes": [0, 1]}));
    b
}

/// Bakes the lit floor into `dir`; returns the operator file.
fn baked(dir: &Path) -> std::path::PathBuf {
    let scene = dir.join("floor.glb");
    std::fs::write(&scene, lit_floor().glb()).unwrap();
    let out = dir.join("floor.lrr");
    // Unrefined: the counts below are the uniform grid's.
    bake(
        &scene,
        &out,
        &[
            "--element-size",
            "0.2",
            "--patch-size",
            "1",
            "--refine",
            "0",
        ],
    )
    .unwrap();
    out
}

/// The RGB float pixels of a one-layer EXR.
pub(crate) fn read_rgb(path: &Path) -> (usize, usize, Vec<[f32; 3]>) {
    use exr::prelude::*;
    let image = read_all_flat_layers_from_file(path).unwrap();
    let layer = &image.layer_data[0];
    let (w, h) = (layer.size.0, layer.size.1);
    let channel = |name: &str| -> Vec<f32> {
        let c = layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name)
            .unwrap();
        c.sample_data.values_as_f32().collect()
    };
    let (r, g, b) = (channel("R"), channel("G"), channel("B"));
    (w, h, (0..w * h).map(|i| [r[i], g[i], b[i]]).collect())
}

#[test]
fn the_bake_keeps_the_scenes_lightmap_coordinates_at_every_corner() {
    let dir = temp_dir("scene-lightmap-file");
    let path = baked(&dir);
    let info = crate::util::lrr_json(&["info", path.to_str().unwrap(), "--json"]);
    assert_eq!(info["display"]["lightmap_uv"], true, "{}", info["display"]);
    let text = lrr(&["info", path.to_str().unwrap()]).unwrap();
    assert!(text.contains("the scene's lightmap coordinates"), "{text}");
    let file = lrr_formats::OperatorFile::read(&path).unwrap();
    let uv = &file.display.lightmap.as_ref().expect("section LIGHTMAP").uv;
    // LIGHTMAP holds the coordinates of the display faces' corners.
    let g = file.faces().geometry;
    let mut floor_corners = 0;
    for s in 0..g.len() {
        for c in 0..usize::from(g.vertex_count[s]) {
            let p = &g.vertices[12 * s + 3 * c..12 * s + 3 * c + 3];
            let got = DVec2::new(
                f64::from(uv[8 * s + 2 * c]),
                f64::from(uv[8 * s + 2 * c + 1]),
            );
            if p[2] < 0.5 {
                let want = floor_uv(DVec2::new(f64::from(p[0]), f64::from(p[1])));
                assert!((got - want).length() < 1e-6, "{got} vs {want}");
                floor_corners += 1;
            } else {
                assert!(got.min_element() >= 0.7 - 1e-6 && got.max_element() <= 0.95 + 1e-6);
            }
        }
    }
    // The floor halves until its elements are at most 0.2: 16 × 16 quads of 0.125.
    assert_eq!(floor_corners, 4 * 16 * 16);
}

#[test]
fn the_exr_fills_the_scenes_atlas_with_the_runtimes_radiance() {
    let dir = temp_dir("scene-lightmap-exr");
    let file = baked(&dir);
    let exr_path = dir.join("floor.exr");
    let said = lrr(&[
        "export",
        file.to_str().unwrap(),
        "-o",
        exr_path.to_str().unwrap(),
        "--size",
        "64",
        "--samples",
        "float",
    ])
    .unwrap();
    assert!(said.contains("the scene's lightmap coordinates"), "{said}");
    let (w, h, pixels) = read_rgb(&exr_path);
    assert_eq!((w, h), (64, 64));
    let op = Operator::load(&file).unwrap();
    let b = op.evaluate_baked();
    let smooth = Reconstruction::new(op.file()).unwrap();
    let mut vertices = vec![[0.0f32; 3]; smooth.vertex_count()];
    smooth.vertex_values(&b, &mut vertices).unwrap();
    let (mut inside, mut lo, mut hi) = (0, f32::MAX, 0.0f32);
    let mut filled = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let t = DVec2::new((x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64);
            let q = floor_point(t);
            let margin = 1e-6;
            if q.min_element() <= margin || q.max_element() >= 2.0 - margin {
                continue;
            }
            let p = [q.x as f32, q.y as f32, 0.0];
            let s = op.locate_face(p, [0.0, 0.0, 1.0]).unwrap();
            let want = smooth.at(&vertices, s, p).map(|v| v / std::f32::consts::PI);
            let got = pixels[y * w + x];
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() <= 2e-6 * want[c],
                    "texel ({x}, {y}) channel {c}: {} against the runtime's {}",
                    got[c],
                    want[c]
                );
            }
            filled[y * w + x] = true;
            inside += 1;
            lo = lo.min(got[0]);
            hi = hi.max(got[0]);
        }
    }
    // The floor covers |det| · 4 = 0.25 · 0.25 · 1.01 · 4 of the atlas' 64² texels ≈ 1034.
    assert!(
        (1000..1070).contains(&inside),
        "{inside} texels inside the floor"
    );
    assert!(
        hi > 1.5 * lo,
        "the radiance varies over the floor: {lo} .. {hi}"
    );
    // Two rings of dilation (the default padding): every texel next to a floor texel is lit;
    // texels three rings or more from every chart stay black.
    let near = |x: usize, y: usize, r: i64| {
        (-r..=r).any(|dy| {
            (-r..=r).any(|dx| {
                let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                nx >= 0
                    && ny >= 0
                    && (nx as usize) < w
                    && (ny as usize) < h
                    && filled[ny as usize * w + nx as usize]
            })
        })
    };
    let lamp = |x: usize, y: usize| x >= 40 && y >= 40;
    for y in 0..h {
        for x in 0..w {
            let v = pixels[y * w + x];
            if near(x, y, 1) {
                assert!(
                    v.iter().all(|&c| c > 0.0),
                    "texel ({x}, {y}) next to the floor is black"
                );
            } else if !near(x, y, 3) && !lamp(x, y) {
                assert_eq!(v, [0.0; 3], "texel ({x}, {y}) far from every chart");
            }
        }
    }
}

#[test]
fn gltf_lightmap_uvs_are_the_scenes_and_generated_ones_stay_available() {
    let dir = temp_dir("scene-lightmap-gltf");
    let file = baked(&dir);
    let glb = dir.join("floor.glb");
    let f = file.to_str().unwrap();
    lrr(&[
        "export",
        f,
        "-o",
        glb.to_str().unwrap(),
        "--lightmap",
        "--size",
        "64",
    ])
    .unwrap();
    let (doc, bin) = read_glb(&std::fs::read(&glb).unwrap());
    let attrs = &doc["meshes"][0]["primitives"][0]["attributes"];
    let pos = floats(&doc, &bin, attrs["POSITION"].as_u64().unwrap() as usize, 3);
    let uv = floats(
        &doc,
        &bin,
        attrs["TEXCOORD_0"].as_u64().unwrap() as usize,
        2,
    );
    assert_eq!(pos.len() / 3, uv.len() / 2);
    let mut floor = 0;
    for (p, t) in pos.chunks(3).zip(uv.chunks(2)) {
        if p[2] < 0.5 {
            let want = floor_uv(DVec2::new(f64::from(p[0]), f64::from(p[1])));
            let got = DVec2::new(f64::from(t[0]), f64::from(t[1]));
            assert!((got - want).length() < 1e-6, "{got} vs {want}");
            floor += 1;
        }
    }
    // One vertex per smooth vertex of the floor's 16 × 16 grid.
    assert_eq!(floor, 17 * 17);
    // --uv generated packs charts instead; --texel-density alone implies it.
    let gen_exr = dir.join("generated.exr");
    let said = lrr(&[
        "export",
        f,
        "-o",
        gen_exr.to_str().unwrap(),
        "--uv",
        "generated",
    ])
    .unwrap();
    assert!(said.contains("generated charts"), "{said}");
    let said = lrr(&[
        "export",
        f,
        "-o",
        gen_exr.to_str().unwrap(),
        "--texel-density",
        "10",
    ])
    .unwrap();
    assert!(said.contains("generated charts"), "{said}");
    let e = lrr(&[
        "export",
        f,
        "-o",
        gen_exr.to_str().unwrap(),
        "--uv",
        "scene",
        "--texel-density",
        "10",
    ])
    .unwrap_err();
    assert!(e.contains("--texel-density") && e.contains("--size"), "{e}");
}

#[test]
fn a_file_without_scene_coordinates_says_how_to_get_them() {
    let dir = temp_dir("scene-lightmap-none");
    let scene = dir.join("floor.glb");
    // The lamp without TEXCOORD_1: only some faces have coordinates, so the bake keeps none
    // and the import warns.
    let mut root: serde_json::Value = serde_json::from_str(&lit_floor().gltf()).unwrap();
    root["meshes"][1]["primitives"][0]["attributes"]
        .as_object_mut()
        .unwrap()
        .remove("TEXCOORD_1");
    std::fs::write(&scene, root.to_string()).unwrap();
    let loaded = lrr_precompute::scene::load(&scene).unwrap();
    assert!(
        loaded
            .warnings
            .iter()
            .any(|w| w.contains("2 of 4 faces") && w.contains("TEXCOORD_1") && w.contains("lamp")),
        "{:?}",
        loaded.warnings
    );
    let out = dir.join("floor.lrr");
    bake(
        &scene,
        &out,
        &["--element-size", "0.5", "--patch-size", "1"],
    )
    .unwrap();
    // The bake packs charts of its own instead.
    let file = lrr_formats::OperatorFile::read(&out).unwrap();
    let atlas = file.display.lightmap.unwrap().atlas.unwrap();
    assert_eq!(atlas.source, lrr_formats::LightmapSource::Generated);
    assert_eq!((atlas.width, atlas.height, atlas.padding), (1024, 1024, 2));
    let exr = dir.join("x.exr");
    let e = lrr(&[
        "export",
        out.to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
        "--uv",
        "scene",
    ])
    .unwrap_err();
    assert!(
        e.contains("TEXCOORD_1") && e.contains("--uv generated"),
        "{e}"
    );
}

/// The JSON and binary chunks of a GLB.
fn read_glb(bytes: &[u8]) -> (serde_json::Value, Vec<u8>) {
    let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
    let jlen = word(12);
    let doc = serde_json::from_slice(&bytes[20..20 + jlen]).unwrap();
    let blen = word(20 + jlen);
    (doc, bytes[28 + jlen..28 + jlen + blen].to_vec())
}

/// The f32 components of a tightly packed accessor.
fn floats(doc: &serde_json::Value, bin: &[u8], accessor: usize, width: usize) -> Vec<f32> {
    let a = &doc["accessors"][accessor];
    let view = &doc["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
    let start = view["byteOffset"].as_u64().unwrap_or(0) as usize
        + a["byteOffset"].as_u64().unwrap_or(0) as usize;
    let count = a["count"].as_u64().unwrap() as usize * width;
    (0..count)
        .map(|i| f32::from_le_bytes(bin[start + 4 * i..start + 4 * i + 4].try_into().unwrap()))
        .collect()
}

#[test]
fn scene_coordinates_survive_an_include_with_a_scale() {
    // The description scales everything, the glTF included, by 10: the coordinates stay at the scaled points.
    let dir = temp_dir("scene-lightmap-include");
    std::fs::write(dir.join("floor.glb"), lit_floor().glb()).unwrap();
    std::fs::write(
        dir.join("scene.toml"),
        "name = \"big floor\"\nscale = 10.0\n[[include]]\ngltf = \"floor.glb\"\n",
    )
    .unwrap();
    let out = dir.join("big.lrr");
    bake(
        &dir.join("scene.toml"),
        &out,
        &["--element-size", "2", "--patch-size", "10"],
    )
    .unwrap();
    let file = lrr_formats::OperatorFile::read(&out).unwrap();
    let uv = &file.display.lightmap.as_ref().unwrap().uv;
    let g = file.faces().geometry;
    for s in 0..g.len() {
        let p = &g.vertices[12 * s..12 * s + 3];
        if p[2] < 5.0 {
            let want = floor_uv(DVec2::new(f64::from(p[0]), f64::from(p[1])) / 10.0);
            let got = DVec2::new(f64::from(uv[8 * s]), f64::from(uv[8 * s + 1]));
            assert!((got - want).length() < 1e-6, "{got} vs {want}");
        }
    }
}

/// OpenEXR (PyPI) and the Khronos glTF validator (npm) on the exports of a file with the
/// scene's lightmap coordinates: scripts/check-exports.py maps texel centres back to 3D through
/// the exported glTF's UVs (here the scene's) and compares with `lrr probe`. Ignored by
/// default (it needs scripts/setup-exports.sh); scripts/test runs it with `--ignored`.
#[test]
#[ignore]
fn readers_we_did_not_write_accept_scene_uv_lightmaps() {
    let root = crate::util::root();
    let python = root.join(".exports/venv/bin/python");
    assert!(
        python.exists(),
        "{} is missing: run scripts/setup-exports.sh",
        python.display()
    );
    let dir = temp_dir("scene-lightmap-readers");
    let file = baked(&dir);
    let out = std::process::Command::new(python)
        .arg(root.join("scripts/check-exports.py"))
        .arg(crate::util::lrr_binary())
        .arg(&file)
        .arg(dir.join("check"))
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
fn relight_fills_the_scenes_atlas_like_export() {
    let dir = temp_dir("scene-lightmap-relight");
    let file = baked(&dir);
    let f = file.to_str().unwrap();
    let anim = dir.join("anim.toml");
    std::fs::write(
        &anim,
        "fps = 1.0\n[[group]]\nname = \"lamp\"\nkeys = [{ time = 0.0, intensity = 0.5 }]\n",
    )
    .unwrap();
    let frames = dir.join("frames");
    let said = lrr(&[
        "relight",
        f,
        "--animation",
        anim.to_str().unwrap(),
        "-o",
        frames.to_str().unwrap(),
        "--size",
        "64",
        "--samples",
        "float",
        "-q",
    ])
    .unwrap();
    assert!(said.contains("the scene's lightmap coordinates"), "{said}");
    let exported = dir.join("half.exr");
    lrr(&[
        "export",
        f,
        "-o",
        exported.to_str().unwrap(),
        "--size",
        "64",
        "--samples",
        "float",
        "--group",
        "lamp=0.5",
    ])
    .unwrap();
    let (_, _, relit) = read_rgb(&frames.join("lightmap-00000.exr"));
    let (_, _, want) = read_rgb(&exported);
    assert_eq!(relit, want);
    assert!(want.iter().any(|p| p[0] > 0.0));
}

/// A curved surface of 10⁵ triangles (none coplanar with another) bakes with the defaults and
/// keeps a lightmap the runtime fills. It used to be 10⁵ one-triangle charts, more than etagere
/// numbers: the bake stopped ("100831 charts of at least 5×5 texels (padding 2) do not fit").
/// Past that limit the atlas has shelves of its own (`display::atlas`'s tests), and the sphere's
/// triangles now join into charts within 30° (`display::charts`), so the default 1024² holds
/// them.
#[test]
fn a_curved_surface_of_a_hundred_thousand_triangles_keeps_its_lightmap() {
    let dir = temp_dir("lightmap-many-charts");
    let scene = dir.join("bs.toml");
    lrr(&[
        "scene",
        "box-sphere",
        "--triangles",
        "100000",
        "-o",
        scene.to_str().unwrap(),
    ])
    .unwrap();
    let out = dir.join("bs.lrr");
    bake(&scene, &out, &[]).unwrap_or_else(|e| panic!("the default bake: {e}"));
    let info = crate::util::lrr_json(&["info", out.to_str().unwrap(), "--json"]);
    let atlas = &info["display"]["lightmap_atlas"];
    let side = atlas["width"].as_u64().unwrap();
    assert_eq!(side, 1024, "{info}");
    let op = Operator::load(&out).unwrap();
    let mut map = lrr_runtime::Lightmap::new(op.file(), None).unwrap();
    assert!(
        map.sample_count() > 100_000,
        "{} samples",
        map.sample_count()
    );
    let mut texels = vec![[0.0f32; 3]; map.width() * map.height()];
    map.fill(&op.evaluate_baked(), &mut texels).unwrap();
    assert!(texels.iter().flatten().all(|x| x.is_finite() && *x >= 0.0));
    assert!(texels.iter().any(|t| t[0] > 0.0));
}
