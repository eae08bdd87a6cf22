//! Shared by the integration tests: small valid operators and tools to damage their bytes.
//!
//! `src/testdata.rs` holds the unit tests' copy of `sample` (these tests see only the public API).

#![allow(dead_code)] // each test binary uses a different part

use lrr_formats::{
    ALIGN, Bvh, BvhNode, Camera, Container, ContainerWriter, Display, Faces, Geometry,
    HEADER_CHECKSUM_OFFSET, HEADER_LEN, Material, Materials, OperatorData, OperatorFile,
    PointLight, Precision, SECTION_ENTRY_LEN, Smooth, StoredMatrix, checksum,
};

/// n = 6 elements in k = 2 patches; elements 1, 3, 5 are triangles, the others quads.
pub fn sample(precision: Precision, channels: u32) -> OperatorFile {
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
        metadata_json: r#"{"scene":"corrupt test","bake":{"k":2}}"#.to_string(),
        n: 6,
        k: 2,
        channels,
        precision,
        order: vec![3, 0, 5, 1, 4, 2],
        index: vec![0, 3, 6],
        weights: vec![0.5, 0.25, 0.25, 0.2, 0.3, 0.5],
        operator: OperatorData::Factored {
            fk: StoredMatrix::from_f32(&fk, precision),
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

/// `sample` in the plain layout (made-up `Y_k` of either sign).
pub fn plain_sample(precision: Precision, channels: u32) -> OperatorFile {
    let yk: Vec<f32> = (0..channels * 12)
        .map(|i| (i as f32 - 7.0) / 64.0)
        .collect();
    OperatorFile {
        operator: OperatorData::PlainYk {
            yk: StoredMatrix::from_f32(&yk, precision),
        },
        ..sample(precision, channels)
    }
}

/// Two light groups on `file` (one of two positions, one of one).
pub fn with_lights(mut file: OperatorFile) -> OperatorFile {
    let lamp = file.light_group("lamp", vec![1, 4], vec![1.0, 2.0, 3.0, 0.5, 0.5, 0.0]);
    let sun = file.light_group("sun ☀", vec![5], vec![4.0, 4.0, 3.5]);
    file.lights = vec![lamp.unwrap(), sun.unwrap()];
    file
}

/// Every display section (format 1.2) on `file` (the elements of `sample`, light groups as
/// `with_lights`): smooth vertices at shared corners, two materials, a point light following
/// group 1 and a fixed one, one camera and a BVH of three nodes over the 9 display triangles.
pub fn with_display(mut file: OperatorFile) -> OperatorFile {
    let smooth = smooth_by_position(&file.geometry, |e| e as u32);
    let mirror = Material {
        mirror: [0.8, 0.85, 0.9],
        specular: [0.2; 3],
        shininess: 50.0,
        ..Material::diffuse("mirror ✨", [0.1; 3])
    };
    let node = |min, max, first, count| BvhNode {
        min,
        max,
        first,
        count,
    };
    file.display = Display {
        smooth: Some(smooth),
        materials: Some(Materials {
            materials: vec![Material::diffuse("wall", [0.5; 3]), mirror],
            element_material: vec![1, 0, 0, 0, 0, 1],
        }),
        point_lights: vec![
            PointLight {
                name: "bulb".into(),
                position: [1.0, 2.0, 3.0],
                intensity: [4.0, 4.0, 4.0],
                group: 1,
            },
            PointLight {
                name: String::new(),
                position: [-1.0, 2.0, 3.0],
                intensity: [0.5, 0.0, 0.25],
                group: PointLight::FIXED,
            },
        ],
        cameras: vec![Camera {
            name: String::new(),
            eye: [3.0, 0.5, 4.0],
            target: [3.0, 0.5, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_y_deg: 40.0,
        }],
        bvh: Some(Bvh {
            nodes: vec![
                node([0.0; 3], [6.0, 1.0, 0.0], 1, 0),
                node([0.0; 3], [3.0, 1.0, 0.0], 0, 5),
                node([3.0, 0.0, 0.0], [6.0, 1.0, 0.0], 5, 4),
            ],
            triangles: vec![0, 1, 2, 3, 4, 8, 7, 6, 5],
        }),
        lightmap: None,
        faces: None,
        direct_lights: Vec::new(),
        sky_transfer: None,
    };
    file
}

/// Smooth weights over the polygons of `g` (a strip of unit elements along x, or their faces):
/// corner `(x, y)` is smooth vertex `x + 7 y`, the mean of the elements (`element(polygon)`, each
/// once) with a corner there.
pub fn smooth_by_position(g: &Geometry, element: impl Fn(usize) -> u32) -> Smooth {
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); 14];
    let mut corners = Vec::new();
    for (p, &count) in g.vertex_count.iter().enumerate() {
        for j in 0..4 {
            let at = p * 12 + j * 3;
            let (x, y) = (g.vertices[at], g.vertices[at + 1]);
            let v = x as u32 + 7 * y as u32;
            if j < usize::from(count) {
                if !members[v as usize].contains(&element(p)) {
                    members[v as usize].push(element(p));
                }
                corners.push(v);
            } else {
                corners.push(Smooth::NONE);
            }
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

/// `file` (with the display sections of `with_display`) drawn through display faces (section
/// FACES, format 1.4): each quad element as two triangles cut along its other diagonal, each
/// triangle element as itself (9 faces, in element order, so the same BVH holds their 9 fan
/// triangles), SMOOTH on the faces' corners.
pub fn with_faces(mut file: OperatorFile) -> OperatorFile {
    let g = &file.geometry;
    let mut faces = Faces::default();
    for e in 0..g.vertex_count.len() {
        let polygons: &[[usize; 3]] = if g.vertex_count[e] == 4 {
            &[[1, 2, 3], [3, 0, 1]]
        } else {
            &[[0, 1, 2]]
        };
        for corners in polygons {
            faces.element.push(e as u32);
            faces.geometry.vertex_count.push(3);
            for &c in corners {
                faces
                    .geometry
                    .vertices
                    .extend(&g.vertices[e * 12 + c * 3..e * 12 + c * 3 + 3]);
            }
            faces.geometry.vertices.extend([0.0; 3]);
            faces.geometry.normals.extend(&g.normals[e * 3..e * 3 + 3]);
        }
    }
    let element = faces.element.clone();
    file.display.smooth = Some(smooth_by_position(&faces.geometry, |p| element[p]));
    file.display.faces = Some(faces);
    file
}

/// Every kind of file: f32 RGB factored with light groups, f16 grey factored, f16 RGB plain with
/// light groups, f32 grey plain, f32 RGB factored with light groups and every display section of
/// format 1.2, and the same drawn through display faces (format 1.4).
pub fn samples() -> [OperatorFile; 6] {
    [
        with_lights(sample(Precision::F32, 3)),
        sample(Precision::F16, 1),
        with_lights(plain_sample(Precision::F16, 3)),
        plain_sample(Precision::F32, 1),
        with_display(with_lights(sample(Precision::F32, 3))),
        with_faces(with_display(with_lights(sample(Precision::F32, 3)))),
    ]
}

/// The display sections of format 1.2, in the order they are written.
pub const DISPLAY_KINDS: [u32; 5] = [
    lrr_formats::kind::SMOOTH,
    lrr_formats::kind::MATERIALS,
    lrr_formats::kind::POINT_LIGHTS,
    lrr_formats::kind::CAMERAS,
    lrr_formats::kind::BVH,
];

pub fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap())
}

/// End of the padded section table.
pub fn table_end(bytes: &[u8]) -> usize {
    let count = u32_at(bytes, 12) as usize;
    HEADER_LEN + (count * SECTION_ENTRY_LEN).next_multiple_of(ALIGN)
}

/// Recomputes the header checksum after a deliberate edit of the header or the table.
pub fn reseal(bytes: &mut [u8]) {
    let end = table_end(bytes).min(bytes.len());
    let mut head = bytes[..end].to_vec();
    head[HEADER_CHECKSUM_OFFSET..HEADER_CHECKSUM_OFFSET + 8].fill(0);
    let sum = checksum(&head);
    bytes[HEADER_CHECKSUM_OFFSET..HEADER_CHECKSUM_OFFSET + 8].copy_from_slice(&sum.to_le_bytes());
}

/// Byte position of field `field` (0 kind, 4 flags, 8 offset, 16 length, 24 checksum) of entry `i`.
pub fn entry_at(i: usize, field: usize) -> usize {
    HEADER_LEN + i * SECTION_ENTRY_LEN + field
}

/// Sets a u64 field of a table entry and reseals the header.
pub fn set_entry_u64(bytes: &mut [u8], i: usize, field: usize, value: u64) {
    let at = entry_at(i, field);
    bytes[at..at + 8].copy_from_slice(&value.to_le_bytes());
    reseal(bytes);
}

/// Index of the table entry of `kind`.
pub fn entry_of(bytes: &[u8], kind: u32) -> usize {
    (0..u32_at(bytes, 12) as usize)
        .find(|&i| u32_at(bytes, entry_at(i, 0)) == kind)
        .unwrap()
}

/// Rebuilds a valid container after `edit` changed payloads: checksums match again, so only the
/// decoder and the validator stand between the damage and the caller.
pub fn rebuild(bytes: &[u8], mut edit: impl FnMut(u32, &mut Vec<u8>)) -> Vec<u8> {
    let c = Container::parse(bytes).unwrap();
    let mut w = ContainerWriter::new();
    for s in c.sections() {
        let mut payload = c.section(s.kind).unwrap().to_vec();
        edit(s.kind, &mut payload);
        w.add(s.kind, s.required(), payload);
    }
    w.to_bytes()
}

/// Sets little-endian u32 word `i` of the payload of `kind`, checksums recomputed.
pub fn with_word(bytes: &[u8], kind: u32, i: usize, value: u32) -> Vec<u8> {
    rebuild(bytes, |k, p| {
        if k == kind {
            p[4 * i..4 * i + 4].copy_from_slice(&value.to_le_bytes());
        }
    })
}

/// A small deterministic generator (xorshift64*).
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}
