//! Sharded bakes: the rows of `F_k` cut into N ranges of about equal estimated cost
//! (`cost`), each baked by its own process, on any machine (`lrr bake SCENE --shard i/N -o
//! part-i.bin`), and merged into the very bytes a single bake writes (`merge`).
//!
//! Form-factor rows are independent (every factor depends only on its element-patch pair),
//! so a shard needs no other shard. Every shard meshes the scene itself (refinement where
//! light changes included: its first pass, `crate::refine`, is part of the mesh stage): meshing is
//! deterministic (the same elements, patches and order in every process, whatever the
//! thread count) and costs a small fraction of a shard's form factors (docs/DISTRIBUTED.md
//! measures both), so no plan file has to be shipped to the shards. A shard checkpoints its
//! rows like a bake (`PART.ckpt`) and picks the checkpoint up by itself when run again after
//! a kill: a scheduler's retry is the same command line. The part file (`part`) carries the
//! shard's rows in f64 and the skeleton of the operator file, so the merge needs neither the
//! scene nor the meshing.
//!
//! The shard index may come from a scheduler's environment: `SLURM_ARRAY_TASK_ID` (a Slurm
//! job array) or `JOB_COMPLETION_INDEX` (a Kubernetes indexed Job), see [`ShardSpec::parse`].

mod cost;
mod merge;
mod part;
mod plan;

pub use cost::{boundaries, shard_costs};
pub use merge::{MergeSettings, Merged, merge};
pub use part::PartHeader;

use std::ops::Range;
use std::path::Path;

use lrr_formats::Xxh64;

use crate::bake::{BakeSettings, MeshFrom, Prepared};
use crate::checkpoint::{self, Checkpoint, CheckpointSettings};
use crate::error::{Error, Result};
use crate::mesh::MeshSizes;
use crate::patches::PatchMethod;
use crate::progress::Progress;
use crate::scene::Scene;
use crate::write::{Skeleton, SkeletonInputs};

/// Which shard of how many.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ShardSpec {
    /// From 0.
    pub index: usize,
    /// At least 1.
    pub count: usize,
}

/// Environment variables a shard index may come from, in the order they are read.
pub const INDEX_VARIABLES: [&str; 2] = ["SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX"];

impl ShardSpec {
    /// Parses `I/N` (shard I of N, I from 0) or `env/N`, where I comes from the first of
    /// [`INDEX_VARIABLES`] that `var` finds set.
    pub fn parse(text: &str, var: &dyn Fn(&str) -> Option<String>) -> Result<Self> {
        let usage = |why: String| {
            Error::Settings(format!(
                "--shard {text}: {why}; write I/N (shard I of N, I from 0 to N - 1), or env/N to \
                 take I from {} or {}",
                INDEX_VARIABLES[0], INDEX_VARIABLES[1]
            ))
        };
        let (index, count) = text.split_once('/').ok_or_else(|| usage("no '/'".into()))?;
        let count: usize = count
            .trim()
            .parse()
            .ok()
            .filter(|&c| c >= 1)
            .ok_or_else(|| usage(format!("'{count}' is not a number of shards (1 or more)")))?;
        let (index, source) = if index.trim() == "env" {
            let (name, value) = INDEX_VARIABLES
                .iter()
                .find_map(|&v| var(v).map(|value| (v, value)))
                .ok_or_else(|| usage("neither variable is set".into()))?;
            (value, format!(" (from {name})"))
        } else {
            (index.to_string(), String::new())
        };
        let index: usize = index
            .trim()
            .parse()
            .ok()
            .filter(|&i| i < count)
            .ok_or_else(|| {
                usage(format!(
                    "shard '{index}'{source} is not a number from 0 to {}",
                    count - 1
                ))
            })?;
        Ok(Self { index, count })
    }
}

/// What a shard did.
#[derive(Debug, Clone)]
pub struct ShardBaked {
    /// Which shard.
    pub shard: ShardSpec,
    /// The bake's elements and patches.
    pub n: usize,
    /// Patches.
    pub k: usize,
    /// This shard's rows (file positions).
    pub rows: Range<usize>,
    /// Estimated cost of this shard's rows and of the whole bake (`cost`).
    pub cost: u64,
    /// Estimated cost of the whole bake.
    pub total_cost: u64,
    /// Estimated cost of every shard (the balance the cut expects).
    pub shard_costs: Vec<u64>,
    /// Rows taken from a checkpoint of an earlier, interrupted run.
    pub resumed_rows: u64,
    /// Occlusion rays cast by this run.
    pub rays: u64,
    /// The part's header.
    pub header: PartHeader,
}

/// Bakes one shard of a scene into the part file `output`; its checkpoint is
/// `checkpoint::path_for(output)`, resumed when it is there and belongs to this shard.
/// With `plan`, the meshes come from that plan file ([`write_plan`]) instead of being made
/// again.
pub fn bake_shard(
    scene: &Scene,
    settings: &BakeSettings,
    shard: ShardSpec,
    output: &Path,
    plan: Option<&Path>,
    progress: &Progress,
) -> Result<ShardBaked> {
    if settings.samples == 0 {
        return Err(Error::Settings("--samples must be at least 1".into()));
    }
    let sizes = MeshSizes::resolve(scene, settings.element_size, settings.patch_size)?;
    check_refine(settings)?;
    crate::pool::with_threads(settings.threads, || {
        let from = match plan {
            None => MeshFrom::meshing(settings),
            Some(path) => {
                let stage = progress.stage("read plan", 0);
                let visibility = visibility_name(scene, settings.visibility);
                let text = settings_text(sizes, settings, visibility);
                let id = plan_identity(scene, &text);
                let mesh = plan::read(path, &id, scene)?;
                stage.finish();
                MeshFrom::Plan {
                    mesh: Box::new(mesh),
                    refine: refine_budget(settings),
                }
            }
        };
        let mut prepared = Prepared::with_mesh(
            scene,
            sizes,
            settings.method,
            settings.visibility,
            progress,
            settings.max_memory,
            from,
        )?;
        // Removed with the rows' checkpoint once the part is written.
        let first_pass_checkpoint = prepared.first_pass_checkpoint.take();
        let display = crate::display::build(
            scene,
            &prepared.mesh,
            prepared.occluder.as_deref(),
            progress,
            settings.max_memory,
        )?;
        // Its last reader was the display's smooth weights.
        prepared.mesh.contacts = None;
        let stage = progress.stage("cut", 0);
        let costs = cost::row_costs(&prepared.mesh, prepared.occluder.is_some());
        let cut = cost::boundaries(&costs, shard.count);
        let per_shard = cost::shard_costs(&costs, &cut);
        stage.finish();
        let rows = cut[shard.index]..cut[shard.index + 1];
        let ff = prepared.form_factors(settings.samples);
        let (fk, checkpoint) =
            shard_rows(&prepared, &ff, settings, rows.clone(), output, progress)?;
        let stage = progress.stage("write", 0);
        let (reflectance, emission) = prepared.file_order_materials();
        let skeleton = Skeleton::new(&SkeletonInputs {
            scene_name: &scene.name,
            sizes,
            method: settings.method,
            samples: settings.samples,
            visibility: prepared.visibility_name(),
            mesh: &prepared.mesh,
            reflectance: &reflectance,
            emission: &emission,
            surfaces: &scene.surfaces,
            channels: prepared.channels(),
            display: &display,
            refine: prepared.refine,
        });
        let skeleton = part::encode_skeleton(&skeleton);
        let header = PartHeader {
            version: format!("lrr {}", env!("CARGO_PKG_VERSION")),
            scene_hash: scene_hash(scene),
            settings: settings_text(sizes, settings, prepared.visibility_name()),
            shard: shard.index,
            count: shard.count,
            n: prepared.mesh.n(),
            k: prepared.mesh.k(),
            boundaries: cut,
            record_rows: ((1usize << 20) / prepared.mesh.k().max(1)).max(1),
            skeleton_hash: lrr_formats::checksum(&skeleton),
            skeleton_len: skeleton.len() as u64,
        };
        part::write(output, &header, &skeleton, &fk)?;
        let resumed_rows = checkpoint.as_ref().map_or(0, Checkpoint::resumed_rows);
        if let Some(c) = checkpoint {
            c.remove()?;
        }
        if let Some(c) = first_pass_checkpoint {
            c.remove()?;
        }
        stage.finish();
        let (_, _, rays) = ff.stats.get();
        Ok(ShardBaked {
            shard,
            n: header.n,
            k: header.k,
            rows: rows.clone(),
            cost: per_shard[shard.index],
            total_cost: per_shard.iter().sum(),
            shard_costs: per_shard,
            resumed_rows,
            rays,
            header,
        })
    })?
}

/// Meshes the scene once and writes the plan file every shard may read
/// (`lrr bake --shard I/N --plan PLAN`); returns n and k.
pub fn write_plan(
    scene: &Scene,
    settings: &BakeSettings,
    output: &Path,
    progress: &Progress,
) -> Result<(usize, usize)> {
    let sizes = MeshSizes::resolve(scene, settings.element_size, settings.patch_size)?;
    check_refine(settings)?;
    crate::pool::with_threads(settings.threads, || {
        let prepared = Prepared::with_mesh(
            scene,
            sizes,
            settings.method,
            settings.visibility,
            progress,
            settings.max_memory,
            MeshFrom::meshing(settings),
        )?;
        let text = settings_text(sizes, settings, prepared.visibility_name());
        let stage = progress.stage("write", 0);
        plan::write(output, &plan_identity(scene, &text), &prepared.mesh)?;
        stage.finish();
        Ok((prepared.mesh.n(), prepared.mesh.k()))
    })?
}

fn plan_identity<'a>(scene: &Scene, settings: &'a str) -> plan::PlanIdentity<'a> {
    plan::PlanIdentity {
        version: concat!("lrr ", env!("CARGO_PKG_VERSION")),
        scene_hash: scene_hash(scene),
        settings,
    }
}

/// The visibility name a bake of `scene` records (as `Prepared::visibility_name`).
fn visibility_name(scene: &Scene, backend: crate::visibility::Backend) -> &'static str {
    if crate::bake::needs_occluder(scene) {
        backend.name()
    } else {
        "none (nothing occludes)"
    }
}

/// The shard's rows, checkpointed; an earlier run's checkpoint is resumed when it belongs
/// to these rows, and replaced (with a note) when it does not.
fn shard_rows(
    prepared: &Prepared,
    ff: &crate::formfactor::FormFactors,
    settings: &BakeSettings,
    rows: Range<usize>,
    output: &Path,
    progress: &Progress,
) -> Result<(Vec<f64>, Option<Checkpoint>)> {
    let path = checkpoint::path_for(output);
    let key = checkpoint::range_key(
        checkpoint::key(&prepared.identity(), ff.samples),
        rows.clone(),
    );
    let block_rows = settings.checkpoint.as_ref().and_then(|c| c.block_rows);
    let run = |resume: bool| {
        let c = CheckpointSettings {
            path: path.clone(),
            resume,
            block_rows,
        };
        checkpoint::element_patch_matrix(
            &prepared.mesh,
            ff,
            progress,
            settings.max_memory,
            Some((&c, key)),
            rows.clone(),
            "form factors",
        )
    };
    checkpoint::resume_or_replace(&path, "this shard", run)
}

/// Hash of everything of the scene a bake reads: name, surfaces, materials, faces, lights.
pub(crate) fn scene_hash(scene: &Scene) -> u64 {
    let mut h = Xxh64::new();
    let text = |h: &mut Xxh64, s: &str| {
        h.update(&(s.len() as u64).to_le_bytes());
        h.update(s.as_bytes());
    };
    text(&mut h, &scene.name);
    for s in &scene.surfaces {
        text(&mut h, s);
    }
    for m in &scene.materials {
        for v in m.reflectance.iter().chain(&m.emission) {
            h.update(&v.to_le_bytes());
        }
    }
    for f in &scene.faces {
        h.update(&(f.material as u64).to_le_bytes());
        h.update(&(f.surface as u64).to_le_bytes());
        for v in f.polygon.vertices() {
            for c in v.to_array() {
                h.update(&c.to_le_bytes());
            }
        }
    }
    // The lights that are not surfaces steer 2MSC and the refinement, and the sky's transfer.
    for l in &scene.point_lights {
        text(&mut h, l.group.as_deref().unwrap_or("\0"));
        for c in l.position.iter().chain(&l.intensity) {
            h.update(&c.to_le_bytes());
        }
    }
    for l in &scene.direct_lights {
        h.update(&l.kind.code().to_le_bytes());
        for c in l
            .position
            .iter()
            .chain(&l.direction)
            .chain(&l.strength)
            .chain(&l.extra)
        {
            h.update(&c.to_le_bytes());
        }
    }
    h.finish()
}

/// The settings that decide the file, as text (exact: shortest round-trip decimals).
fn settings_text(sizes: MeshSizes, s: &BakeSettings, visibility: &str) -> String {
    let method = match s.method {
        PatchMethod::TwoFixed => "2mf".to_string(),
        PatchMethod::SpatialCoherence {
            threshold,
            min_patch_area,
            rule,
        } => format!(
            "{} threshold {threshold:?} min-patch-area {min_patch_area:?}{}",
            s.method.name(),
            match rule {
                crate::patches::CoherenceRule::Split => String::new(),
                crate::patches::CoherenceRule::Merge =>
                    format!(" revision {}", crate::patches::coherence::merge::REVISION),
            }
        ),
    };
    // Refinement where light changes: the budget and the rules' revision (absent when the
    // mesh is not refined, so unrefined plans and parts keep their text).
    let refine = match refine_budget(s) {
        Some(b) => format!(", refine {b:?} revision {}", crate::refine::REVISION),
        None => String::new(),
    };
    format!(
        "method {method}, element size {:?}, patch size {:?}, {} samples, visibility {visibility}{refine}",
        sizes.element_size, sizes.patch_size, s.samples
    )
}

/// `--refine`'s budget, refused before any work when it is not a share of n.
fn check_refine(settings: &BakeSettings) -> Result<()> {
    match settings.refine {
        Some(budget) => crate::refine::check_budget(budget),
        None => Ok(()),
    }
}

/// The budget a refined mesh records (`None` for none or 0: the unrefined bake).
fn refine_budget(settings: &BakeSettings) -> Option<f64> {
    settings.refine.filter(|&b| b > 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shard_specs_parse_and_refuse_with_reasons() {
        let none = |_: &str| None;
        assert_eq!(
            ShardSpec::parse("2/7", &none).unwrap(),
            ShardSpec { index: 2, count: 7 }
        );
        let slurm = |v: &str| (v == "SLURM_ARRAY_TASK_ID").then(|| "6".to_string());
        assert_eq!(ShardSpec::parse("env/7", &slurm).unwrap().index, 6);
        let k8s = |v: &str| (v == "JOB_COMPLETION_INDEX").then(|| "0".to_string());
        assert_eq!(ShardSpec::parse("env/3", &k8s).unwrap().index, 0);
        for (text, why) in [
            ("7/7", "not a number from 0 to 6"),
            ("2", "no '/'"),
            ("1/0", "not a number of shards"),
            ("env/4", "neither variable is set"),
        ] {
            let e = ShardSpec::parse(text, &none).unwrap_err().to_string();
            assert!(e.contains(why) && e.contains("I/N"), "{text}: {e}");
        }
        let e = ShardSpec::parse("env/4", &slurm).unwrap_err().to_string();
        assert!(e.contains("from SLURM_ARRAY_TASK_ID"), "{e}");
    }
}
