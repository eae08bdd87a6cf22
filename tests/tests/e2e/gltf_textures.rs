//! glTF base colour textures varying the reflectance over a surface: each element takes the
//! texture's mean over its area (`Scene::reflectance_over`), checked after a bake against the
//! texels the element covers; texture coordinates in every accepted encoding; bad ones refused
//! with the accessor named.

use serde_json::{Value, json};

use super::gltf::Builder;
use crate::util::{bake, temp_dir};

/// The floor's bake: elements of 0.25 on the 2 × 2 floor, one texel each, unrefined (the
/// refinement where light changes would split some).
pub const FLOOR_BAKE: [&str; 6] = [
    "--element-size",
    "0.25",
    "--patch-size",
    "1",
    "--refine",
    "0",
];

/// An 8×8 texture of four 4×4 blocks: red, green (top row of blocks), blue, white (bottom).
const BLOCKS: [[u8; 3]; 4] = [[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255]];

fn png_blocks() -> Vec<u8> {
    let mut texels = Vec::with_capacity(8 * 8 * 3);
    for y in 0..8 {
        for x in 0..8 {
            texels.extend_from_slice(&BLOCKS[2 * (y / 4) + x / 4]);
        }
    }
    let mut out = Vec::new();
    image::ImageEncoder::write_image(
        image::codecs::png::PngEncoder::new(&mut out),
        &texels,
        8,
        8,
        image::ColorType::Rgb8,
    )
    .unwrap();
    out
}

/// Texture coordinates in one of the encodings glTF allows: FLOAT, or normalised
/// UNSIGNED_SHORT / UNSIGNED_BYTE (component types 5126, 5123, 5121).
fn texcoords(b: &mut Builder, uv: &[[f64; 2]], component: u32) -> usize {
    let bytes: Vec<u8> = match component {
        5126 => uv
            .iter()
            .flatten()
            .flat_map(|x| (*x as f32).to_le_bytes())
            .collect(),
        5123 => uv
            .iter()
            .flatten()
            .flat_map(|x| ((x * 65535.0).round() as u16).to_le_bytes())
            .collect(),
        _ => uv
            .iter()
            .flatten()
            .map(|x| (x * 255.0).round() as u8)
            .collect(),
    };
    let view = b.view(&bytes, None);
    b.accessor(
        json!({"bufferView": view, "componentType": component, "normalized": component != 5126,
        "count": uv.len(), "type": "VEC2"}),
    )
}

/// A 2 × 2 floor at z = 0 (two triangles, TEXCOORD_0 = (x/2, 1 − y/2): the image upright,
/// seen from above) under the textured material, and a lamp above it; `component` encodes the
/// texture coordinates.
pub fn textured_floor(component: u32) -> Builder {
    textured_floor_with(component, &png_blocks())
}

/// [`textured_floor`] with the image `png`.
fn textured_floor_with(component: u32, png: &[u8]) -> Builder {
    let mut b = Builder::default();
    let floor = b.positions(&[
        [0.0, 0.0, 0.0],
        [2.0, 0.0, 0.0],
        [2.0, 2.0, 0.0],
        [0.0, 2.0, 0.0],
    ]);
    let uv = texcoords(
        &mut b,
        &[[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]],
        component,
    );
    let idx = b.indices(&[0, 1, 2, 0, 2, 3]);
    let lamp = b.positions(&[
        [0.5, 0.5, 1.0],
        [0.5, 1.5, 1.0],
        [1.5, 1.5, 1.0],
        [1.5, 0.5, 1.0],
    ]);
    let lamp_idx = b.indices(&[0, 1, 2, 0, 2, 3]);
    let img = b.view(png, None);
    b.push(
        "images",
        json!({"bufferView": img, "mimeType": "image/png"}),
    );
    // Clamp to edge: the outer rows of elements see their own block only.
    b.push("samplers", json!({"wrapS": 33071, "wrapT": 33071}));
    b.push("textures", json!({"source": 0, "sampler": 0}));
    b.push(
        "materials",
        json!({"name": "tiles", "pbrMetallicRoughness": {
        "baseColorFactor": [0.8, 0.8, 0.8, 1.0], "baseColorTexture": {"index": 0},
        "metallicFactor": 0.0}}),
    );
    b.push(
        "materials",
        json!({"name": "lamp", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0],
        "metallicFactor": 0.0}, "emissiveFactor": [1.0, 1.0, 1.0]}),
    );
    b.push(
        "meshes",
        json!({"name": "floor", "primitives": [{"attributes": {"POSITION": floor,
        "TEXCOORD_0": uv}, "indices": idx, "material": 0}]}),
    );
    b.push(
        "meshes",
        json!({"name": "lamp", "primitives": [{"attributes": {"POSITION": lamp},
        "indices": lamp_idx, "material": 1}]}),
    );
    b.push("nodes", json!({"name": "floor", "mesh": 0}));
    b.push("nodes", json!({"name": "lamp", "mesh": 1}));
    b.push("scenes", json!({"nodes": [0, 1]}));
    b
}

fn srgb_to_linear(v: f64) -> f64 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Element centres and reflectances of a baked file (file order).
fn baked_floor(file: &lrr_formats::OperatorFile) -> Vec<([f64; 3], [f64; 3])> {
    let g = &file.geometry;
    (0..file.n as usize)
        .map(|e| {
            let c = usize::from(g.vertex_count[e]);
            let mut centre = [0.0; 3];
            for i in 0..c {
                for (k, x) in centre.iter_mut().enumerate() {
                    *x += f64::from(g.vertices[12 * e + 3 * i + k]) / c as f64;
                }
            }
            let rho = [0, 1, 2].map(|k| f64::from(file.reflectance[3 * e + k]));
            (centre, rho)
        })
        .filter(|(c, _)| c[2] < 0.5)
        .collect()
}

#[test]
fn each_element_takes_the_mean_of_the_texels_it_covers() {
    let dir = temp_dir("gltf-texture");
    for component in [5126, 5123, 5121] {
        let path = dir.join(format!("floor-{component}.glb"));
        std::fs::write(&path, textured_floor(component).glb()).unwrap();
        let scene = lrr_precompute::scene::load(&path).unwrap();
        assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
        assert_eq!(scene.textures.len(), 1);
        let out = dir.join(format!("floor-{component}.lrr"));
        // Elements of 0.25 on the 2 × 2 floor: one texel each (8 × 8), one block per 4 × 4
        // (unrefined: the refinement where light changes would split some).
        bake(&path, &out, &FLOOR_BAKE).unwrap();
        let material = scene.materials.iter().find(|m| m.name == "tiles").unwrap();
        check_blocks(&out, material.reflectance);
    }
}

/// The elements of the baked floor `out` against the blocks under them (factor 0.8), and
/// their mean against the material's `reflectance`.
fn check_blocks(out: &std::path::Path, reflectance: [f64; 3]) {
    let file = lrr_formats::OperatorFile::read(out).unwrap();
    assert_eq!(file.channels, 3, "a coloured texture needs three channels");
    let floor = baked_floor(&file);
    assert_eq!(floor.len(), 64);
    let factor = f64::from(0.8f32);
    let mut mean = [0.0; 3];
    for (centre, rho) in &floor {
        // Texel column and row of the element (v = 1 − y/2 puts y = 2 at the top row).
        let (tx, ty) = (
            (centre[0] * 4.0) as usize,
            ((2.0 - centre[1]) * 4.0) as usize,
        );
        let block = BLOCKS[2 * (ty / 4) + tx / 4];
        // An element one texel or more from a block edge sees its block's colour only
        // (bilinear filtering reaches half a texel).
        let inner = |t: usize| (t % 4 != 3 && !t.is_multiple_of(4)) || t == 0 || t == 7;
        if inner(tx) && inner(ty) {
            let want = block.map(|c| factor * srgb_to_linear(f64::from(c) / 255.0));
            for k in 0..3 {
                // The file stores f32.
                assert!(
                    (rho[k] - want[k]).abs() < 1e-6,
                    "element at {centre:?} (texel {tx}, {ty}): {rho:?}, want {want:?}"
                );
            }
        }
        for k in 0..3 {
            mean[k] += rho[k] / 64.0;
        }
    }
    // Over the floor the elements average to the material's mean (the image's mean times
    // the factor): bilinear blending at block edges only moves colour across them.
    for k in 0..3 {
        let err = (mean[k] - reflectance[k]).abs() / reflectance[k];
        assert!(err < 2e-3, "mean {mean:?} vs material {reflectance:?}");
    }
}

/// The floor of [`textured_floor`] as an OBJ whose MTL names the blocks with `map_Kd -clamp on`
/// (`vt` with `v` up, as OBJ has it: the same image upright from above) and a lamp; `image`
/// is the file `map_Kd` names.
fn obj_floor(dir: &std::path::Path, image: &str) -> std::path::PathBuf {
    std::fs::write(dir.join("blocks.png"), png_blocks()).unwrap();
    std::fs::write(
        dir.join("floor.mtl"),
        format!(
            "newmtl tiles\nKd 0.8 0.8 0.8\nmap_Kd -clamp on {image}\n\n\
             newmtl lamp\nKd 0.5 0.5 0.5\nKe 1 1 1\n"
        ),
    )
    .unwrap();
    let path = dir.join("floor.obj");
    std::fs::write(
        &path,
        "mtllib floor.mtl\n\
         v 0 0 0\nv 2 0 0\nv 2 2 0\nv 0 2 0\n\
         v 0.5 0.5 1\nv 0.5 1.5 1\nv 1.5 1.5 1\nv 1.5 0.5 1\n\
         vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
         o floor\nusemtl tiles\nf 1/1 2/2 3/3 4/4\n\
         o lamp\nusemtl lamp\nf 5 6 7 8\n",
    )
    .unwrap();
    path
}

#[test]
fn an_obj_map_kd_varies_the_reflectance_as_a_gltf_texture_does() {
    let dir = temp_dir("obj-texture");
    let path = obj_floor(&dir, "blocks.png");
    let scene = lrr_precompute::scene::load(&path).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert_eq!(scene.textures.len(), 1);
    let out = dir.join("floor.lrr");
    bake(&path, &out, &FLOOR_BAKE).unwrap();
    let material = scene.materials.iter().find(|m| m.name == "tiles").unwrap();
    check_blocks(&out, material.reflectance);
    // A face without its own vt (the file has some): the material's mean over the whole
    // floor, not the colour of the coordinate before.
    let plain = std::fs::read_to_string(&path)
        .unwrap()
        .replace("f 1/1 2/2 3/3 4/4", "f 1 2 3 4");
    std::fs::write(dir.join("plain.obj"), plain).unwrap();
    let out = dir.join("plain.lrr");
    bake(&dir.join("plain.obj"), &out, &FLOOR_BAKE).unwrap();
    let file = lrr_formats::OperatorFile::read(&out).unwrap();
    for (centre, rho) in baked_floor(&file) {
        for k in 0..3 {
            assert!(
                (rho[k] - material.reflectance[k]).abs() < 1e-6,
                "element at {centre:?}: {rho:?}, want the mean {:?}",
                material.reflectance
            );
        }
    }
    // An image that is not there: a warning, and Kd alone.
    let path = obj_floor(&dir, "missing.png");
    let scene = lrr_precompute::scene::load(&path).unwrap();
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("map_Kd image 'missing.png' is not beside")
                && w.contains("Kd used alone")),
        "{:?}",
        scene.warnings
    );
    let tiles = scene.materials.iter().find(|m| m.name == "tiles").unwrap();
    assert_eq!((tiles.reflectance, tiles.texture), ([0.8; 3], None));
    // A white image and no Kd: a reflectance of 1, clamped with a warning, not refused.
    let mut white = Vec::new();
    image::ImageEncoder::write_image(
        image::codecs::png::PngEncoder::new(&mut white),
        &[255u8; 12],
        2,
        2,
        image::ColorType::Rgb8,
    )
    .unwrap();
    std::fs::write(dir.join("white.png"), white).unwrap();
    std::fs::write(
        dir.join("white.mtl"),
        "newmtl white\nmap_Kd white.png\n\nnewmtl lamp\nKd 0.5 0.5 0.5\nKe 1 1 1\n",
    )
    .unwrap();
    let obj = std::fs::read_to_string(&path)
        .unwrap()
        .replace("floor.mtl", "white.mtl")
        .replace("usemtl tiles", "usemtl white");
    std::fs::write(dir.join("white.obj"), obj).unwrap();
    let scene = lrr_precompute::scene::load(&dir.join("white.obj")).unwrap();
    let white = scene.materials.iter().find(|m| m.name == "white").unwrap();
    assert_eq!(white.reflectance, [0.99; 3]);
    assert!(
        scene.warnings.iter().any(|w| w.contains("clamped to 0.99")),
        "{:?}",
        scene.warnings
    );
}

#[test]
fn an_override_replaces_the_texture_and_a_missing_texcoord_falls_back_to_the_mean() {
    let dir = temp_dir("gltf-texture-override");
    std::fs::write(dir.join("floor.glb"), textured_floor(5126).glb()).unwrap();
    let toml = "name = \"tiles\"\n[[include]]\ngltf = \"floor.glb\"\n\
                [[material_override]]\nname = \"tiles\"\nreflectance = [0.3, 0.3, 0.3]\n";
    std::fs::write(dir.join("scene.toml"), toml).unwrap();
    let out = dir.join("scene.lrr");
    bake(
        &dir.join("scene.toml"),
        &out,
        &["--element-size", "0.25", "--patch-size", "1"],
    )
    .unwrap();
    let file = lrr_formats::OperatorFile::read(&out).unwrap();
    assert_eq!(file.channels, 1, "a grey override leaves a grey scene");
    for (_, rho) in baked_floor(&file) {
        assert!((rho[0] - 0.3).abs() < 1e-7, "{rho:?}");
    }
    // Without TEXCOORD_0 the material's mean applies, and a warning says so.
    let mut root: Value = serde_json::from_str(&textured_floor(5126).gltf()).unwrap();
    root["meshes"][0]["primitives"][0]["attributes"]
        .as_object_mut()
        .unwrap()
        .remove("TEXCOORD_0");
    let path = dir.join("no-uv.gltf");
    std::fs::write(&path, root.to_string()).unwrap();
    let scene = lrr_precompute::scene::load(&path).unwrap();
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("no TEXCOORD_0") && w.contains("mean")),
        "{:?}",
        scene.warnings
    );
    let out = dir.join("no-uv.lrr");
    bake(
        &path,
        &out,
        &["--element-size", "0.25", "--patch-size", "1"],
    )
    .unwrap();
    let file = lrr_formats::OperatorFile::read(&out).unwrap();
    let material = scene.materials.iter().find(|m| m.name == "tiles").unwrap();
    for (_, rho) in baked_floor(&file) {
        for k in 0..3 {
            assert!((rho[k] - material.reflectance[k]).abs() < 1e-7, "{rho:?}");
        }
    }
}

#[test]
fn bad_texture_coordinates_are_refused_with_the_accessor_named() {
    let import = |root: Value| {
        lrr_precompute::scene::gltf::import(
            root.to_string().as_bytes(),
            std::path::Path::new("."),
            "floor",
            "floor.gltf",
        )
        .map(|_| ())
        .expect_err("accepted bad texture coordinates")
        .to_string()
    };
    let root = || -> Value { serde_json::from_str(&textured_floor(5126).gltf()).unwrap() };
    let uv = 1; // the TEXCOORD_0 accessor (after the floor's positions)
    let mut wrong_type = root();
    wrong_type["accessors"][uv]["type"] = json!("VEC3");
    let mut short = root();
    short["accessors"][uv]["count"] = json!(3);
    // A NaN coordinate, written as the float it is.
    let mut b = textured_floor(5126);
    let nan = texcoords(
        &mut b,
        &[[0.0, 1.0], [f64::NAN, 1.0], [1.0, 0.0], [0.0, 0.0]],
        5126,
    );
    let mut not_finite: Value = serde_json::from_str(&b.gltf()).unwrap();
    not_finite["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(nan);
    for (root, parts) in [
        (
            wrong_type,
            &["TEXCOORD_0", "accessor 1", "VEC2 of FLOAT"][..],
        ),
        (short, &["TEXCOORD_0", "3 elements for 4 positions"][..]),
        (
            not_finite,
            &["TEXCOORD_0", "coordinate 1", "not finite"][..],
        ),
    ] {
        let e = import(root);
        for p in parts {
            assert!(e.contains(p), "error lacks '{p}': {e}");
        }
        assert!(e.starts_with("floor.gltf"), "{e}");
    }
}

/// An image is planned from the size its header declares before it is decoded (16 bytes a
/// texel): a 2048 × 2048 PNG of one grey (tens of kB of file) plans 64 MiB beside the file's
/// own, so at 32 MiB the bake is refused in one line naming the image, not left to allocate;
/// within the default limit it bakes.
#[test]
fn an_image_too_large_for_the_memory_is_refused_before_it_is_decoded() {
    let dir = temp_dir("gltf-texture-memory");
    let side = 2048u32;
    let mut png = Vec::new();
    image::ImageEncoder::write_image(
        image::codecs::png::PngEncoder::new(&mut png),
        &vec![128u8; (3 * side * side) as usize],
        side,
        side,
        image::ColorType::Rgb8,
    )
    .unwrap();
    assert!(png.len() < 1 << 20, "{} bytes", png.len());
    let path = dir.join("floor.glb");
    std::fs::write(&path, textured_floor_with(5126, &png).glb()).unwrap();
    let out = dir.join("floor.lrr");
    let err = bake(&path, &out, &["--max-memory", "32M"]).unwrap_err();
    assert!(
        err.contains("decoding ")
            && err.contains("image 0 (2048×2048 texels) needs about ")
            && err.contains("but only 32.0 MiB can be used")
            && err.contains("use a smaller image"),
        "{err}"
    );
    assert!(!out.exists());
    bake(&path, &out, &FLOOR_BAKE).unwrap();
    assert!(out.exists());
}

/// The textured floor as `gltfpack` writes it (`KHR_mesh_quantization`): positions as
/// UNSIGNED_SHORT integers (padded to 8 bytes a vertex) scaled back by the node, texture
/// coordinates as UNSIGNED_SHORT integers scaled back by the texture's `KHR_texture_transform`;
/// `rotated` stores `(1 − v, u)` instead, turned back by a quarter turn and an offset, and
/// gives the same integers as `TEXCOORD_1`.
fn quantised_floor(rotated: bool) -> Builder {
    let mut b = textured_floor(5126);
    let q = 1024.0; // a power of two: the scales are exact
    let corners = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
    let mut bytes = Vec::new();
    for [x, y] in corners {
        for c in [x * q, y * q, 0.0, 0.0] {
            bytes.extend_from_slice(&(c as u16).to_le_bytes());
        }
    }
    let view = b.view(&bytes, Some(8));
    let pos = b.accessor(
        json!({"bufferView": view, "componentType": 5123, "count": 4,
        "type": "VEC3", "min": [0, 0, 0], "max": [2.0 * q, 2.0 * q, 0]}),
    );
    let uv = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
    let stored = uv.map(|[u, v]| if rotated { [1.0 - v, u] } else { [u, v] });
    let bytes: Vec<u8> = (stored.iter().flatten())
        .flat_map(|t| ((t * q) as u16).to_le_bytes())
        .collect();
    let view = b.view(&bytes, None);
    let uv = b.accessor(
        json!({"bufferView": view, "componentType": 5123, "count": 4,
        "type": "VEC2"}),
    );
    let transform = if rotated {
        json!({"offset": [0.0, 1.0], "rotation": std::f64::consts::FRAC_PI_2,
            "scale": [1.0 / q, 1.0 / q]})
    } else {
        json!({"scale": [1.0 / q, 1.0 / q]})
    };
    let doc = &mut b.doc;
    doc["meshes"][0]["primitives"][0]["attributes"] = if rotated {
        // The same integers as TEXCOORD_1: no transform scales lightmap coordinates back.
        json!({"POSITION": pos, "TEXCOORD_0": uv, "TEXCOORD_1": uv})
    } else {
        json!({"POSITION": pos, "TEXCOORD_0": uv})
    };
    doc["nodes"][0]["scale"] = json!([1.0 / q, 1.0 / q, 1.0 / q]);
    doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"] =
        json!({"KHR_texture_transform": transform});
    let used = json!(["KHR_mesh_quantization", "KHR_texture_transform"]);
    doc.insert("extensionsUsed".into(), used.clone());
    doc.insert("extensionsRequired".into(), used);
    b
}

#[test]
fn a_quantised_floor_with_a_texture_transform_bakes_as_the_float_one() {
    let dir = temp_dir("gltf-quantised");
    let float = lrr_precompute::scene::load(&{
        let path = dir.join("float.glb");
        std::fs::write(&path, textured_floor(5126).glb()).unwrap();
        path
    })
    .unwrap();
    for rotated in [false, true] {
        let path = dir.join(format!("quantised-{rotated}.glb"));
        std::fs::write(&path, quantised_floor(rotated).glb()).unwrap();
        let scene = lrr_precompute::scene::load(&path).unwrap();
        if rotated {
            // Integer lightmap coordinates are left out, with a warning: the bake charts them.
            assert_eq!(scene.warnings.len(), 1, "{:?}", scene.warnings);
            assert!(scene.warnings[0].contains("TEXCOORD_1 holds unnormalised integers"));
            assert!(scene.faces.iter().all(|f| f.uv[1].is_none()));
        } else {
            assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
        }
        // The same floor, corner for corner.
        assert_eq!(scene.faces.len(), float.faces.len());
        for (f, g) in scene.faces.iter().zip(&float.faces) {
            for (p, q) in f.polygon.vertices().iter().zip(g.polygon.vertices()) {
                assert!((*p - *q).length() < 1e-12, "{p} against {q}");
            }
        }
        // Each element the mean of its texels: the texture read where the float file reads it
        // (a quarter turn the wrong way, or none, would put other blocks under the elements).
        let out = dir.join(format!("quantised-{rotated}.lrr"));
        bake(&path, &out, &FLOOR_BAKE).unwrap();
        let material = scene.materials.iter().find(|m| m.name == "tiles").unwrap();
        check_blocks(&out, material.reflectance);
    }
}
