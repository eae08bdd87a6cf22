//! From a bake to the operator file (lrr-formats), written atomically.

use std::path::Path;

use lrr_formats::{FkData, Geometry, OperatorData, OperatorFile, Precision};

use crate::bake::Baked;
use crate::error::Result;

/// Assembles the operator file of a bake (elements in file order).
pub fn operator_file(b: &Baked) -> OperatorFile {
    let n = b.n();
    let mut geometry = Geometry {
        vertex_count: Vec::with_capacity(n),
        vertices: Vec::with_capacity(n * 12),
        normals: Vec::with_capacity(n * 3),
    };
    for s in 0..n {
        let p = &b.mesh.element_at(s).polygon;
        geometry.vertex_count.push(p.count as u8);
        // Triangles leave their fourth slot zero (Polygon keeps unused slots zeroed).
        for v in &p.vertices {
            geometry
                .vertices
                .extend([v.x as f32, v.y as f32, v.z as f32]);
        }
        geometry
            .normals
            .extend([p.normal.x as f32, p.normal.y as f32, p.normal.z as f32]);
    }
    let flat = |v: &[[f64; 3]]| {
        v.iter()
            .flat_map(|x| x.map(|c| c as f32))
            .collect::<Vec<f32>>()
    };
    OperatorFile {
        metadata_json: b.metadata_json(),
        n: n as u32,
        k: b.k() as u32,
        channels: b.cores.channels as u32,
        precision: Precision::F32,
        order: b.mesh.order.clone(),
        index: b.mesh.index.clone(),
        weights: b.mesh.weights.iter().map(|&w| w as f32).collect(),
        operator: OperatorData::Factored {
            fk: FkData::F32(b.fk.iter().map(|&f| f as f32).collect()),
            cores: b.cores.m.clone(),
        },
        reflectance: flat(&b.reflectance),
        emission: flat(&b.emission),
        geometry,
        lights: Vec::new(),
    }
}

/// Writes the bake's operator file atomically (temporary file + rename).
pub fn write(b: &Baked, path: &Path) -> Result<OperatorFile> {
    let file = operator_file(b);
    file.write(path)?;
    Ok(file)
}
