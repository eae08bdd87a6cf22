//! From a bake to the operator file (lrr-formats): the sections, the metadata JSON, the light
//! groups, the stored precision and layout, written atomically.

use std::path::Path;

use lrr_formats::{Geometry, Layout, OperatorData, OperatorFile, Precision, StoredMatrix};

use serde::Serialize;

use crate::bake::Baked;
use crate::error::Result;
use crate::patches::{Mesh, PatchMethod};

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
        metadata_json: metadata_json(b),
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
    /// Number format of the stored matrix (f32 or f16).
    pub precision: Precision,
    /// Factored (`F_k` + cores) or the plain per-channel `Y_k`.
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
pub(crate) fn stored_file(b: &Baked, storage: Storage) -> Result<OperatorFile> {
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

/// What the file's metadata section holds (JSON). Only deterministic values: no timings, no
/// thread count, so the same inputs give the same bytes.
#[derive(Debug, Serialize)]
pub(crate) struct Metadata<'a> {
    pub generator: String,
    pub scene: &'a str,
    pub method: &'a str,
    /// 2MSC only: `--threshold` and the `A_min` used (absent for 2MF, whose files stay as
    /// they were before 2MSC existed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub threshold: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_patch_area: Option<f64>,
    pub element_size: f64,
    pub patch_size: f64,
    pub samples: u32,
    pub visibility: &'a str,
    pub condition: &'a [f64],
    /// Per named surface: ranges `[start, end)` of original element ids.
    pub surfaces: Vec<SurfaceRanges>,
}

/// The elements of one named surface, as ranges of original element ids.
#[derive(Debug, Clone, Serialize, serde::Deserialize, PartialEq)]
pub struct SurfaceRanges {
    /// Surface name.
    pub name: String,
    /// Half-open ranges `[first, end)` of original element ids.
    pub elements: Vec<[u32; 2]>,
}

/// The metadata section's JSON ([`Metadata`]).
pub(crate) fn metadata_json(b: &Baked) -> String {
    let refinement = match b.method {
        PatchMethod::TwoFixed => None,
        PatchMethod::SpatialCoherence {
            threshold,
            min_patch_area,
        } => crate::patches::refinement(b.sizes, threshold, min_patch_area).ok(),
    };
    let meta = Metadata {
        generator: format!("lrr {}", env!("CARGO_PKG_VERSION")),
        scene: &b.scene_name,
        method: b.method.name(),
        threshold: refinement.map(|r| r.threshold),
        min_patch_area: refinement.map(|r| r.min_patch_area),
        element_size: b.sizes.element_size,
        patch_size: b.sizes.patch_size,
        samples: b.samples,
        visibility: b.visibility,
        condition: &b.cores.condition,
        surfaces: surface_ranges(&b.mesh, &b.surfaces),
    };
    serde_json::to_string(&meta).expect("metadata serialises")
}

/// Ranges of original element ids per surface (elements of a face are consecutive ids).
pub(crate) fn surface_ranges(mesh: &Mesh, surfaces: &[String]) -> Vec<SurfaceRanges> {
    let mut out: Vec<SurfaceRanges> = surfaces
        .iter()
        .map(|s| SurfaceRanges {
            name: s.clone(),
            elements: Vec::new(),
        })
        .collect();
    for (id, e) in mesh.elements.iter().enumerate() {
        let ranges = &mut out[e.surface as usize].elements;
        let id = id as u32;
        match ranges.last_mut() {
            Some(r) if r[1] == id => r[1] = id + 1,
            _ => ranges.push([id, id + 1]),
        }
    }
    out
}
