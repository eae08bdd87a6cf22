//! From a bake to the operator file (lrr-formats): the sections, the metadata JSON, the light
//! groups, the stored precision and layout, written atomically.

use std::path::Path;

use lrr_formats::{Display, Geometry, Layout, OperatorData, OperatorFile, Precision, StoredMatrix};

use serde::Serialize;

use crate::bake::Baked;
use crate::cores::Cores;
use crate::error::Result;
use crate::mesh::MeshSizes;
use crate::patches::{Mesh, PatchMethod};
pub use crate::storage::{Storage, WRITE_BYTES_PER_ELEMENT, write_bytes};

/// Everything an operator file holds but `F_k` and the cores, in file order: what a bake
/// writes around its matrix, and what every shard of a sharded bake carries to the merge
/// (`crate::shard`), so that both go through the same code to the same bytes.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Skeleton {
    pub scene_name: String,
    /// `PatchMethod::name`.
    pub method: String,
    /// 2MSC: the threshold and the `A_min` used.
    pub refinement: Option<[f64; 2]>,
    /// `--refine`: the budget and the elements split.
    pub refine: Option<(f64, usize)>,
    pub element_size: f64,
    pub patch_size: f64,
    pub samples: u32,
    pub visibility: String,
    /// Surface names, indexed by `Element::surface`.
    pub surfaces: Vec<String>,
    /// Per surface: ranges of original element ids (the metadata's `surfaces`).
    pub surface_ranges: Vec<SurfaceRanges>,
    /// Channels of the cores: 1 for a grey scene, else 3.
    pub channels: usize,
    pub order: Vec<u32>,
    pub index: Vec<u32>,
    /// Per file position: `w = A_e / A_p`.
    pub weights: Vec<f64>,
    /// Per file position: RGB reflectance.
    pub reflectance: Vec<[f64; 3]>,
    /// Per file position: RGB emitted exitance.
    pub emission: Vec<[f64; 3]>,
    /// Per file position: the element's surface.
    pub surface_at: Vec<u32>,
    /// Per file position: the element's polygon and normal, in f32.
    pub geometry: Geometry,
    /// The display sections (format 1.2: materials, point lights, cameras, BVH).
    pub display: Display,
}

/// What a [`Skeleton`] is cut from (a finished bake, or a shard's meshes).
pub(crate) struct SkeletonInputs<'a> {
    pub scene_name: &'a str,
    pub sizes: MeshSizes,
    pub method: PatchMethod,
    pub samples: u32,
    pub visibility: &'a str,
    pub mesh: &'a Mesh,
    /// Per file position.
    pub reflectance: &'a [[f64; 3]],
    /// Per file position.
    pub emission: &'a [[f64; 3]],
    pub surfaces: &'a [String],
    pub channels: usize,
    /// From `display::build`.
    pub display: &'a Display,
    /// `--refine`'s budget (the elements split are in the mesh's report).
    pub refine: Option<f64>,
}

impl Skeleton {
    pub(crate) fn new(i: &SkeletonInputs) -> Self {
        let n = i.mesh.n();
        let refinement = match i.method {
            PatchMethod::TwoFixed => None,
            PatchMethod::SpatialCoherence {
                threshold,
                min_patch_area,
                rule,
            } => crate::patches::refinement(i.sizes, threshold, min_patch_area, rule)
                .ok()
                .map(|r| [r.threshold, r.min_patch_area]),
        };
        Self {
            scene_name: i.scene_name.to_string(),
            method: i.method.name().to_string(),
            refinement,
            refine: i.refine.map(|b| (b, i.mesh.meshing.refined)),
            element_size: i.sizes.element_size,
            patch_size: i.sizes.patch_size,
            samples: i.samples,
            visibility: i.visibility.to_string(),
            surfaces: i.surfaces.to_vec(),
            surface_ranges: surface_ranges(i.mesh, i.surfaces),
            channels: i.channels,
            order: i.mesh.order.clone(),
            index: i.mesh.index.clone(),
            weights: i.mesh.weights.clone(),
            reflectance: i.reflectance.to_vec(),
            emission: i.emission.to_vec(),
            surface_at: (0..n).map(|s| i.mesh.element_at(s).surface).collect(),
            geometry: crate::display::geometry(i.mesh),
            display: i.display.clone(),
        }
    }

    /// The skeleton of a finished bake.
    pub(crate) fn of(b: &Baked) -> Self {
        Self::new(&SkeletonInputs {
            scene_name: &b.scene_name,
            sizes: b.sizes,
            method: b.method,
            samples: b.samples,
            visibility: b.visibility,
            mesh: &b.mesh,
            reflectance: &b.reflectance,
            emission: &b.emission,
            surfaces: &b.surfaces,
            channels: b.cores.channels,
            display: &b.display,
            refine: b.refine,
        })
    }

    /// Number of elements.
    pub(crate) fn n(&self) -> usize {
        self.order.len()
    }

    /// Number of patches.
    pub(crate) fn k(&self) -> usize {
        self.index.len().saturating_sub(1)
    }

    /// The operator file with this `F_k` (f32, or empty for a streamed write) and cores, in
    /// f32, without light groups (the display's point lights name them: add them with
    /// [`add_light_groups`](Self::add_light_groups) before the file is validated).
    pub(crate) fn file(&self, fk: StoredMatrix, cores: &Cores) -> OperatorFile {
        OperatorFile {
            order: self.order.clone(),
            index: self.index.clone(),
            geometry: self.geometry.clone(),
            display: self.display.clone(),
            ..self.bare_file(fk, cores)
        }
    }

    /// [`file`](Self::file), its largest parts (the order, the index, the geometry and the
    /// display) moved out of `self` rather than copied.
    fn take_file(&mut self, fk: StoredMatrix, cores: &Cores) -> OperatorFile {
        let file = self.bare_file(fk, cores);
        OperatorFile {
            order: std::mem::take(&mut self.order),
            index: std::mem::take(&mut self.index),
            geometry: std::mem::take(&mut self.geometry),
            display: std::mem::take(&mut self.display),
            ..file
        }
    }

    /// [`file`](Self::file) without the order, the index, the geometry and the display.
    fn bare_file(&self, fk: StoredMatrix, cores: &Cores) -> OperatorFile {
        let flat = |v: &[[f64; 3]]| {
            v.iter()
                .flat_map(|x| x.map(|c| c as f32))
                .collect::<Vec<f32>>()
        };
        OperatorFile {
            metadata_json: self.metadata_json(&cores.condition),
            n: self.n() as u32,
            k: self.k() as u32,
            channels: cores.channels as u32,
            precision: fk.precision(),
            order: Vec::new(),
            index: Vec::new(),
            weights: self.weights.iter().map(|&w| w as f32).collect(),
            operator: OperatorData::Factored {
                fk,
                cores: cores.m.clone(),
            },
            reflectance: flat(&self.reflectance),
            emission: flat(&self.emission),
            geometry: Geometry::default(),
            lights: Vec::new(),
            display: Display::default(),
        }
    }

    /// The operator file stored as asked ([`stored_file`]), made from `self`.
    fn into_stored(
        mut self,
        fk: StoredMatrix,
        cores: &Cores,
        storage: Storage,
    ) -> Result<OperatorFile> {
        let mut file = self.take_file(fk, cores);
        self.add_light_groups(&mut file)?;
        drop(self);
        if storage.precision != file.precision {
            store_matrix_as(&mut file, storage.precision);
        }
        if storage.layout == Layout::PlainYk {
            file = file.into_plain_yk(0)?;
        }
        Ok(file)
    }

    /// The metadata section's JSON ([`Metadata`]).
    fn metadata_json(&self, condition: &[f64]) -> String {
        let meta = Metadata {
            generator: format!("lrr {}", env!("CARGO_PKG_VERSION")),
            scene: &self.scene_name,
            method: &self.method,
            threshold: self.refinement.map(|r| r[0]),
            min_patch_area: self.refinement.map(|r| r[1]),
            refine: self.refine.map(|r| r.0),
            refined_elements: self.refine.map(|r| r.1),
            element_size: self.element_size,
            patch_size: self.patch_size,
            samples: self.samples,
            visibility: &self.visibility,
            condition,
            surfaces: self.surface_ranges.clone(),
        };
        serde_json::to_string(&meta).expect("metadata serialises")
    }

    /// Adds one light group per emitting surface (named after the surface; its elements at
    /// their baked emission).
    pub(crate) fn add_light_groups(&self, file: &mut OperatorFile) -> Result<()> {
        // One pass over the elements, collecting emitters per surface.
        let mut members: Vec<(Vec<u32>, Vec<f32>)> =
            vec![(Vec::new(), Vec::new()); self.surfaces.len()];
        for (s, e) in self.emission.iter().enumerate() {
            if e.iter().any(|&x| x > 0.0) {
                let (positions, emission) = &mut members[self.surface_at[s] as usize];
                positions.push(s as u32);
                emission.extend(e.map(|x| x as f32));
            }
        }
        for (name, (positions, emission)) in self.surfaces.iter().zip(members) {
            if !positions.is_empty() {
                let group = file.light_group(name.clone(), positions, emission)?;
                file.lights.push(group);
            }
        }
        Ok(())
    }
}

/// Assembles the operator file of a bake (elements in file order, `F_k` in f32, factored) with
/// its light groups, as [`write`] stores it by default.
pub fn operator_file(b: &Baked) -> Result<OperatorFile> {
    stored_file(b, Storage::default())
}

/// `F_k` as the file stores it before any change of precision: f32.
pub(crate) fn f32_matrix(fk: &[f64]) -> StoredMatrix {
    StoredMatrix::F32(fk.iter().map(|&f| f as f32).collect())
}

/// The operator file of a bake stored as asked, with one light group per emitting surface
/// (named after the surface; its elements at their baked emission).
pub(crate) fn stored_file(b: &Baked, storage: Storage) -> Result<OperatorFile> {
    stored_file_with(b, f32_matrix(&b.fk), storage)
}

/// [`stored_file`] with `F_k` given in f32 (`fk`, file order).
fn stored_file_with(b: &Baked, fk: StoredMatrix, storage: Storage) -> Result<OperatorFile> {
    Skeleton::of(b).into_stored(fk, &b.cores, storage)
}

/// Stores a factored file's `F_k` in `precision` (rounding once from its current values).
pub fn store_matrix_as(file: &mut OperatorFile, precision: Precision) {
    if let OperatorData::Factored { fk, .. } = &mut file.operator {
        let stored = match &*fk {
            StoredMatrix::F32(v) => StoredMatrix::from_f32(v, precision),
            other => StoredMatrix::from_f32(&other.to_f32(), precision),
        };
        *fk = stored;
    }
    file.precision = precision;
}

/// Writes the bake's operator file atomically (temporary file + rename) and returns it. The
/// bake's `F_k` in f64 is released as its f32 copy is made ([`into_f32`]; `b.fk` is empty
/// after), its display moves into the file (`b.display` is empty after), and the file is
/// encoded section by section as it is written, its `F_k` in pieces
/// ([`OperatorFile::write`]): the write stage holds about what the bake held, not copies of
/// the matrix or of the display. [`write_bytes`] plans it.
pub fn write(b: &mut Baked, path: &Path, storage: Storage) -> Result<OperatorFile> {
    let fk = into_f32(std::mem::take(&mut b.fk));
    let display = std::mem::take(&mut b.display);
    let mut skeleton = Skeleton::of(b);
    skeleton.display = display;
    let file = skeleton.into_stored(StoredMatrix::F32(fk), &b.cores, storage)?;
    file.write(path)?;
    Ok(file)
}

/// `fk` rounded to f32 (as [`f32_matrix`]), made from the end in sixteenths, each sixteenth of
/// the f64 values released once converted: the output's pages are touched only as they are
/// written, so the two vectors are never both resident in full (about 8 bytes per value at the
/// most, not 12).
pub(crate) fn into_f32(mut fk: Vec<f64>) -> Vec<f32> {
    let n = fk.len();
    let mut out = vec![0.0f32; n];
    let step = n.div_ceil(16).max(1 << 16);
    let mut end = n;
    while end > 0 {
        let start = end.saturating_sub(step);
        for (o, &x) in out[start..end].iter_mut().zip(&fk[start..end]) {
            *o = x as f32;
        }
        fk.truncate(start);
        fk.shrink_to_fit();
        end = start;
    }
    out
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
    /// `--refine` only: its budget and the elements it split (absent otherwise, so unrefined
    /// files stay as they were).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refine: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refined_elements: Option<usize>,
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

#[cfg(test)]
mod into_f32_tests {
    #[test]
    fn into_f32_rounds_as_f32_matrix() {
        for n in [0usize, 1, 5, (1 << 16) + 3, 40 * (1 << 16) + 7] {
            let fk: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin() / 3.0).collect();
            let want = super::f32_matrix(&fk);
            assert_eq!(super::StoredMatrix::F32(super::into_f32(fk)), want, "{n}");
        }
    }
}
