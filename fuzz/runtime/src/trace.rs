//! The body of the `trace_mutated` target, shared with the replay test (included by
//! `tests/tests/e2e/fuzz_replay.rs` like `operators.rs`): a valid file with every section the
//! ray tracer reads (display geometry, or display faces, a BVH, materials of every kind, point
//! lights, a camera),
//! edited as [`super::operators::mutate_from`] reads the fuzzer's bytes, then loaded, turned
//! into a [`Tracer`] and rendered at a few pixels. Refusals are fine at every step; a panic, or
//! a render of a checked tracer that fails, is the bug.

use lrr_formats::{
    Camera, Display, Faces, Layout, Material, Materials, OperatorFile, PointLight, Precision,
};
use lrr_runtime::testkit;
use lrr_runtime::trace::{Lighting, Tracer, View};

use super::operators;

/// A valid file for the tracer. `variant` bit 0: 16 elements instead of 64; bit 1: binary16
/// `F_k`; bit 2: the second light follows a light group; bit 3: every element drawn through
/// display faces (section FACES, format 1.4), its quad as two triangles cut along the other
/// diagonal than GEOMETRY's fan.
pub fn display_file(variant: u8) -> Vec<u8> {
    let n = if variant & 1 != 0 { 16 } else { 64 };
    let precision = if variant & 2 != 0 {
        Precision::F16
    } else {
        Precision::F32
    };
    let mut file = testkit::synthetic::file(n, 4, 3, precision, Layout::Factored, 7)
        .expect("a valid synthetic file");
    let base = Material::diffuse("diffuse", [0.5; 3]);
    let materials = vec![
        base.clone(),
        Material {
            name: "mirror".into(),
            mirror: [0.8; 3],
            ..base.clone()
        },
        Material {
            name: "glass".into(),
            mirror: [0.1; 3],
            transmission: [0.9; 3],
            ior: 1.5,
            ..base.clone()
        },
        Material {
            name: "shiny".into(),
            specular: [0.5; 3],
            shininess: 20.0,
            ..base
        },
    ];
    let light = |name: &str, position, group| PointLight {
        name: name.into(),
        position,
        intensity: [1.0; 3],
        group,
    };
    let group = if variant & 4 != 0 && !file.lights.is_empty() {
        0
    } else {
        PointLight::FIXED
    };
    file.display = Display {
        materials: Some(Materials {
            materials,
            element_material: (0..n as u32).map(|e| e % 4).collect(),
        }),
        point_lights: vec![
            light("top", [4.0, 4.0, 3.0], PointLight::FIXED),
            light("side", [0.5, 2.0, 1.0], group),
        ],
        cameras: vec![Camera {
            name: "top".into(),
            eye: [4.0, 2.0, 6.0],
            target: [4.0, 2.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_y_deg: 70.0,
        }],
        bvh: Some(testkit::bvh::build(&file.geometry)),
        ..Display::default()
    };
    if variant & 8 != 0 {
        let g = &file.geometry;
        let mut faces = Faces::default();
        for e in 0..n {
            for corners in [[1, 2, 3], [3, 0, 1]] {
                faces.element.push(e as u32);
                faces.geometry.vertex_count.push(3);
                for c in corners {
                    faces.geometry.vertices.extend(g.vertex(e, c));
                }
                faces.geometry.vertices.extend([0.0; 3]);
                faces.geometry.normals.extend(g.normal(e));
            }
        }
        file.display.bvh = Some(testkit::bvh::build(&faces.geometry));
        file.display.faces = Some(faces);
    }
    file.to_bytes().expect("the base file encodes")
}

/// `trace_mutated`: true when the edited file was accepted and rendered.
pub fn trace_mutated(data: &[u8]) -> bool {
    let bytes = operators::mutate_from(data, display_file);
    let Ok(file) = OperatorFile::from_bytes(&bytes) else {
        return false;
    };
    let Ok(mut tracer) = Tracer::new(&file) else {
        return false;
    };
    // A file without SMOOTH weights refuses smooth shading; either way flat works.
    let _ = tracer.set_smooth(true);
    tracer
        .set_smooth(false)
        .expect("flat shading needs nothing from the file");
    let cameras = file.display.cameras.clone();
    let radiosity = vec![[0.5f32; 3]; file.n as usize];
    let groups = vec![1.0f32; file.lights.len()];
    let lighting = Lighting {
        radiosity: &radiosity,
        group_intensities: &groups,
        direct: None,
    };
    let mut rendered = false;
    for camera in cameras.iter().take(2) {
        let Ok(view) = View::new(camera, 6, 4) else {
            continue;
        };
        if let Err(e) = tracer.render(&view, &lighting, 6, 4, 1) {
            panic!("a checked tracer refuses a frame of the right sizes: {e}");
        }
        rendered = true;
    }
    rendered
}
