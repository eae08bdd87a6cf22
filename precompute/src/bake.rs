//! The bake pipeline: mesh → visibility → form factors → operator, with timings.
//!
//! Stages and their names in the report: `mesh`, `visibility` (BVH build), `form factors`,
//! `operator` (k×k cores). Everything runs inside a rayon pool of `--threads` threads; the
//! results do not depend on that number (see [`crate::formfactor`]), and faer runs
//! sequentially, so the same inputs give the same bytes.

use serde::Serialize;

use crate::checkpoint::{self, Checkpoint};
use crate::error::{Error, Result};
use crate::formfactor::kernel::Polygon;
use crate::formfactor::{FormFactors, Target};
use crate::memory;
use crate::mesh::{Mesh, MeshSizes, PatchMethod};
use crate::operator::{Cores, OperatorInputs, build_cores};
use crate::progress::Progress;
use crate::scene::Scene;
use crate::visibility::{Occluder, nothing_occludes, obvhs::ObvhsOccluder};

/// Default quadrature/visibility samples per element-patch pair.
pub const DEFAULT_SAMPLES: u32 = 16;

/// What a bake may be told.
#[derive(Debug, Clone, PartialEq)]
pub struct BakeSettings {
    pub element_size: Option<f64>,
    pub patch_size: Option<f64>,
    /// How patches are built (2MF or 2MSC).
    pub method: PatchMethod,
    pub samples: u32,
    pub threads: Option<usize>,
    /// Refuse jobs whose working memory would exceed this many bytes (default: 80% of what
    /// the machine has available).
    pub max_memory: Option<u64>,
    /// Where and how to checkpoint the form-factor stage (bake only).
    pub checkpoint: Option<CheckpointSettings>,
}

/// Checkpointing of the form-factor rows.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckpointSettings {
    pub path: std::path::PathBuf,
    /// Continue from an existing checkpoint instead of starting over.
    pub resume: bool,
    /// Rows per checkpoint block (default: about 10⁶ element-patch-sample triples).
    pub block_rows: Option<usize>,
}

impl Default for BakeSettings {
    fn default() -> Self {
        Self {
            element_size: None,
            patch_size: None,
            method: PatchMethod::TwoFixed,
            samples: DEFAULT_SAMPLES,
            threads: None,
            max_memory: None,
            checkpoint: None,
        }
    }
}

/// Runs `f` in a rayon pool of `threads` threads (all cores when `None`), with faer sequential.
pub fn with_threads<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> Result<T> {
    faer::set_global_parallelism(faer::Par::Seq);
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(t) = threads {
        if t == 0 {
            return Err(Error::Settings("--threads must be at least 1".into()));
        }
        builder = builder.num_threads(t);
    }
    let pool = builder
        .build()
        .map_err(|e| Error::Settings(format!("cannot start {threads:?} threads: {e}")))?;
    Ok(pool.install(f))
}

/// A meshed scene with its visibility structure: what every command that integrates form
/// factors starts from.
pub struct Prepared<'s> {
    pub scene: &'s Scene,
    pub sizes: MeshSizes,
    pub method: PatchMethod,
    pub mesh: Mesh,
    pub occluder: Option<ObvhsOccluder>,
}

impl<'s> Prepared<'s> {
    /// Builds the BVH unless nothing can occlude, and meshes the scene (2MSC probes
    /// visibility while it meshes, so the BVH comes first).
    pub fn new(
        scene: &'s Scene,
        sizes: MeshSizes,
        method: PatchMethod,
        progress: &Progress,
    ) -> Result<Self> {
        if let PatchMethod::SpatialCoherence {
            threshold,
            min_patch_area,
        } = method
        {
            // Refuse bad parameters before the BVH is built.
            crate::mesh::refinement(sizes, threshold, min_patch_area)?;
        }
        let stage = progress.stage("visibility", 0);
        let occluder = if nothing_occludes(scene) {
            None
        } else {
            Some(ObvhsOccluder::build(scene))
        };
        stage.finish();
        let stage = progress.stage("mesh", 0);
        let mesh = Mesh::build(
            scene,
            sizes,
            method,
            occluder.as_ref().map(|o| o as &dyn Occluder),
        )?;
        stage.finish();
        Ok(Self {
            scene,
            sizes,
            method,
            mesh,
            occluder,
        })
    }

    pub fn form_factors(&self, samples: u32) -> FormFactors<'_> {
        FormFactors::new(samples, self.occluder.as_ref().map(|o| o as &dyn Occluder))
    }

    /// Name of the visibility method used.
    pub fn visibility_name(&self) -> &'static str {
        if self.occluder.is_some() {
            "obvhs"
        } else {
            "none (nothing occludes)"
        }
    }

    /// `F_k`: element-to-patch form factors, n×k row-major in file order, computed in blocks
    /// of rows that are checkpointed when `checkpoint` is given. Returns the open checkpoint,
    /// which the caller removes once the output is safely written.
    pub fn element_patch_matrix(
        &self,
        ff: &FormFactors,
        progress: &Progress,
        max_memory: Option<u64>,
        checkpoint: Option<&CheckpointSettings>,
    ) -> Result<(Vec<f64>, Option<Checkpoint>)> {
        let (n, k) = (self.mesh.n(), self.mesh.k());
        let bytes = (n as u128) * (k as u128) * 12;
        memory::check_with(
            bytes,
            max_memory,
            "the element-to-patch matrix",
            "use a larger --element-size or --patch-size",
        )?;
        let rows: Vec<Polygon> = (0..n).map(|s| self.mesh.element_at(s).polygon).collect();
        let targets: Vec<Target> = self.mesh.patches.iter().map(|p| p.shape.clone()).collect();
        let mut fk = vec![0.0; n * k];
        let stage = progress.stage("form factors", n as u64);
        let block_rows = checkpoint
            .and_then(|c| c.block_rows)
            .unwrap_or_else(|| (1usize << 20) / (k.max(1) * ff.samples as usize))
            .clamp(1, n.max(1));
        let blocks = n.div_ceil(block_rows);
        let mut done = vec![false; blocks];
        let mut file = None;
        if let Some(c) = checkpoint {
            let shape = checkpoint::Shape {
                key: self.key(ff.samples),
                n: n as u64,
                k: k as u64,
                block_rows: block_rows as u64,
            };
            file = Some(if c.resume {
                let (f, saved) = Checkpoint::resume(&c.path, shape)?;
                for (b, values) in saved {
                    let b = b as usize;
                    fk[b * block_rows * k..b * block_rows * k + values.len()]
                        .copy_from_slice(&values);
                    done[b] = true;
                    stage.inc((values.len() / k.max(1)) as u64);
                }
                f
            } else {
                Checkpoint::create(&c.path, shape)?
            });
        }
        for b in (0..blocks).filter(|&b| !done[b]) {
            let (r0, r1) = (b * block_rows, ((b + 1) * block_rows).min(n));
            let out = &mut fk[r0 * k..r1 * k];
            ff.matrix(
                &rows[r0..r1],
                &self.mesh.order[r0..r1],
                &targets,
                out,
                &|i| stage.inc(i),
            );
            if let Some(f) = &mut file {
                f.append(b as u64, out)?;
            }
        }
        stage.finish();
        Ok((fk, file))
    }

    /// Key of everything `F_k` depends on, for checkpoints.
    pub fn key(&self, samples: u32) -> u64 {
        let mut geometry = Vec::with_capacity(self.scene.faces.len() * 4 * 24);
        for f in &self.scene.faces {
            for v in f.polygon.vertices() {
                for c in v.to_array() {
                    geometry.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
        let sizes = [
            self.sizes.element_size.to_le_bytes(),
            self.sizes.patch_size.to_le_bytes(),
        ]
        .concat();
        let counts = [
            self.mesh.n() as u64,
            self.mesh.k() as u64,
            u64::from(samples),
        ]
        .map(u64::to_le_bytes)
        .concat();
        let method = match self.method {
            PatchMethod::TwoFixed => b"2mf".to_vec(),
            PatchMethod::SpatialCoherence {
                threshold,
                min_patch_area,
            } => [
                b"2msc".to_vec(),
                threshold.to_le_bytes().to_vec(),
                min_patch_area.unwrap_or(-1.0).to_le_bytes().to_vec(),
            ]
            .concat(),
        };
        checkpoint::key(&[
            &geometry,
            &sizes,
            &counts,
            &method,
            env!("CARGO_PKG_VERSION").as_bytes(),
        ])
    }

    /// Reflectance and emission of each element, in original id order.
    pub fn element_materials(&self) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
        self.mesh
            .elements
            .iter()
            .map(|e| {
                let m = &self.scene.materials[self.scene.faces[e.face as usize].material];
                (m.reflectance, m.emission)
            })
            .unzip()
    }
}

/// The result of a bake, in file order.
pub struct Baked {
    pub scene_name: String,
    pub sizes: MeshSizes,
    pub method: PatchMethod,
    pub samples: u32,
    pub visibility: &'static str,
    pub mesh: Mesh,
    pub fk: Vec<f64>,
    pub cores: Cores,
    pub reflectance: Vec<[f64; 3]>,
    pub emission: Vec<[f64; 3]>,
    pub surfaces: Vec<String>,
    pub rays: u64,
    pub culled_pairs: u64,
    /// The form-factor checkpoint, to remove once the output is written.
    pub checkpoint: Option<Checkpoint>,
}

/// Bakes a scene: the whole pipeline up to the k×k cores.
pub fn bake(scene: &Scene, settings: &BakeSettings, progress: &Progress) -> Result<Baked> {
    if settings.samples == 0 {
        return Err(Error::Settings("--samples must be at least 1".into()));
    }
    let sizes = MeshSizes::resolve(scene, settings.element_size, settings.patch_size)?;
    with_threads(settings.threads, || {
        let prepared = Prepared::new(scene, sizes, settings.method, progress)?;
        let ff = prepared.form_factors(settings.samples);
        let (fk, checkpoint) = prepared.element_patch_matrix(
            &ff,
            progress,
            settings.max_memory,
            settings.checkpoint.as_ref(),
        )?;
        let (rho, emission) = prepared.element_materials();
        let order = &prepared.mesh.order;
        let reflectance: Vec<[f64; 3]> = order.iter().map(|&e| rho[e as usize]).collect();
        let emission: Vec<[f64; 3]> = order.iter().map(|&e| emission[e as usize]).collect();
        let channels = if scene.is_grey() { 1 } else { 3 };
        let stage = progress.stage("operator", 0);
        let cores = build_cores(&OperatorInputs {
            fk: &fk,
            weights: &prepared.mesh.weights,
            index: &prepared.mesh.index,
            reflectance: &reflectance,
            channels,
        })?;
        stage.finish();
        let (_, culled, rays) = ff.stats.get();
        let visibility = prepared.visibility_name();
        Ok(Baked {
            scene_name: scene.name.clone(),
            sizes,
            method: settings.method,
            samples: settings.samples,
            visibility,
            mesh: prepared.mesh,
            fk,
            cores,
            reflectance,
            emission,
            surfaces: scene.surfaces.clone(),
            rays,
            culled_pairs: culled,
            checkpoint,
        })
    })?
}

/// What the file's metadata section holds (JSON). Only deterministic values: no timings, no
/// thread count, so the same inputs give the same bytes.
#[derive(Debug, Serialize)]
pub struct Metadata<'a> {
    pub generator: String,
    pub scene: &'a str,
    pub method: &'a str,
    pub element_size: f64,
    pub patch_size: f64,
    pub samples: u32,
    pub visibility: &'a str,
    pub condition: &'a [f64],
    /// Per named surface: ranges `[start, end)` of original element ids.
    pub surfaces: Vec<SurfaceRanges>,
}

#[derive(Debug, Clone, Serialize, serde::Deserialize, PartialEq)]
pub struct SurfaceRanges {
    pub name: String,
    pub elements: Vec<[u32; 2]>,
}

impl Baked {
    pub fn n(&self) -> usize {
        self.mesh.n()
    }
    pub fn k(&self) -> usize {
        self.mesh.k()
    }

    /// Largest per-channel condition number.
    pub fn condition(&self) -> f64 {
        self.cores.condition.iter().copied().fold(0.0, f64::max)
    }

    /// Original element id ranges of each named surface.
    pub fn surface_ranges(&self) -> Vec<SurfaceRanges> {
        surface_ranges(&self.mesh, &self.surfaces)
    }

    pub fn metadata_json(&self) -> String {
        let meta = Metadata {
            generator: format!("lrr {}", env!("CARGO_PKG_VERSION")),
            scene: &self.scene_name,
            method: self.method.name(),
            element_size: self.sizes.element_size,
            patch_size: self.sizes.patch_size,
            samples: self.samples,
            visibility: self.visibility,
            condition: &self.cores.condition,
            surfaces: self.surface_ranges(),
        };
        serde_json::to_string(&meta).expect("metadata serialises")
    }
}

/// Ranges of original element ids per surface (elements of a face are consecutive ids).
pub fn surface_ranges(mesh: &Mesh, surfaces: &[String]) -> Vec<SurfaceRanges> {
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
