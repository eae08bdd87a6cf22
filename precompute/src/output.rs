//! From a bake to the operator file (lrr-formats), written atomically.

use std::path::Path;

use lrr_formats::{Geometry, Layout, OperatorData, OperatorFile, Precision, StoredMatrix};

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
            fk: StoredMatrix::F32(b.fk.iter().map(|&f| f as f32).collect()),
            cores: b.cores.m.clone(),
        },
        reflectance: flat(&b.reflectance),
        emission: flat(&b.emission),
        geometry,
        lights: Vec::new(),
    }
}

/// How the operator is stored in the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Storage {
    pub precision: Precision,
    pub layout: Layout,
}

impl Default for Storage {
    fn default() -> Self {
        Self {
            precision: Precision::F32,
            layout: Layout::Factored,
        }
    }
}

/// The operator file of a bake stored as asked, with one light group per emitting surface
/// (named after the surface; its elements at their baked emission).
pub fn stored_file(b: &Baked, storage: Storage) -> Result<OperatorFile> {
    let mut file = operator_file(b);
    add_light_groups(b, &mut file)?;
    if storage.precision != file.precision {
        store_matrix_as(&mut file, storage.precision);
    }
    if storage.layout == Layout::PlainYk {
        file = file.to_plain_yk(0)?;
    }
    Ok(file)
}

fn add_light_groups(b: &Baked, file: &mut OperatorFile) -> Result<()> {
    // One pass over the elements, collecting emitters per surface.
    let mut members: Vec<(Vec<u32>, Vec<f32>)> = vec![(Vec::new(), Vec::new()); b.surfaces.len()];
    for (s, e) in b.emission.iter().enumerate() {
        if e.iter().any(|&x| x > 0.0) {
            let (positions, emission) = &mut members[b.mesh.element_at(s).surface as usize];
            positions.push(s as u32);
            emission.extend(e.map(|x| x as f32));
        }
    }
    for (name, (positions, emission)) in b.surfaces.iter().zip(members) {
        if !positions.is_empty() {
            let group = file.light_group(name.clone(), positions, emission)?;
            file.lights.push(group);
        }
    }
    Ok(())
}

/// Stores a factored file's `F_k` in `precision` (rounding once from its current values).
pub fn store_matrix_as(file: &mut OperatorFile, precision: Precision) {
    if let OperatorData::Factored { fk, .. } = &mut file.operator {
        *fk = StoredMatrix::from_f32(&fk.to_f32(), precision);
    }
    file.precision = precision;
}

/// Writes the bake's operator file atomically (temporary file + rename).
pub fn write(b: &Baked, path: &Path, storage: Storage) -> Result<OperatorFile> {
    let file = stored_file(b, storage)?;
    file.write(path)?;
    Ok(file)
}
