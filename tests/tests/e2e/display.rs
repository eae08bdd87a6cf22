//! The display sections a bake writes (format 1.2): materials per element, point lights with
//! their light group, cameras and the BVH; the same bytes on any thread count and through a
//! sharded bake; bad point lights and cameras refused before the form factors.

use lrr_formats::{OperatorFile, PointLight as FilePointLight};
use lrr_precompute::bake::{BakeSettings, bake};
use lrr_precompute::progress::Progress;
use lrr_precompute::scene::{Camera, PointLight, Scene};

use crate::util::{cornell, lrr, temp_dir};

/// The Cornell box with a mirror on the tall block, glass on the short one, two point lights
/// and a camera.
fn dressed_cornell() -> Scene {
    let mut scene = lrr_precompute::scene::load(&cornell()).unwrap();
    let white = scene
        .materials
        .iter()
        .position(|m| m.name == "white")
        .unwrap();
    let mut glass = scene.materials[white].clone();
    glass.name = "glass".into();
    glass.optics.transmission = [0.9, 0.9, 0.9];
    glass.optics.ior = 1.5;
    glass.optics.specular = [0.3; 3];
    glass.optics.shininess = 60.0;
    scene.materials.push(glass);
    let glass = scene.materials.len() - 1;
    let short = scene
        .surfaces
        .iter()
        .position(|s| s == "short-block")
        .unwrap();
    for f in scene.faces.iter_mut().filter(|f| f.surface == short) {
        f.material = glass;
    }
    scene.point_lights = vec![
        PointLight {
            name: "lamp glow".into(),
            position: [278.0, 540.0, 280.0],
            intensity: [1e4, 8e3, 3e3],
            group: Some("light".into()),
        },
        PointLight {
            name: "fixed".into(),
            position: [100.0, 300.0, 100.0],
            intensity: [10.0; 3],
            group: None,
        },
    ];
    scene.cameras = vec![Camera {
        name: "front".into(),
        eye: [278.0, 273.0, -800.0],
        target: [278.0, 273.0, 0.0],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 39.3,
    }];
    scene
}

fn settings(threads: usize) -> BakeSettings {
    BakeSettings {
        element_size: Some(120.0),
        patch_size: Some(300.0),
        samples: 4,
        threads: Some(threads),
        ..BakeSettings::default()
    }
}

fn baked_bytes(scene: &Scene, threads: usize) -> Vec<u8> {
    let baked = bake(scene, &settings(threads), &Progress::hidden()).unwrap();
    lrr_precompute::write::operator_file(&baked)
        .unwrap()
        .to_bytes()
        .unwrap()
}

#[test]
fn a_bake_stores_materials_lights_cameras_and_a_bvh() {
    let scene = dressed_cornell();
    let bytes = baked_bytes(&scene, 2);
    let file = OperatorFile::from_bytes(&bytes).unwrap();
    let d = &file.display;
    // Materials: every scene material, and each element's is its face's.
    let m = d.materials.as_ref().unwrap();
    let names: Vec<&str> = m.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["white", "red", "green", "light", "glass"]);
    assert_eq!(m.materials[4].ior, 1.5);
    assert_eq!(m.materials[4].transmission, [0.9; 3]);
    assert_eq!(m.materials[0].transmission, [0.0; 3]);
    let glass_elements = m.element_material.iter().filter(|&&i| i == 4).count();
    assert!(glass_elements > 0);
    // Point lights: "light" names the emitting surface's group.
    let light_group = file.lights.iter().position(|g| g.name == "light").unwrap() as u32;
    assert_eq!(d.point_lights.len(), 2);
    assert_eq!(d.point_lights[0].group, light_group);
    assert_eq!(d.point_lights[0].name, "lamp glow");
    assert_eq!(d.point_lights[1].group, FilePointLight::FIXED);
    assert_eq!(d.cameras.len(), 1);
    assert_eq!(d.cameras[0].fov_y_deg, 39.3);
    // The BVH covers the fan triangles of the display faces (validated by from_bytes: a tree,
    // every triangle once, boxes holding them).
    let bvh = d.bvh.as_ref().unwrap();
    assert_eq!(bvh.triangles.len(), file.faces().triangle_count());
    assert!(bvh.nodes.len() >= bvh.triangles.len() / 2);
    // Deterministic: the same bytes on one thread.
    assert_eq!(baked_bytes(&scene, 1), bytes);
}

#[test]
fn a_material_name_picks_its_only_emitting_surface() {
    let mut scene = dressed_cornell();
    scene.point_lights[0].group = Some("light".into());
    let via_surface = baked_bytes(&scene, 2);
    // The material "light" is used by the surface "light" alone: the same group.
    let m = scene
        .materials
        .iter()
        .position(|m| m.name == "light")
        .unwrap();
    scene.materials[m].name = "lamp-material".into();
    scene.point_lights[0].group = Some("lamp-material".into());
    let file = OperatorFile::from_bytes(&baked_bytes(&scene, 2)).unwrap();
    let before = OperatorFile::from_bytes(&via_surface).unwrap();
    assert_eq!(
        file.display.point_lights[0].group,
        before.display.point_lights[0].group
    );
}

#[test]
fn bad_point_lights_and_cameras_are_refused_before_the_form_factors() {
    type Edit = fn(&mut Scene);
    let cases: [(Edit, &str); 5] = [
        (
            |s| s.point_lights[0].group = Some("sun".into()),
            "point light 'lamp glow': its group 'sun' is no surface or material of the scene; \
             the light groups are the emitting surfaces: light",
        ),
        (
            |s| s.point_lights[0].group = Some("floor".into()),
            "its group 'floor' is a surface that emits nothing",
        ),
        (
            |s| s.point_lights[1].intensity[2] = -1.0,
            "point light \"fixed\": intensity channel b: value -1",
        ),
        (
            |s| s.cameras[0].up = [0.0, 0.0, 2.0],
            "camera \"front\": up [0.0, 0.0, 2.0] is zero or parallel",
        ),
        (
            |s| s.cameras.push(s.cameras[0].clone()),
            "two cameras are named 'front'",
        ),
    ];
    for (edit, expected) in cases {
        let mut scene = dressed_cornell();
        edit(&mut scene);
        let progress = Progress::hidden();
        let e = bake(&scene, &settings(1), &progress).err().unwrap();
        assert!(
            e.to_string().contains(expected),
            "{e} (expected {expected:?})"
        );
        let stages: Vec<String> = progress.timings().into_iter().map(|t| t.0).collect();
        assert!(!stages.iter().any(|s| s == "form factors"), "{stages:?}");
    }
}

#[test]
fn sharded_bakes_carry_the_display_sections() {
    let dir = temp_dir("display-shards");
    let single = dir.join("single.lrr");
    let scene = cornell();
    let scene = scene.to_str().unwrap();
    let flags = [
        "--element-size",
        "120",
        "--patch-size",
        "300",
        "--samples",
        "4",
    ];
    let mut args = vec!["bake", scene, "-o", single.to_str().unwrap()];
    args.extend(flags);
    lrr(&args).unwrap();
    let mut parts = Vec::new();
    for i in 0..3 {
        let part = dir.join(format!("part-{i}.bin"));
        let shard = format!("{i}/3");
        let mut args = vec![
            "bake",
            scene,
            "--shard",
            &shard,
            "-o",
            part.to_str().unwrap(),
        ];
        args.extend(flags);
        lrr(&args).unwrap();
        parts.push(part.to_str().unwrap().to_string());
    }
    let merged = dir.join("merged.lrr");
    let mut args = vec!["merge", "-o", merged.to_str().unwrap()];
    args.extend(parts.iter().map(String::as_str));
    lrr(&args).unwrap();
    let bytes = std::fs::read(&single).unwrap();
    assert_eq!(std::fs::read(&merged).unwrap(), bytes);
    let file = OperatorFile::from_bytes(&bytes).unwrap();
    assert!(file.display.bvh.is_some() && file.display.materials.is_some());
    std::fs::remove_dir_all(&dir).unwrap();
}
