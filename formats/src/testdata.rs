//! A small valid operator for unit tests (tests/corrupt.rs keeps its own copy: it sees only the
//! public API).

use crate::display::{Bvh, BvhNode, Camera, Display, Material, Materials, PointLight, Smooth};
use crate::file::{OperatorData, OperatorFile, Precision, StoredMatrix};
use crate::geometry::{Faces, Geometry};
use crate::half::f32_to_f16;

/// n = 6 elements in k = 2 patches of 3; elements 1, 3 are triangles, the others quads.
pub(crate) fn sample(precision: Precision, channels: u32) -> OperatorFile {
    let fk = [0.1, 0.2, 0.0, 0.0, 0.1, 0.2, 0.3, 0.25, 0.0, 0.0, 0.0, 0.05];
    let mut vertices = Vec::new();
    let mut vertex_count = Vec::new();
    for e in 0..6u8 {
        let x = f32::from(e);
        let quad = e % 2 == 0;
        vertex_count.push(if quad { 4 } else { 3 });
        vertices.extend([x, 0.0, 0.0, x + 1.0, 0.0, 0.0, x + 1.0, 1.0, 0.0]);
        vertices.extend(if quad { [x, 1.0, 0.0] } else { [0.0; 3] });
    }
    OperatorFile {
        metadata_json: r#"{"scene":"unit test","bake":{"k":2}}"#.to_string(),
        n: 6,
        k: 2,
        channels,
        precision,
        order: vec![3, 0, 5, 1, 4, 2],
        index: vec![0, 3, 6],
        weights: vec![0.5, 0.25, 0.25, 0.2, 0.3, 0.5],
        operator: OperatorData::Factored {
            fk: match precision {
                Precision::F32 => StoredMatrix::F32(fk.to_vec()),
                Precision::F16 => StoredMatrix::F16(fk.iter().map(|&v| f32_to_f16(v)).collect()),
            },
            cores: (0..channels * 4)
                .map(|i| 1.0 + f64::from(i) / 8.0)
                .collect(),
        },
        reflectance: (0..18).map(|i| i as f32 / 20.0).collect(),
        emission: (0..18).map(|i| if i < 3 { 5.0 } else { 0.0 }).collect(),
        geometry: Geometry {
            vertex_count,
            vertices,
            normals: [0.0, 0.0, 1.0].repeat(6),
        },
        lights: Vec::new(),
        display: Default::default(),
    }
}

/// The same elements in the plain layout, `channels` blocks of made-up `Y_k` values.
pub(crate) fn plain_sample(precision: Precision, channels: u32) -> OperatorFile {
    let yk: Vec<f32> = (0..channels * 12).map(|i| -(i as f32) / 64.0).collect();
    OperatorFile {
        channels,
        precision,
        operator: OperatorData::PlainYk {
            yk: StoredMatrix::from_f32(&yk, precision),
        },
        ..sample(precision, channels)
    }
}

/// [`sample`] (f32, RGB) with a light group "lamp" and every display section: smooth vertices at
/// the shared corners (elements side by side along x), materials "white" and "glass", point
/// lights "key" (group 0) and "fill" (fixed), cameras "front" and "top", and a BVH of 5 nodes
/// over the 9 display triangles.
pub(crate) fn display_sample() -> OperatorFile {
    let mut f = sample(Precision::F32, 3);
    let lamp = f.light_group("lamp", vec![0], vec![5.0; 3]).unwrap();
    f.lights.push(lamp);
    let smooth = smooth_by_position(&f.geometry, |e| e as u32);
    let glass = Material {
        specular: [0.5; 3],
        shininess: 20.0,
        mirror: [0.1, 0.1, 0.1],
        transmission: [0.9, 0.95, 1.0],
        ior: 1.5,
        ..Material::diffuse("glass", [0.05; 3])
    };
    let node = |min: [f32; 3], max: [f32; 3], first, count| BvhNode {
        min,
        max,
        first,
        count,
    };
    f.display = Display {
        smooth: Some(smooth),
        materials: Some(Materials {
            materials: vec![Material::diffuse("white", [0.7; 3]), glass],
            element_material: vec![0, 0, 1, 0, 0, 1],
        }),
        point_lights: vec![
            PointLight {
                name: "key".into(),
                position: [3.0, 0.5, 2.0],
                intensity: [10.0, 9.0, 8.0],
                group: 0,
            },
            PointLight {
                name: "fill".into(),
                position: [-1.0, 0.5, 2.0],
                intensity: [1.0; 3],
                group: PointLight::FIXED,
            },
        ],
        cameras: vec![
            Camera {
                name: "front".into(),
                eye: [3.0, 0.5, 5.0],
                target: [3.0, 0.5, 0.0],
                up: [0.0, 1.0, 0.0],
                fov_y_deg: 45.0,
            },
            Camera {
                name: "top".into(),
                eye: [3.0, 5.0, 0.5],
                target: [3.0, 0.0, 0.5],
                up: [0.0, 0.0, -1.0],
                fov_y_deg: 60.0,
            },
        ],
        // Elements 0-2 (triangles 0-4) left, 3 (triangle 5) and 4-5 (triangles 6-8) right.
        bvh: Some(Bvh {
            nodes: vec![
                node([0.0; 3], [6.0, 1.0, 0.0], 1, 0),
                node([0.0; 3], [3.0, 1.0, 0.0], 0, 5),
                node([3.0, 0.0, 0.0], [6.0, 1.0, 0.0], 3, 0),
                node([3.0, 0.0, 0.0], [4.0, 1.0, 0.0], 5, 1),
                node([4.0, 0.0, 0.0], [6.0, 1.0, 0.0], 6, 3),
            ],
            triangles: vec![4, 3, 2, 1, 0, 5, 6, 7, 8],
        }),
        lightmap: None,
        faces: None,
        direct_lights: Vec::new(),
        sky_transfer: None,
    };
    f
}

/// Smooth weights over the polygons of `g` (the elements' or the faces' of a strip along x in
/// z = 0 with corners at integer points): corner `(x, y)` is smooth vertex `x + 7 y`, the mean of
/// the elements (`element(polygon)`, each once) that have a corner there.
fn smooth_by_position(g: &Geometry, element: impl Fn(usize) -> u32) -> Smooth {
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); 14];
    let mut corners = Vec::new();
    for (p, &count) in g.vertex_count.iter().enumerate() {
        for j in 0..4 {
            if j >= usize::from(count) {
                corners.push(Smooth::NONE);
                continue;
            }
            let [x, y, _] = g.vertex(p, j);
            let v = x as u32 + 7 * y as u32;
            if !members[v as usize].contains(&element(p)) {
                members[v as usize].push(element(p));
            }
            corners.push(v);
        }
    }
    let mut smooth = Smooth {
        corners,
        offsets: vec![0],
        ..Smooth::default()
    };
    for m in &members {
        smooth.positions.extend(m);
        smooth
            .weights
            .extend(m.iter().map(|_| 1.0 / m.len() as f32));
        smooth.offsets.push(smooth.positions.len() as u32);
    }
    smooth
}

/// [`display_sample`] drawn through display faces (section FACES, format 1.4): each quad
/// element as two triangles cut along its other diagonal (`v1 v2 v3`, `v3 v0 v1`), each
/// triangle as itself: 9 faces whose 9 fan triangles the same BVH holds (faces in element
/// order), SMOOTH on the faces' corners.
pub(crate) fn faces_sample() -> OperatorFile {
    let mut f = display_sample();
    let g = &f.geometry;
    let mut faces = Faces::default();
    for e in 0..g.len() {
        let polygons: &[[usize; 3]] = if g.vertex_count[e] == 4 {
            &[[1, 2, 3], [3, 0, 1]]
        } else {
            &[[0, 1, 2]]
        };
        for corners in polygons {
            faces.element.push(e as u32);
            faces.geometry.vertex_count.push(3);
            for &c in corners {
                faces.geometry.vertices.extend(g.vertex(e, c));
            }
            faces.geometry.vertices.extend([0.0; 3]);
            faces.geometry.normals.extend(g.normal(e));
        }
    }
    let element = faces.element.clone();
    f.display.smooth = Some(smooth_by_position(&faces.geometry, |p| element[p]));
    f.display.faces = Some(faces);
    f
}
