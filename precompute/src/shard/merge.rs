//! `lrr merge`: the parts of a sharded bake → the operator file a single bake writes.
//!
//! 1. Every part's header is read: the parts must come from one scene, one set of settings
//!    and one lrr version, and cover every shard exactly once; a missing, repeated,
//!    truncated or foreign part is named before anything else happens.
//! 2. First pass over the rows, in file order: the k×k systems `I - Vᵀ diag(ρ_c) F_k` summed
//!    row by row exactly as a bake sums them (`cores::Systems`, same terms in the same
//!    order, so the same bits), and every record's checksum checked. Then the cores.
//!    (Per-shard partial sums of the systems would save this pass but add in another order:
//!    the cores, and so the file, would differ in their last bits from a single bake's.)
//! 3. Second pass: the rows again, rounded to the file's precision and streamed into the
//!    operator file (`OperatorFile::write_streamed`, atomic: a damaged record or any error
//!    leaves no output).
//!
//! Memory: the process itself (8 MiB reserved), the skeleton (about 250 bytes per element,
//! plus two copies of the display sections, the skeleton's and the file's, and the section
//! being written: about 300 bytes per element more with a BVH),
//! the systems and cores
//! (about `(2c + 3)·k²·8` bytes) and a buffer of rows sized to what `--max-memory` leaves;
//! never `F_k` itself. The plain layout (`Y_k`) is assembled in memory and refused when it
//! does not fit.

use std::path::{Path, PathBuf};

use lrr_formats::{Display, Layout, StoredMatrix};

use super::part::{PartHeader, PartReader};
use crate::cores::Systems;
use crate::error::{Error, Result};
use crate::memory;
use crate::progress::Progress;
use crate::write::{self, Skeleton, Storage};

/// What a merge may be told.
#[derive(Debug, Clone, Copy, Default)]
pub struct MergeSettings {
    /// Refuse a merge whose working memory would exceed this many bytes (default: 80% of what
    /// the machine has available); rows are streamed in buffers that fit under it.
    pub max_memory: Option<u64>,
    /// How the operator is stored (as `lrr bake --precision --layout`).
    pub storage: Storage,
}

/// What a merge did.
#[derive(Debug, Clone)]
pub struct Merged {
    /// Elements.
    pub n: usize,
    /// Patches.
    pub k: usize,
    /// Shards merged.
    pub parts: usize,
    /// Channels of the cores.
    pub channels: usize,
    /// Largest per-channel condition number.
    pub condition: f64,
    /// Rows per buffer in the streaming passes.
    pub chunk_rows: usize,
    /// The working memory the merge planned for (bytes), under `--max-memory`.
    pub planned_bytes: u64,
}

/// Merges `parts` (any order) into the operator file `output`.
pub fn merge(
    parts: &[PathBuf],
    output: &Path,
    settings: &MergeSettings,
    progress: &Progress,
) -> Result<Merged> {
    let stage = progress.stage("check parts", 0);
    let mut readers = ordered_parts(parts)?;
    stage.finish();
    let header = readers[0].header.clone();
    let (n, k) = (header.n, header.k);
    let skeleton = readers[0].skeleton()?;
    if skeleton.n() != n || skeleton.k() != k {
        return Err(Error::part(
            &readers[0].path,
            "damaged: the skeleton's sizes disagree with the header",
        ));
    }
    let (chunk_rows, planned) = plan_memory(&header, &skeleton, settings)?;
    for r in &mut readers[1..] {
        r.skip_skeleton()?;
    }
    let stage = progress.stage("cores", n as u64);
    let mut systems = Systems::new(
        &skeleton.weights,
        &skeleton.index,
        &skeleton.reflectance,
        skeleton.channels,
    );
    for r in &mut readers {
        r.rows(chunk_rows, &mut |rows| {
            systems.add_rows(rows);
            stage.inc((rows.len() / k.max(1)) as u64);
            Ok(())
        })?;
    }
    let cores = systems.finish()?;
    stage.finish();
    let stage = progress.stage("write", n as u64);
    let precision = settings.storage.precision;
    if settings.storage.layout == Layout::PlainYk {
        write_plain(parts, &skeleton, &cores, chunk_rows, output, settings)?;
    } else {
        let mut file = skeleton.file(StoredMatrix::from_f32(&[], precision), &cores);
        skeleton.add_light_groups(&mut file)?;
        let mut readers = ordered_parts(parts)?;
        for r in &mut readers {
            r.skip_skeleton()?;
        }
        let mut failure = None;
        let written = file.write_streamed(output, &mut |emit| {
            for r in &mut readers {
                let step = r.rows(chunk_rows, &mut |rows| {
                    let f32s: Vec<f32> = rows.iter().map(|&v| v as f32).collect();
                    stage.inc((rows.len() / k.max(1)) as u64);
                    emit(&StoredMatrix::from_f32(&f32s, precision)).map_err(Error::from)
                });
                if let Err(e) = step {
                    let message = e.to_string();
                    failure = Some(e);
                    return Err(lrr_formats::FormatError::new(
                        lrr_formats::ErrorKind::Io,
                        message,
                    ));
                }
            }
            Ok(())
        });
        if let Err(e) = written {
            return Err(failure.unwrap_or(Error::Format(e)));
        }
    }
    stage.finish();
    Ok(Merged {
        n,
        k,
        parts: readers.len(),
        channels: cores.channels,
        condition: cores.condition.iter().copied().fold(0.0, f64::max),
        chunk_rows,
        planned_bytes: planned,
    })
}

/// The plain layout: `Y_k` needs all of `F_k` at once (as a bake does), so it is assembled in
/// memory, within `--max-memory`.
fn write_plain(
    parts: &[PathBuf],
    skeleton: &Skeleton,
    cores: &crate::cores::Cores,
    chunk_rows: usize,
    output: &Path,
    settings: &MergeSettings,
) -> Result<()> {
    let (n, k) = (skeleton.n() as u128, skeleton.k() as u128);
    let channels = 3u128;
    memory::check_with(
        n * k * (8 + 4 + 4 * channels),
        settings.max_memory,
        "the plain layout (assembled in memory from F_k)",
        "merge into the factored layout (the default), or raise --max-memory",
    )?;
    let mut fk = Vec::with_capacity(skeleton.n() * skeleton.k());
    for r in &mut ordered_parts(parts)? {
        r.skip_skeleton()?;
        r.rows(chunk_rows, &mut |rows| {
            fk.extend_from_slice(rows);
            Ok(())
        })?;
    }
    let mut file = skeleton.file(write::f32_matrix(&fk), cores);
    drop(fk);
    skeleton.add_light_groups(&mut file)?;
    if settings.storage.precision != file.precision {
        write::store_matrix_as(&mut file, settings.storage.precision);
    }
    file.into_plain_yk(0)?.write(output)?;
    Ok(())
}

/// Opens every part and puts them in shard order, after checking that they make one bake.
fn ordered_parts(parts: &[PathBuf]) -> Result<Vec<PartReader>> {
    if parts.is_empty() {
        return Err(Error::Settings(
            "merge: no parts given (pass the part files of every shard)".into(),
        ));
    }
    let readers = parts
        .iter()
        .map(|p| PartReader::open(p))
        .collect::<Result<Vec<_>>>()?;
    check_same_bake(&readers)?;
    let count = readers[0].header.count;
    let mut slots: Vec<Option<PartReader>> = (0..count).map(|_| None).collect();
    for r in readers {
        let i = r.header.shard;
        if let Some(first) = &slots[i] {
            return Err(Error::part(
                &r.path,
                format!(
                    "repeated: shard {i}/{count} is also given as {}; pass each part once",
                    first.path.display()
                ),
            ));
        }
        slots[i] = Some(r);
    }
    let missing: Vec<String> = (0..count)
        .filter(|&i| slots[i].is_none())
        .map(|i| {
            let b = &slots
                .iter()
                .flatten()
                .next()
                .expect("one part")
                .header
                .boundaries;
            format!("{i}/{count} (rows {}..{})", b[i], b[i + 1])
        })
        .collect();
    if !missing.is_empty() {
        let some = slots.iter().flatten().next().expect("one part");
        return Err(Error::part(
            &some.path,
            format!(
                "missing parts: shard {} not given; bake {} with `lrr bake SCENE --shard {}/{count} …` \
                 (the same settings) and merge again",
                missing.join(", "),
                if missing.len() == 1 { "it" } else { "them" },
                if missing.len() == 1 {
                    missing[0].split('/').next().unwrap_or("I")
                } else {
                    "I"
                }
            ),
        ));
    }
    Ok(slots.into_iter().flatten().collect())
}

/// The parts must share scene, settings, version and cut; the odd one out is named against
/// the rest (the first part's group wins ties).
fn check_same_bake(readers: &[PartReader]) -> Result<()> {
    let same = |a: &PartHeader, b: &PartHeader| difference(a, b).is_none();
    let reference = readers
        .iter()
        .max_by_key(|r| {
            let votes = readers
                .iter()
                .filter(|o| same(&o.header, &r.header))
                .count();
            // Ties: the earliest part (max_by_key keeps the last maximum, so rank by position).
            (
                votes,
                std::cmp::Reverse(readers.iter().position(|o| std::ptr::eq(o, *r))),
            )
        })
        .expect("one part");
    for r in readers {
        if let Some(what) = difference(&r.header, &reference.header) {
            return Err(Error::part(
                &r.path,
                format!(
                    "foreign part: {what}, compared with {} (and the parts that agree with it); \
                     every part must come from the same scene, settings and lrr version",
                    reference.path.display()
                ),
            ));
        }
    }
    Ok(())
}

/// How `a` differs from `b` as parts of one bake, in words; `None` if they fit.
fn difference(a: &PartHeader, b: &PartHeader) -> Option<String> {
    if a.version != b.version {
        Some(format!(
            "another lrr version ({}, not {})",
            a.version, b.version
        ))
    } else if a.scene_hash != b.scene_hash {
        Some(format!(
            "another scene (content hash {:016x}, not {:016x})",
            a.scene_hash, b.scene_hash
        ))
    } else if a.settings != b.settings {
        Some(format!(
            "other bake settings ({}, not {})",
            a.settings, b.settings
        ))
    } else if a.count != b.count || a.boundaries != b.boundaries {
        Some(format!(
            "another cut into shards ({} shards, not {})",
            a.count, b.count
        ))
    } else if (a.n, a.k, a.record_rows, a.skeleton_hash)
        != (b.n, b.k, b.record_rows, b.skeleton_hash)
    {
        Some("other meshes (same scene and settings, other elements or patches)".to_string())
    } else {
        None
    }
}

/// What the process holds before the merge allocates anything (code, libraries, stacks):
/// `lrr merge` of an 8-element bake peaks at 5.9 MiB resident (Linux x86-64, release build).
const PROCESS: u128 = 8 << 20;

/// Bytes the display sections of a file hold (as data or encoded: the same sizes).
fn display_bytes(d: &Display) -> u128 {
    let smooth = d.smooth.as_ref().map_or(0, |s| {
        4 * (s.corners.len() + s.offsets.len() + s.positions.len() + s.weights.len())
    });
    let materials = d.materials.as_ref().map_or(0, |m| {
        4 * m.element_material.len() + m.materials.iter().map(|m| 64 + m.name.len()).sum::<usize>()
    });
    let named = |name: &String| 64 + name.len();
    let lights: usize = d.point_lights.iter().map(|l| named(&l.name)).sum::<usize>()
        + d.direct_lights
            .iter()
            .map(|l| named(&l.name))
            .sum::<usize>();
    let cameras: usize = d.cameras.iter().map(|c| named(&c.name)).sum();
    let bvh = d
        .bvh
        .as_ref()
        .map_or(0, |b| 32 * b.nodes.len() + 4 * b.triangles.len());
    let faces = d.faces.as_ref().map_or(0, |f| {
        4 * f.element.len() + f.geometry.vertex_count.len() * 61
    });
    let sky = d.sky_transfer.as_ref().map_or(0, |t| 4 * t.len());
    (smooth + materials + lights + cameras + bvh + faces + sky) as u128
}

/// Rows per streaming buffer and the bytes planned, refused when even one row does not fit.
fn plan_memory(
    header: &PartHeader,
    skeleton: &Skeleton,
    settings: &MergeSettings,
) -> Result<(usize, u64)> {
    let (n, k, c) = (
        header.n as u128,
        header.k.max(1) as u128,
        skeleton.channels as u128,
    );
    // Skeleton and its bytes, the file's copies (order, index, f32 arrays, geometry), lights.
    let per_element = 130 + 100 + 16;
    // The display sections: the skeleton's, the file's and their encoded payloads while the
    // file is written, and the BVH check's scratch (13 bytes per triangle, 4 per node).
    let display = 3 * display_bytes(&skeleton.display)
        + skeleton.display.bvh.as_ref().map_or(0, |b| {
            13 * b.triangles.len() as u128 + 4 * b.nodes.len() as u128
        });
    let fixed = PROCESS
        + n * per_element
        + display
        + crate::cores::cores_bytes(k as usize, c as usize)
        + header.skeleton_len as u128;
    // Per buffered row: the bytes read, f64 values, f32 values, the encoded payload.
    let per_row = k * (8 + 8 + 4 + 4);
    let limit = settings
        .max_memory
        .map_or_else(|| memory::available() * 8 / 10, u128::from);
    // Buffers beyond a few MiB read no faster: at most 4 MiB of f64 rows at a time.
    let useful = (4u128 << 20) / (k * 8);
    let fits = limit.saturating_sub(fixed) / per_row;
    let chunk = fits.min(useful).min(header.record_rows as u128) as usize;
    memory::check_with(
        fixed + per_row,
        settings.max_memory,
        "merging (the process, the skeleton, the k×k systems and one row)",
        "raise --max-memory",
    )?;
    let chunk = chunk.max(1);
    Ok((chunk, (fixed + per_row * chunk as u128) as u64))
}
