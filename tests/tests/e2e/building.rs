//! The generated building (`lrr scene building`, scenes/building/): the committed files are what
//! the generator writes; the glTF imports with its rooms, light groups, cameras and areas; a
//! coarse bake lights every texel of every lightmap chart and relights through its animation.

use std::path::PathBuf;

use lrr_precompute::scene::Scene;
use lrr_runtime::Operator;

use crate::util::{bake, lrr, root, temp_dir};

/// The committed description.
fn building() -> PathBuf {
    root().join("scenes/building/building.toml")
}

const FILES: [&str; 3] = ["building.toml", "building.glb", "building-animation.toml"];

#[test]
fn the_committed_building_is_what_the_generator_writes() {
    let dir = temp_dir("building-gen");
    let text = lrr(&[
        "scene",
        "building",
        "-o",
        dir.join("building.toml").to_str().unwrap(),
    ])
    .unwrap();
    assert!(text.contains("9 light groups, 3 cameras"), "{text}");
    for name in FILES {
        let shipped = root().join("scenes/building").join(name);
        let shipped = std::fs::read(&shipped).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(
            shipped == std::fs::read(dir.join(name)).unwrap(),
            "scenes/building/{name} is not what the generator writes; run `cargo run --release \
             --bin lrr -- scene building -o scenes/building/building.toml`"
        );
    }
    let e = lrr(&["scene", "building"]).unwrap_err();
    assert!(e.contains("writes three files") && e.contains("-o"), "{e}");
    let e = lrr(&[
        "scene",
        "building",
        "-o",
        dir.join("b.glb").to_str().unwrap(),
    ])
    .unwrap_err();
    assert!(e.contains("name a .toml file"), "{e}");
}

/// Total area of the faces of `surface`.
fn area(scene: &Scene, surface: &str) -> f64 {
    let id = scene
        .surfaces
        .iter()
        .position(|s| s == surface)
        .unwrap_or_else(|| panic!("no surface {surface}: {:?}", scene.surfaces));
    let faces = scene.faces.iter().filter(|f| f.surface == id);
    faces.map(|f| f.polygon.area()).sum()
}

#[test]
fn the_building_imports_with_its_rooms_light_groups_cameras_and_areas() {
    let scene = lrr_precompute::scene::load(&building()).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let rooms = [
        "living", "kitchen", "hall", "study", "bedroom", "bath", "studio", "landing", "guest",
    ];
    for room in rooms {
        for part in ["floor", "ceiling", &format!("wall-{room}")] {
            assert!(
                area(&scene, &format!("{room}/{part}")) > 1.0,
                "{room}/{part}"
            );
        }
        // The light group: every emitting face, one or two 60 cm lamps (120 × 60 in the
        // kitchen and the studio), and nothing else emits under the room's name.
        let lamps = if matches!(room, "living" | "kitchen" | "studio") {
            0.72
        } else {
            0.36
        };
        assert!(
            (area(&scene, room) - lamps).abs() < 1e-6,
            "{room}: {}",
            area(&scene, room)
        );
        let id = scene.surfaces.iter().position(|s| s == room).unwrap();
        for f in scene.faces.iter().filter(|f| f.surface == id) {
            assert_eq!(scene.materials[f.material].name, "lamp");
        }
    }
    let emitting: f64 = scene
        .faces
        .iter()
        .filter(|f| scene.materials[f.material].emission[0] > 0.0)
        .map(|f| f.polygon.area())
        .sum();
    assert!(
        (emitting - (6.0 * 0.36 + 3.0 * 0.72)).abs() < 1e-6,
        "{emitting}"
    );
    let cameras: Vec<&str> = scene.cameras.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(cameras, ["living", "hall", "landing"]);
    // The living room's floor: 4.69 × 7.50 m, less the sofa (0.9 × 2.2), the coffee table
    // (0.9 × 1.0) and the shelf (1.2 × 0.4) standing on it, plus the thresholds of its opening
    // to the kitchen (1.8 × 0.12) and its doorway to the hall (0.9 × 0.12) and the sills of its
    // three windows (1.6, 1.6 and 1.8 m by 0.25).
    let want = 4.69 * 7.5 - 0.9 * 2.2 - 0.9 * 1.0 - 1.2 * 0.4 + 2.7 * 0.12 + 5.0 * 0.25;
    let got = area(&scene, "living/floor");
    assert!(
        (got - want).abs() < 1e-5,
        "living/floor {got} against {want}"
    );
}

#[test]
fn a_coarse_bake_lights_every_lightmap_chart_and_relights_through_the_animation() {
    let dir = temp_dir("building-bake");
    let file = dir.join("coarse.lrr");
    let args = [
        "--element-size",
        "1.0",
        "--patch-size",
        "3.0",
        "--samples",
        "4",
    ];
    let text = bake(&building(), &file, &args).unwrap();
    assert!(text.contains("k = "), "{text}");
    let op = Operator::load(&file).unwrap();
    let groups: Vec<&str> = op.light_groups().collect();
    assert_eq!(groups.len(), 9, "{groups:?}");
    // The bake packed the lightmap (the building has no TEXCOORD_1); every sample of it and
    // every texel dilation fills is lit (every lamp on, as baked).
    let b = op.evaluate_baked();
    let atlas = op.file().display.lightmap.as_ref().unwrap().atlas.unwrap();
    assert_eq!(atlas.source, lrr_formats::LightmapSource::Generated);
    let mut map = lrr_runtime::Lightmap::new(op.file(), None).unwrap();
    assert_eq!(map.values(), lrr_runtime::LightmapValues::Smooth);
    let mut texels = vec![[0.0f32; 3]; map.width() * map.height()];
    map.fill(&b, &mut texels).unwrap();
    let mut lit = 0;
    for s in map.samples() {
        assert!(
            texels[s.texel].iter().sum::<f32>() > 0.0,
            "sample {s:?} is black"
        );
        lit += 1;
    }
    let filled = texels
        .iter()
        .filter(|t| t.iter().sum::<f32>() > 0.0)
        .count();
    assert_eq!(
        filled,
        lit + map.dilated_count(),
        "a dilated texel is black"
    );
    assert!(lit > 100_000, "{lit} texels");
    // The committed animation names the file's groups; its frames render from a camera.
    let anim = root().join("scenes/building/building-animation.toml");
    let frames = dir.join("frames");
    let text = lrr(&[
        "relight",
        file.to_str().unwrap(),
        "--animation",
        anim.to_str().unwrap(),
        "-o",
        frames.to_str().unwrap(),
        "-q",
        "--images",
        "png",
        "--camera",
        "living",
        "--image-size",
        "32x18",
    ])
    .unwrap();
    assert!(
        text.contains("wrote 97 frames (32x18 PNG images)"),
        "{text}"
    );
    assert!(frames.join("frame-00096.png").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}
