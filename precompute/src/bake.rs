//! The bake pipeline: mesh → visibility → form factors → operator, with timings.
//!
//! Stages and their names in the report: `mesh`, `visibility` (BVH build), `form factors`,
//! `operator` (k×k cores). Everything runs inside a rayon pool of `--threads` threads; the
//! results do not depend on that number (see [`crate::formfactor`]), and faer runs
//! sequentially, so the same inputs give the same bytes.

use crate::checkpoint::{self, Checkpoint, CheckpointSettings};
use crate::cores::{Cores, OperatorInputs, build_cores};
use crate::error::{Error, Result};
use crate::formfactor::FormFactors;
use crate::formfactor::enclosure::Enclosure;
use crate::mesh::MeshSizes;
use crate::patches::{Mesh, PatchMethod};
use crate::progress::Progress;
use crate::scene::Scene;
use crate::visibility::obvhs::ObvhsOccluder;
use crate::visibility::{Backend, ClosestHit, Occluder, nothing_occludes};

/// Default quadrature/visibility samples per element-patch pair.
pub const DEFAULT_SAMPLES: u32 = 16;

/// What a bake may be told.
#[derive(Debug, Clone, PartialEq)]
pub struct BakeSettings {
    /// Element size in scene units; `None`: the scene's hint, else a fraction of its extent.
    pub element_size: Option<f64>,
    /// Patch size (2MF cut) in scene units; `None`: the scene's hint, else a fraction of its extent.
    pub patch_size: Option<f64>,
    /// How patches are built (2MF or 2MSC).
    pub method: PatchMethod,
    /// Quadrature points and visibility rays per element-patch pair ([`DEFAULT_SAMPLES`]).
    pub samples: u32,
    /// Which backend answers the occlusion queries (`--visibility`).
    pub visibility: Backend,
    /// Threads of the bake's pool; `None`: all cores.
    pub threads: Option<usize>,
    /// Refuse jobs whose working memory would exceed this many bytes (default: 80% of what
    /// the machine has available).
    pub max_memory: Option<u64>,
    /// Where and how to checkpoint the form-factor stage (bake only; with `refine`, the
    /// first pass's rows).
    pub checkpoint: Option<CheckpointSettings>,
    /// Refinement where light changes ([`crate::refine`]): split elements where a first
    /// solve jumps between neighbours, adding at most this share of n; `None`: no refinement.
    pub refine: Option<f64>,
    /// How the operator file will be stored: planned with the other stages, before the form
    /// factors ([`crate::storage::write_bytes`]).
    pub storage: crate::storage::Storage,
}

impl Default for BakeSettings {
    fn default() -> Self {
        Self {
            element_size: None,
            patch_size: None,
            method: PatchMethod::TwoFixed,
            samples: DEFAULT_SAMPLES,
            visibility: Backend::default(),
            threads: None,
            max_memory: None,
            checkpoint: None,
            refine: None,
            storage: crate::storage::Storage::default(),
        }
    }
}

/// Which elements' rows must sum to one ([`Enclosure::probe_each`]), as the stage `stage` of
/// `progress`. The test runs on the default backend's structure whatever answers the segments,
/// so every backend rescales the same rows.
///
/// Planned like the stages that allocate more: an element's counts and mark, and the default
/// backend's BVH where the bake's backend (Embree) has no closest-hit query of its own.
fn enclosure_of(
    scene: &Scene,
    occ: &dyn Occluder,
    mesh: &Mesh,
    (stage, progress, max_memory): (&str, &Progress, Option<u64>),
) -> Result<Enclosure> {
    let n = mesh.elements.len();
    let query = occ.closest_hit();
    let own_bvh = match query {
        Some(_) => 0,
        None => crate::visibility::Backend::Obvhs.build_bytes(scene),
    };
    let bytes = n as u128 * crate::formfactor::enclosure::BYTES_PER_ELEMENT + own_bvh;
    crate::memory::check_then(
        bytes,
        max_memory,
        || format!("the enclosure test ({n} elements)"),
        |_| match own_bvh {
            0 => crate::memory::size_advice() + ", or raise --max-memory",
            _ => "use --visibility obvhs (its BVH answers the test), or simplify the model \
                  (fewer triangles), or raise --max-memory"
                .to_string(),
        },
    )?;
    progress.estimate(stage, bytes);
    let running = progress.stage(stage, 0);
    let own;
    let probe = match query {
        Some(o) => o,
        None => {
            own = ObvhsOccluder::build(scene);
            &own as &dyn ClosestHit
        }
    };
    let enclosure = Enclosure::probe_each(probe, n, |i| mesh.elements[i].on_surface());
    running.finish();
    Ok(enclosure)
}

/// Where [`Prepared::with_mesh`] takes its mesh from.
pub(crate) enum MeshFrom {
    /// Meshing the scene.
    Build,
    /// Meshing it, then refining where light changes ([`crate::refine::refine_mesh`]).
    Refine {
        budget: f64,
        /// The bake's samples per pair (the first pass takes at most these).
        samples: u32,
        /// A whole bake's storage, whose write is checked before the first pass
        /// (`storage::check_memory_unrefined`); none for a shard or a plan, which write no
        /// operator file.
        storage: Option<crate::storage::Storage>,
        /// Where the first pass's rows are checkpointed (`checkpoint::first_pass_path` of the
        /// bake's checkpoint), if the bake checkpoints.
        checkpoint: Option<CheckpointSettings>,
    },
    /// A plan's mesh, made before (refined with this budget, if any).
    Plan {
        mesh: Box<Mesh>,
        refine: Option<f64>,
    },
}

impl MeshFrom {
    /// Meshing, refined when the settings' `refine` is a budget above 0.
    pub(crate) fn meshing(settings: &BakeSettings) -> Self {
        match settings.refine {
            Some(budget) if budget > 0.0 => Self::Refine {
                budget,
                samples: settings.samples,
                storage: None,
                checkpoint: settings.checkpoint.as_ref().map(|c| {
                    let path = checkpoint::first_pass_path(&c.path);
                    CheckpointSettings {
                        path,
                        resume: c.resume,
                        block_rows: c.block_rows,
                    }
                }),
            },
            _ => Self::Build,
        }
    }

    /// [`meshing`](Self::meshing) for a bake that writes the operator file itself.
    pub(crate) fn meshing_to_write(settings: &BakeSettings) -> Self {
        let mut from = Self::meshing(settings);
        if let Self::Refine { storage, .. } = &mut from {
            *storage = Some(settings.storage);
        }
        from
    }
}

/// The file metadata's `visibility`: the backend's name, or none when nothing occludes.
/// Whether a bake of `scene` needs its occluder: unless nothing occludes pairs of faces (a
/// convex enclosure) and no light that is not a surface shines. The convexity shortcut holds
/// for pairs of faces only: a sky, a sun or a point light is blocked by faces that never see
/// each other (the back of a shade over a floor, the walls of a closed box). Bakes, shards and
/// plans decide with this one test, so they name the same visibility.
pub(crate) fn needs_occluder(scene: &Scene) -> bool {
    !nothing_occludes(scene) || !crate::lights::LightsOwned::of(scene).is_empty()
}

fn visibility_name(visibility: Backend, occludes: bool) -> &'static str {
    if occludes {
        visibility.name()
    } else {
        "none (nothing occludes)"
    }
}

/// A meshed scene with its visibility structure: what every command that integrates form
/// factors starts from.
pub struct Prepared<'s> {
    /// The scene the mesh was cut from.
    pub scene: &'s Scene,
    /// Element and patch sizes the mesh was built with, in scene units.
    pub sizes: MeshSizes,
    /// How the patches were built (2MF or 2MSC).
    pub method: PatchMethod,
    /// The fine elements and coarse patches.
    pub mesh: Mesh,
    /// The budget the mesh was refined with where light changes (`None`: not refined).
    pub refine: Option<f64>,
    /// The backend asked for; `occluder` is `None` when nothing can occlude.
    pub visibility: Backend,
    /// The occlusion structure; `None` when nothing in the scene can occlude (no rays are cast).
    pub occluder: Option<Box<dyn Occluder>>,
    /// Which elements' rows must sum to one (`formfactor::enclosure`); `None` when nothing
    /// occludes (then the unoccluded factors already conserve).
    pub enclosure: Option<Enclosure>,
    /// The checkpoint of `--refine`'s first pass, to remove once the output is written.
    pub first_pass_checkpoint: Option<Checkpoint>,
}

impl<'s> Prepared<'s> {
    /// Builds the `visibility` backend's BVH unless nothing can occlude (then no backend is
    /// needed, whichever was asked for), and meshes the scene (2MSC probes visibility while
    /// it meshes, so the BVH comes first).
    pub fn new(
        scene: &'s Scene,
        sizes: MeshSizes,
        method: PatchMethod,
        visibility: Backend,
        progress: &Progress,
    ) -> Result<Self> {
        Self::with_mesh(
            scene,
            sizes,
            method,
            visibility,
            progress,
            None,
            MeshFrom::Build,
        )
    }

    /// [`new`](Self::new), with the mesh refined where light changes (`MeshFrom::Refine`,
    /// [`crate::refine`]) or made before (a sharded bake's plan, `crate::shard`: then only the
    /// BVH is built).
    pub(crate) fn with_mesh(
        scene: &'s Scene,
        sizes: MeshSizes,
        method: PatchMethod,
        visibility: Backend,
        progress: &Progress,
        max_memory: Option<u64>,
        from: MeshFrom,
    ) -> Result<Self> {
        if !visibility.available() {
            // Refuse before any work, even where no ray would be cast: the flag is wrong here.
            visibility.build(scene)?;
        }
        if let PatchMethod::SpatialCoherence {
            threshold,
            min_patch_area,
            rule,
        } = method
        {
            // Refuse bad parameters before the BVH is built.
            crate::patches::refinement(sizes, threshold, min_patch_area, rule)?;
        }
        let stage = progress.stage("visibility", 0);
        let occluder = if !needs_occluder(scene) {
            None
        } else {
            let bytes = visibility.build_bytes(scene);
            crate::memory::check_with(
                bytes,
                max_memory,
                &format!("the occlusion BVH ({} faces)", scene.faces.len()),
                "simplify the model (fewer triangles), or raise --max-memory",
            )?;
            progress.estimate("visibility", bytes);
            Some(visibility.build_within(scene, max_memory)?)
        };
        stage.finish();
        let stage = progress.stage("mesh", 0);
        let (mesh, refine, first_pass_checkpoint) = match from {
            MeshFrom::Plan { mesh, refine } => {
                stage.finish();
                (*mesh, refine, None)
            }
            MeshFrom::Build => {
                let mesh =
                    Mesh::build_within(scene, sizes, method, occluder.as_deref(), max_memory)?;
                progress.estimate("mesh", mesh.meshing.planned_bytes);
                stage.finish();
                (mesh, None, None)
            }
            MeshFrom::Refine {
                budget,
                samples,
                storage,
                checkpoint,
            } => {
                let mesh =
                    Mesh::build_within(scene, sizes, method, occluder.as_deref(), max_memory)?;
                progress.estimate("mesh", mesh.meshing.planned_bytes);
                stage.finish();
                // The first pass rescales the rows the bake would (a closed scene's rows sum
                // to one there too, as far as its few samples let them: docs/MESHING.md).
                let enclosure = (occluder.as_deref())
                    .map(|occ| {
                        let stage = ("first pass enclosure", progress, max_memory);
                        enclosure_of(scene, occ, &mesh, stage)
                    })
                    .transpose()?;
                let first = crate::refine::FirstPass {
                    occluder: occluder.as_deref(),
                    closed: enclosure.as_ref().map(|e| e.closed.as_slice()),
                    samples,
                    storage,
                };
                // The first pass's rows depend on the unrefined mesh and the first pass's
                // sampling only (its light comes after): keyed as a bake of that mesh, tagged.
                // Hashed only when the bake checkpoints.
                let resume = checkpoint.as_ref().map(|c| {
                    let key = checkpoint::first_pass_key(
                        &checkpoint::Identity {
                            scene,
                            sizes,
                            method,
                            n: mesh.n(),
                            k: mesh.k(),
                            visibility: visibility_name(visibility, occluder.is_some()),
                            refine: None,
                            mesh: &mesh,
                        },
                        first.first_pass_samples(),
                        crate::refine::REVISION,
                    );
                    (c, key)
                });
                let (mesh, ckpt) = crate::refine::refine_mesh(
                    scene, mesh, &first, budget, progress, max_memory, resume,
                )?;
                (mesh, Some(budget), ckpt)
            }
        };
        let enclosure = (occluder.as_deref())
            .map(|occ| enclosure_of(scene, occ, &mesh, ("enclosure", progress, max_memory)))
            .transpose()?;
        Ok(Self {
            scene,
            sizes,
            method,
            mesh,
            refine,
            visibility,
            occluder,
            enclosure,
            first_pass_checkpoint,
        })
    }

    /// A form-factor pass over this mesh with `samples` points per pair and this occluder.
    pub fn form_factors(&self, samples: u32) -> FormFactors<'_> {
        let mut ff = FormFactors::new(samples, self.occluder.as_deref())
            .with_enclosure(self.enclosure.as_ref().map(|e| e.closed.as_slice()));
        if !self.mesh.siblings.is_empty() {
            ff.siblings = Some(&self.mesh.siblings);
        }
        ff.elements = Some(&self.mesh.elements);
        ff
    }

    /// Name of the visibility method used (the file metadata's `visibility`).
    pub(crate) fn visibility_name(&self) -> &'static str {
        visibility_name(self.visibility, self.occluder.is_some())
    }

    /// `F_k`, n×k row-major in file order (`checkpoint::element_patch_matrix`), saved block
    /// by block when `checkpoint` is given.
    pub fn element_patch_matrix(
        &self,
        ff: &FormFactors,
        progress: &Progress,
        max_memory: Option<u64>,
        checkpoint: Option<&CheckpointSettings>,
    ) -> Result<(Vec<f64>, Option<Checkpoint>)> {
        let checkpoint = checkpoint.map(|c| (c, checkpoint::key(&self.identity(), ff.samples)));
        checkpoint::element_patch_matrix(
            &self.mesh,
            ff,
            progress,
            max_memory,
            checkpoint,
            0..self.mesh.n(),
            "form factors",
        )
    }

    /// What identifies this bake's `F_k` for checkpoints.
    pub(crate) fn identity(&self) -> checkpoint::Identity<'_> {
        checkpoint::Identity {
            scene: self.scene,
            sizes: self.sizes,
            method: self.method,
            n: self.mesh.n(),
            k: self.mesh.k(),
            visibility: self.visibility_name(),
            refine: self.refine.map(|budget| (budget, crate::refine::REVISION)),
            mesh: &self.mesh,
        }
    }

    /// Reflectance and emission of each element, in file order.
    pub(crate) fn file_order_materials(&self) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
        self.mesh.file_order_materials(self.scene)
    }

    /// Surfaces with an emitting element: the light groups the file will hold (one each,
    /// `write::Skeleton::add_light_groups`).
    pub(crate) fn emitting_surfaces(&self) -> usize {
        let (_, emission) = self.file_order_materials();
        let mut emits = vec![false; self.scene.surfaces.len()];
        for (s, e) in emission.iter().enumerate() {
            if e.iter().any(|&x| x > 0.0) {
                emits[self.mesh.element_at(s).surface as usize] = true;
            }
        }
        emits.iter().filter(|&&e| e).count()
    }

    /// Channels of the cores: 1 for a grey scene, else 3.
    pub(crate) fn channels(&self) -> usize {
        if self.scene.is_grey() { 1 } else { 3 }
    }

    /// Reflectance and emission of each element, in original id order (a textured
    /// material's reflectance averaged over each element: `Scene::reflectance_over`).
    pub fn element_materials(&self) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
        self.mesh.element_materials(self.scene)
    }
}

/// What the enclosure test found (`formfactor::enclosure`) and what it changed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct EnclosureSummary {
    /// Elements every probe ray of which met a front, in a scene no probe ray left.
    pub closed_elements: u64,
    /// Of their rows, those rescaled to sum to one (the others had no partly visible pair, or
    /// needed a factor beyond 2).
    pub rows_rescaled: u64,
    /// Probe rays cast.
    pub rays: u64,
    /// Probe rays that left the scene (any: no row is rescaled).
    pub escaped: u64,
    /// Probe rays that met the back of a face first.
    pub backs: u64,
}

impl EnclosureSummary {
    /// One line for the bake's output.
    pub fn line(&self) -> String {
        if self.escaped > 0 {
            format!(
                "enclosure: open ({} of {} probe rays leave the scene): rows kept as sampled",
                self.escaped, self.rays
            )
        } else {
            format!(
                "enclosure: closed; {} elements see only fronts, {} rows rescaled to sum to one ({} probe rays, {} met a back)",
                self.closed_elements, self.rows_rescaled, self.rays, self.backs
            )
        }
    }
}

/// The result of a bake, in file order.
pub struct Baked {
    /// Name of the scene (file metadata).
    pub scene_name: String,
    /// Element and patch sizes used, in scene units.
    pub sizes: MeshSizes,
    /// How the patches were built.
    pub method: PatchMethod,
    /// Quadrature points and visibility rays per element-patch pair.
    pub samples: u32,
    /// Visibility method used, as written to the metadata (`"none (nothing occludes)"` when no rays were cast).
    pub visibility: &'static str,
    /// The fine and coarse meshes; element data below follow its file order.
    pub mesh: Mesh,
    /// `F_k`: element→patch form factors with visibility, n×k row-major in file order.
    pub fk: Vec<f64>,
    /// Per-channel k×k cores `M_c = (I - Vᵀ diag(ρ_c) F_k)⁻¹` and their condition numbers.
    pub cores: Cores,
    /// Per element in file order: RGB reflectance ρ in [0, 1).
    pub reflectance: Vec<[f64; 3]>,
    /// Per element in file order: RGB emitted exitance `E = π·Ke` (W/m² style).
    pub emission: Vec<[f64; 3]>,
    /// Surface names, indexed by `Element::surface`.
    pub surfaces: Vec<String>,
    /// What the file holds for display (format 1.2): materials, point lights, cameras, BVH.
    pub display: lrr_formats::Display,
    /// Occlusion rays cast by the form-factor pass.
    pub rays: u64,
    /// Element-patch pairs skipped because they face away from each other.
    pub culled_pairs: u64,
    /// The enclosure test and the rows it rescaled (`None` when nothing occludes).
    pub enclosure: Option<EnclosureSummary>,
    /// The form-factor checkpoint, to remove once the output is written.
    pub checkpoint: Option<Checkpoint>,
    /// The checkpoint of `--refine`'s first pass, to remove with it.
    pub first_pass_checkpoint: Option<Checkpoint>,
    /// `--refine`'s budget, when the mesh was refined (the file's metadata).
    pub refine: Option<f64>,
}

/// Bakes a scene: the whole pipeline up to the k×k cores.
pub fn bake(scene: &Scene, settings: &BakeSettings, progress: &Progress) -> Result<Baked> {
    if settings.samples == 0 {
        return Err(Error::Settings("--samples must be at least 1".into()));
    }
    let sizes = MeshSizes::resolve(scene, settings.element_size, settings.patch_size)?;
    if let Some(budget) = settings.refine {
        crate::refine::check_budget(budget)?;
    }
    crate::pool::with_threads(settings.threads, || {
        let mut prepared = Prepared::with_mesh(
            scene,
            sizes,
            settings.method,
            settings.visibility,
            progress,
            settings.max_memory,
            MeshFrom::meshing_to_write(settings),
        )?;
        // Before the form factors: bad point lights and cameras are refused early.
        let display = crate::display::build(
            scene,
            &prepared.mesh,
            prepared.occluder.as_deref(),
            progress,
            settings.max_memory,
        )?;
        // Its last reader was the display's smooth weights.
        prepared.mesh.contacts = None;
        crate::storage::check_memory(
            (prepared.mesh.n(), prepared.mesh.k(), prepared.channels()),
            settings.storage,
            prepared.emitting_surfaces(),
            &display,
            (progress, settings.max_memory),
        )?;
        let ff = prepared.form_factors(settings.samples);
        let (fk, checkpoint) = prepared.element_patch_matrix(
            &ff,
            progress,
            settings.max_memory,
            settings.checkpoint.as_ref(),
        )?;
        let channels = prepared.channels();
        let (reflectance, emission) = prepared.file_order_materials();
        let (n, k) = (prepared.mesh.n(), prepared.mesh.k());
        let bytes = crate::cores::check_memory(k, channels, n, settings.max_memory)?;
        progress.estimate("operator", bytes);
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
        let enclosure = prepared.enclosure.as_ref().map(|e| EnclosureSummary {
            closed_elements: e.closed_count() as u64,
            rows_rescaled: ff.stats.conserved_rows(),
            rays: e.rays,
            escaped: e.escaped,
            backs: e.backs,
        });
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
            display,
            rays,
            culled_pairs: culled,
            enclosure,
            checkpoint,
            first_pass_checkpoint: prepared.first_pass_checkpoint,
            // A budget of 0 refines nothing: the unrefined bake's bytes.
            refine: settings.refine.filter(|&b| b > 0.0),
        })
    })?
}

impl Baked {
    /// Number of elements.
    pub fn n(&self) -> usize {
        self.mesh.n()
    }

    /// Number of patches.
    pub fn k(&self) -> usize {
        self.mesh.k()
    }

    /// Largest per-channel condition number.
    pub fn condition(&self) -> f64 {
        self.cores.condition.iter().copied().fold(0.0, f64::max)
    }
}
