//! Checkpointed form-factor rows: `F_k` computed block by block, each block saved as soon as it
//! is done (`file`), so `lrr bake --resume` continues a killed bake where it stopped and still
//! writes the same bytes. A checkpoint carries a key of everything `F_k` depends on and is
//! never applied to another bake.

mod file;

pub use file::{Checkpoint, first_pass_path, path_for};

use crate::error::Result;
use crate::formfactor::FormFactors;
use crate::geometry::Polygon;
use crate::geometry::Region;
use crate::memory;
use crate::mesh::MeshSizes;
use crate::patches::{Mesh, PatchMethod};
use crate::progress::Progress;
use crate::scene::Scene;

/// Checkpointing of the form-factor rows.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckpointSettings {
    /// Checkpoint file (see [`path_for`]).
    pub path: std::path::PathBuf,
    /// Continue from the checkpoint if it exists (else start afresh) instead of starting over.
    pub resume: bool,
    /// Rows per checkpoint block (default: about 10⁶ element-patch-sample triples).
    pub block_rows: Option<usize>,
}

/// What identifies a bake's `F_k` (see [`key`]).
pub(crate) struct Identity<'a> {
    pub scene: &'a Scene,
    pub sizes: MeshSizes,
    pub method: PatchMethod,
    pub n: usize,
    pub k: usize,
    /// The visibility backend's name as the file's metadata records it.
    pub visibility: &'a str,
    /// `--refine`'s budget when the mesh was refined where light changes, and the revision of
    /// the refinement's rules (`refine::REVISION`).
    pub refine: Option<(f64, u32)>,
    /// The mesh itself: which elements (file order, ids) and which patches. A refined mesh
    /// depends on the materials too (the first pass's light), so another reflectance can give
    /// the same `n` and `k` with other elements.
    pub mesh: &'a Mesh,
}

/// The rows `rows` (file positions) of `F_k`: element-to-patch form factors, row-major,
/// computed in blocks of rows that are checkpointed when `checkpoint` is given (all n rows
/// for a bake, one shard's range for a sharded one). Returns the open checkpoint, which the
/// caller removes once the output is safely written. `checkpoint` comes with the bake's
/// [`key`] (for a range, [`range_key`]).
#[allow(clippy::too_many_arguments)]
pub(crate) fn element_patch_matrix(
    mesh: &Mesh,
    ff: &FormFactors,
    progress: &Progress,
    max_memory: Option<u64>,
    checkpoint: Option<(&CheckpointSettings, u64)>,
    rows: std::ops::Range<usize>,
    stage: &str,
) -> Result<(Vec<f64>, Option<Checkpoint>)> {
    let (n, k) = (rows.len(), mesh.k());
    let bytes = (n as u128) * (k as u128) * 12;
    memory::check_with(
        bytes,
        max_memory,
        &format!("the element-to-patch matrix (n = {n} elements × k = {k} patches)"),
        &memory::size_advice(),
    )?;
    progress.estimate(stage, bytes);
    let polygons: Vec<Polygon> = rows.clone().map(|s| mesh.element_at(s).polygon).collect();
    let ids = &mesh.order[rows];
    let targets: Vec<Region> = mesh.patches.iter().map(|p| p.shape.clone()).collect();
    let mut fk = vec![0.0; n * k];
    let stage = progress.stage(stage, n as u64);
    let block_rows = checkpoint
        .and_then(|(c, _)| c.block_rows)
        .unwrap_or_else(|| (1usize << 20) / (k.max(1) * ff.samples as usize))
        .clamp(1, n.max(1));
    let blocks = n.div_ceil(block_rows);
    let ends = crate::formfactor::Ends::of(ff.occluder, &targets);
    let mut done = vec![false; blocks];
    let mut file = None;
    if let Some((c, key)) = checkpoint {
        let shape = file::Shape {
            key,
            n: n as u64,
            k: k as u64,
            block_rows: block_rows as u64,
        };
        // Resuming with nothing saved (a bake cut off before this stage saved a block, or a
        // shard's first run) starts the stage afresh; `lrr bake --resume` refuses when no
        // checkpoint of the bake exists at all.
        file = Some(if c.resume && c.path.exists() {
            let (mut f, saved) = Checkpoint::resume(&c.path, shape)?;
            for (b, values) in saved {
                f.resumed_rows += (values.len() / k.max(1)) as u64;
                let b = b as usize;
                fk[b * block_rows * k..b * block_rows * k + values.len()].copy_from_slice(&values);
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
        ff.matrix_with(
            &polygons[r0..r1],
            &ids[r0..r1],
            &targets,
            &ends,
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

/// `run(resume)`: resuming the checkpoint at `path` when it is there, and starting over, with a
/// note on standard error (`whose` names what it was for), when it belongs to another bake.
/// Shards, which always resume, use it for their rows; bakes and shards for their first pass.
pub(crate) fn resume_or_replace<T>(
    path: &std::path::Path,
    whose: &str,
    run: impl Fn(bool) -> Result<T>,
) -> Result<T> {
    if !path.exists() {
        return run(false);
    }
    match run(true) {
        Err(crate::error::Error::Settings(m)) if m.contains("different bake") => {
            eprintln!(
                "lrr: note: {} belongs to another bake; starting {whose} over",
                path.display()
            );
            run(false)
        }
        other => other,
    }
}

/// The key of `--refine`'s first pass over the unrefined mesh `bake` with `samples` per
/// pair under the refinement's rules `revision`: a bake's key of that mesh, tagged (the first
/// pass integrates one ray per pair).
pub(crate) fn first_pass_key(bake: &Identity, samples: u32, revision: u32) -> u64 {
    file::hash_parts(&[
        &key(bake, samples).to_le_bytes(),
        b"first pass of --refine, one ray per pair",
        &revision.to_le_bytes(),
    ])
}

/// The key of the rows `rows` of a bake whose key is `key` (a shard's checkpoint).
pub(crate) fn range_key(key: u64, rows: std::ops::Range<usize>) -> u64 {
    file::hash_parts(&[
        &key.to_le_bytes(),
        &(rows.start as u64).to_le_bytes(),
        &(rows.end as u64).to_le_bytes(),
    ])
}

/// Key of everything `F_k` depends on: the scene's geometry, the mesh sizes and method,
/// n, k, the mesh itself (elements in file order with their ids, patch ranges), the samples,
/// the refinement where light changes, the lrr version and the visibility backend.
pub(crate) fn key(bake: &Identity, samples: u32) -> u64 {
    let mut geometry = Vec::with_capacity(bake.scene.faces.len() * 4 * 24);
    for f in &bake.scene.faces {
        for v in f.polygon.vertices() {
            for c in v.to_array() {
                geometry.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    let sizes = [
        bake.sizes.element_size.to_le_bytes(),
        bake.sizes.patch_size.to_le_bytes(),
    ]
    .concat();
    let counts = [bake.n as u64, bake.k as u64, u64::from(samples)]
        .map(u64::to_le_bytes)
        .concat();
    let method = match bake.method {
        PatchMethod::TwoFixed => b"2mf".to_vec(),
        PatchMethod::SpatialCoherence {
            threshold,
            min_patch_area,
            rule,
        } => [
            match rule {
                crate::patches::CoherenceRule::Split => b"2msc".to_vec(),
                crate::patches::CoherenceRule::Merge => [
                    b"2msc-merge".as_slice(),
                    &crate::patches::coherence::merge::REVISION.to_le_bytes(),
                ]
                .concat(),
            },
            threshold.to_le_bytes().to_vec(),
            min_patch_area.unwrap_or(-1.0).to_le_bytes().to_vec(),
            crate::patches::coherence::REVISION.to_le_bytes().to_vec(),
        ]
        .concat(),
    };
    // Refined meshes (`crate::refine`): the budget and the rules' revision; nothing for an
    // unrefined mesh, whose key is as before.
    let refine = match bake.refine {
        None => Vec::new(),
        Some((budget, revision)) => [
            b"refine".to_vec(),
            budget.to_le_bytes().to_vec(),
            revision.to_le_bytes().to_vec(),
        ]
        .concat(),
    };
    // The mesh, streamed into its own hash (a copy of every element would cost about 100
    // bytes each).
    let mut h = lrr_formats::Xxh64::new();
    for s in 0..bake.mesh.n() {
        h.update(&bake.mesh.order[s].to_le_bytes());
        for v in bake.mesh.element_at(s).polygon.vertices() {
            for c in v.to_array() {
                h.update(&c.to_le_bytes());
            }
        }
    }
    for i in &bake.mesh.index {
        h.update(&i.to_le_bytes());
    }
    let mesh = h.finish().to_le_bytes();
    let mut parts: Vec<&[u8]> = vec![&geometry, &sizes, &counts, &method, &mesh];
    if !refine.is_empty() {
        parts.push(&refine);
    }
    parts.extend_from_slice(&[
        env!("CARGO_PKG_VERSION").as_bytes(),
        // Backends agree on all but grazing rays: never mix their rows in one file.
        bake.visibility.as_bytes(),
        // Rows of enclosed elements rescaled to sum to one (formfactor::enclosure), through
        // the whole row when the partly visible pairs cannot carry it; checkpoints of builds
        // before either hold other rows.
        b"enclosed rows sum to one; whole rows when partial pairs cannot".as_slice(),
        // A pair whose sampled segments all graze falls back to the centroid segment only when
        // that exchanges light (formfactor::visible); before, it counted a backward one.
        b"grazing fallback only when the centroid segment exchanges light".as_slice(),
    ]);
    file::hash_parts(&parts)
}
