//! A small valid operator for unit tests (tests/corrupt.rs keeps its own copy: it sees only the
//! public API).

use crate::file::{Geometry, OperatorData, OperatorFile, Precision, StoredMatrix};
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
