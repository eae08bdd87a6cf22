//! The scene description as a build step: a glTF include, material overrides, light groups,
//! cameras, point lights and `[bake]` settings, baked by `lrr bake scene.toml` alone; explicit
//! flags win; bad keys and values are errors that name them.

use crate::gltf::room;
use crate::util::{lrr, temp_dir};
use lrr_formats::{OperatorFile, Precision};
use lrr_precompute::scene::description::SceneDescription;

/// The room glTF (scale 2) plus a lamp of the description's own, grouped with the glTF lamp.
const SCENE: &str = r#"
name = "room build"
scale = 2.0

[[material]]
name = "tube"
reflectance = [0.5, 0.5, 0.5]
radiance = [2.0, 2.0, 2.0]
specular = [0.2, 0.2, 0.2]
shininess = 40

[[surface]]
name = "tube"
material = "tube"
polygons = [[[-0.5, 0.5, 0.9], [-0.5, 0.75, 0.9], [0.5, 0.75, 0.9], [0.5, 0.5, 0.9]]]

[[include]]
gltf = "room.glb"

[[material_override]]
name = "steel"
mirror = [0.3, 0.3, 0.3]
reflectance = [0.4, 0.4, 0.4]

[[light_group]]
name = "ceiling"
materials = ["lamp"]
surfaces = ["tube"]

[[camera]]
name = "door"
eye = [0, -0.9, 0.5]
target = [0, 0, 0.5]
up = [0, 0, 1]
fov_y_deg = 60

[[point_light]]
name = "desk"
position = [0.5, 0.5, 0.3]
colour = [1.0, 0.5, 0.5]
power = 12.566370614359172
group = "ceiling"

[bake]
output = "out/room.lrr"
element_size = 0.25
patch_size = 1.0
method = "2msc"
samples = 4
precision = "f16"
"#;

fn setup() -> std::path::PathBuf {
    let dir = temp_dir("description");
    std::fs::write(dir.join("room.glb"), room().glb()).unwrap();
    std::fs::create_dir_all(dir.join("out")).unwrap();
    let path = dir.join("scene.toml");
    std::fs::write(&path, SCENE).unwrap();
    path
}

#[test]
fn description_builds_the_scene_it_describes() {
    let path = setup();
    let s = lrr_precompute::scene::load(&path).unwrap();
    // Scale 2 applies to the include: the floor is 4 × 4.
    let floor: f64 = s
        .faces
        .iter()
        .filter(|f| s.surfaces[f.surface] == "floor")
        .map(|f| f.polygon.area())
        .sum();
    assert!((floor - 16.0).abs() < 1e-9, "{floor}");
    // The emitting faces of material 'lamp' and surface 'tube' are one surface 'ceiling'; the
    // surfaces they left are gone.
    let emitters: Vec<&str> = s
        .faces
        .iter()
        .filter(|f| s.materials[f.material].emission.iter().any(|&e| e > 0.0))
        .map(|f| s.surfaces[f.surface].as_str())
        .collect();
    assert_eq!(emitters.len(), 3, "{emitters:?}");
    assert!(emitters.iter().all(|e| *e == "ceiling"));
    assert!(!s.surfaces.iter().any(|x| x == "lamp" || x == "tube"));
    // Overrides: the included steel's mirror and reflectance; the own material's optics.
    let steel = s.materials.iter().find(|m| m.name == "steel").unwrap();
    assert_eq!(steel.optics.mirror, [0.3; 3]);
    assert_eq!(steel.reflectance, [0.4; 3]);
    let tube = s.materials.iter().find(|m| m.name == "tube").unwrap();
    assert_eq!(tube.optics.specular, [0.2; 3]);
    assert_eq!(tube.optics.shininess, 40.0);
    // Cameras: the glTF's (scaled), then the description's (scaled).
    let names: Vec<&str> = s.cameras.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["main", "door"]);
    assert!(
        (s.cameras[0].eye[1] + 6.0).abs() < 1e-6,
        "{:?}",
        s.cameras[0]
    );
    assert_eq!(s.cameras[1].eye, [0.0, -1.8, 1.0]);
    // Point lights: power 4π W of colour (1, .5, .5) is intensity (1, .5, .5) W/sr.
    let desk = s.point_lights.iter().find(|l| l.name == "desk").unwrap();
    assert_eq!(desk.position, [1.0, 1.0, 0.6]);
    for (a, b) in desk.intensity.iter().zip([1.0, 0.5, 0.5]) {
        assert!((a - b).abs() < 1e-12, "{:?}", desk.intensity);
    }
    assert_eq!(desk.group.as_deref(), Some("ceiling"));
    let bulb = s.point_lights.iter().find(|l| l.name == "bulb").unwrap();
    assert!((bulb.position[2] - 1.6).abs() < 1e-6);
    // [bake]: sizes scaled into scene units, the rest as written, the output beside the file.
    assert_eq!(s.hints.element_size, Some(0.5));
    assert_eq!(s.hints.patch_size, Some(2.0));
    assert_eq!(s.bake.method.as_deref(), Some("2msc"));
    assert_eq!(s.bake.samples, Some(4));
    assert_eq!(
        s.bake.output.as_deref(),
        Some(path.parent().unwrap().join("out/room.lrr").as_path())
    );
}

#[test]
fn lrr_bake_takes_its_settings_from_the_description_and_flags_win() {
    let path = setup();
    let dir = path.parent().unwrap();
    let text = lrr(&["bake", path.to_str().unwrap(), "-q"]).unwrap();
    let out = dir.join("out/room.lrr");
    let f = OperatorFile::read(&out).unwrap();
    assert_eq!(f.precision, Precision::F16, "{text}");
    let meta: serde_json::Value = serde_json::from_str(&f.metadata_json).unwrap();
    assert_eq!(meta["method"], "2msc", "{meta}");
    assert_eq!(meta["samples"], 4, "{meta}");
    assert_eq!(meta["element_size"], 0.5, "{meta}");
    let groups: Vec<&str> = f.lights.iter().map(|g| g.name.as_str()).collect();
    assert_eq!(groups, ["ceiling"]);
    // Explicit flags win over [bake].
    let other = dir.join("other.lrr");
    lrr(&[
        "bake",
        path.to_str().unwrap(),
        "-q",
        "-o",
        other.to_str().unwrap(),
        "--precision",
        "f32",
        "--method",
        "2mf",
        "--samples",
        "1",
    ])
    .unwrap();
    let g = OperatorFile::read(&other).unwrap();
    assert_eq!(g.precision, Precision::F32);
    let meta: serde_json::Value = serde_json::from_str(&g.metadata_json).unwrap();
    assert_eq!(meta["method"], "2mf", "{meta}");
    assert_eq!(meta["samples"], 1, "{meta}");
    // Same fine mesh either way (the mesh does not depend on the patch method).
    assert_eq!(f.n, g.n);
    // Without [bake] output and without -o: an error saying how to fix it.
    let bare = dir.join("bare.toml");
    std::fs::write(&bare, SCENE.replace("output = \"out/room.lrr\"\n", "")).unwrap();
    let e = lrr(&["bake", bare.to_str().unwrap(), "-q"]).unwrap_err();
    assert!(e.contains("-o OUT.lrr") && e.contains("[bake]"), "{e}");
}

fn build_err(text: &str) -> String {
    let dir = temp_dir("description-bad");
    std::fs::write(dir.join("room.glb"), room().glb()).unwrap();
    match SceneDescription::parse(text, "bad.toml") {
        Err(e) => e.to_string(),
        Ok(d) => d
            .build("bad.toml", &dir)
            .map(|_| ())
            .expect_err("accepted")
            .to_string(),
    }
}

#[test]
fn bad_descriptions_name_the_key_or_value() {
    let cases: [(&str, &str, &[&str]); 9] = [
        (
            "bake key",
            "[bake]\noutptu = \"x.lrr\"\n",
            &["bad.toml:2", "unknown field `outptu`", "output"],
        ),
        (
            "camera key",
            "[[camera]]\nname = \"c\"\neye = [0,0,0]\ntarget = [1,0,0]\nfov = 40\n",
            &["bad.toml:5", "unknown field `fov`", "fov_y_deg"],
        ),
        (
            "light key",
            "[[point_light]]\nname = \"l\"\nposition = [0,0,0]\nwatts = 3\n",
            &["unknown field `watts`"],
        ),
        (
            "method",
            "[bake]\nmethod = \"3mf\"\n",
            &["method = \"3mf\"", "2mf, 2msc"],
        ),
        (
            "override",
            "[[include]]\ngltf = \"room.glb\"\n[[material_override]]\nname = \"stele\"\nior = 1.5\n",
            &["material_override 'stele'", "'steel'", "'floor'"],
        ),
        (
            "group",
            "[[include]]\ngltf = \"room.glb\"\n[[light_group]]\nname = \"g\"\nmaterials = [\"floor\"]\n",
            &["light_group 'g'", "no emitting face"],
        ),
        (
            "light",
            "[[include]]\ngltf = \"room.glb\"\n[[point_light]]\nname = \"l\"\nposition = [0,0,0]\nintensity = [1,1,1]\npower = 3\n",
            &["point_light 'l'", "either intensity"],
        ),
        (
            "include",
            "[[include]]\nobj = \"a.obj\"\ngltf = \"b.glb\"\n",
            &["include 0", "exactly one"],
        ),
        (
            "mirror",
            "[[material]]\nname = \"m\"\nreflectance = [0.5,0.5,0.5]\nmirror = [0.5, 2, 0]\n",
            &["material 'm'", "mirror", "[0, 1]"],
        ),
    ];
    for (what, text, parts) in cases {
        let e = build_err(text);
        for p in parts {
            assert!(e.contains(p), "{what}: '{p}' missing from: {e}");
        }
    }
    // A glTF include's own error names the glTF file.
    let e = build_err("[[include]]\ngltf = \"missing.glb\"\n");
    assert!(e.contains("missing.glb"), "{e}");
}
