//! The bodies of the sharded-bake and checkpoint targets (`shard_part`, `shard_plan`,
//! `checkpoint_resume`), shared with the replay test like [`super::harness`]: the files a
//! bake reads back from disk, which another machine (a shard), an earlier run (a checkpoint)
//! or anyone with write access to the folder may have written.
//!
//! Each input edits a valid file of one small fixed scene ([`SCENE`]), made once per process,
//! as its bytes say: overwrite, set a u64 to an interesting value, truncate, append (as
//! `operator_mutated`'s raw edits); a bit of the first byte then recomputes the file's
//! checksums, so that the edits reach the decoders behind them. Another bit takes the rest of
//! the input as the whole file instead. Each must give Ok or an error, never a panic; what
//! is accepted must make a valid result.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use lrr_formats::checksum;
use lrr_precompute::bake::{BakeSettings, bake};
use lrr_precompute::checkpoint::{self, CheckpointSettings};
use lrr_precompute::progress::Progress;
use lrr_precompute::scene::Scene;
use lrr_precompute::scene::description::SceneDescription;
use lrr_precompute::shard::{self, MergeSettings, ShardSpec};

use super::reader::Reader;

/// The scene every input of these targets belongs to: a lit floor under a shade, a point light
/// and a sun, the lamp a light group (n = 9 elements at element size 0.5).
pub const SCENE: &str = r#"name = "fuzz shards"
[mesh]
element_size = 0.5
patch_size = 1.0
[[material]]
name = "grey"
reflectance = [0.5, 0.5, 0.5]
[[material]]
name = "lamp"
reflectance = [0.2, 0.2, 0.2]
radiance = [1.0, 2.0, 3.0]
[[surface]]
name = "floor"
material = "grey"
polygons = [[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]]
[[surface]]
name = "shade"
material = "grey"
polygons = [[[0.2, 0.2, 0.5], [0.2, 0.6, 0.5], [0.6, 0.6, 0.5], [0.6, 0.2, 0.5]]]
[[surface]]
name = "lamp"
material = "lamp"
polygons = [[[0, 0, 1], [0, 1, 1], [1, 1, 1], [1, 0, 1]]]
[[point_light]]
name = "bulb"
position = [0.5, 0.5, 0.9]
intensity = [1.0, 2.0, 3.0]
[[directional_light]]
name = "sun"
direction = [0.3, 0.2, -1]
irradiance = [2.0, 2.0, 1.5]
"#;

/// [`SCENE`], built once.
pub fn scene() -> &'static Scene {
    static SCENE_BUILT: OnceLock<Scene> = OnceLock::new();
    SCENE_BUILT.get_or_init(|| {
        let desc = SceneDescription::parse(SCENE, "fuzz-shards.toml").expect("a valid scene");
        desc.build("fuzz-shards.toml", Path::new("."))
            .expect("a scene without includes")
    })
}

/// The settings of every bake here: the scene's sizes, 2MF, 4 samples, one thread, at most
/// 64 MiB; `refine` as given (the checkpoint target refines, so that the first pass's
/// checkpoint is there to damage).
pub fn settings(refine: Option<f64>) -> BakeSettings {
    BakeSettings {
        samples: 4,
        threads: Some(1),
        max_memory: Some(64 << 20),
        refine,
        ..BakeSettings::default()
    }
}

/// A folder of this process for the valid files these targets edit.
fn base_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("lrr-fuzz-bases-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("cannot create the fuzz base folder");
        dir
    })
}

/// The valid parts: `[0]` the one part of a bake in one shard, `[1]` and `[2]` the two parts
/// of a bake in two.
pub fn base_parts() -> &'static [Vec<u8>; 3] {
    static PARTS: OnceLock<[Vec<u8>; 3]> = OnceLock::new();
    PARTS.get_or_init(|| {
        let part = |index, count| {
            let path = base_dir().join(format!("part-{index}-of-{count}.bin"));
            let spec = ShardSpec { index, count };
            shard::bake_shard(
                scene(),
                &settings(None),
                spec,
                &path,
                None,
                &Progress::hidden(),
            )
            .expect("the base shard bakes");
            std::fs::read(&path).expect("the base part was written")
        };
        [part(0, 1), part(0, 2), part(1, 2)]
    })
}

/// The valid plan of [`SCENE`] with [`settings`]`(None)`.
pub fn base_plan() -> &'static [u8] {
    static PLAN: OnceLock<Vec<u8>> = OnceLock::new();
    PLAN.get_or_init(|| {
        let path = base_dir().join("base.plan");
        shard::write_plan(scene(), &settings(None), &path, &Progress::hidden())
            .expect("the base plan is written");
        std::fs::read(&path).expect("the base plan was written")
    })
}

/// Rows per checkpoint block in `checkpoint_resume`'s bakes (n = 9: five blocks).
const BLOCK_ROWS: usize = 2;

/// The checkpoints a refined bake of [`SCENE`] leaves when its output is never written: the
/// form-factor rows' (`OUT.ckpt`) and the first pass's (`OUT.first-pass.ckpt`).
pub fn base_checkpoints() -> &'static [Vec<u8>; 2] {
    static CKPT: OnceLock<[Vec<u8>; 2]> = OnceLock::new();
    CKPT.get_or_init(|| {
        let path = checkpoint::path_for(&base_dir().join("base.lrr"));
        let mut s = settings(Some(lrr_precompute::refine::DEFAULT_BUDGET));
        s.checkpoint = Some(CheckpointSettings {
            path: path.clone(),
            resume: false,
            block_rows: Some(BLOCK_ROWS),
        });
        let baked = bake(scene(), &s, &Progress::hidden()).expect("the base bake");
        assert!(baked.checkpoint.is_some() && baked.first_pass_checkpoint.is_some());
        drop(baked); // keeps both files
        let read = |p: &Path| std::fs::read(p).expect("the base checkpoint was written");
        [read(&path), read(&checkpoint::first_pass_path(&path))]
    })
}

/// Raw edits of `bytes` until `r` is exhausted (at most 32): overwrite 1 to 8 bytes, set an
/// aligned u64 to an interesting value, truncate, append.
pub fn edit(bytes: &mut Vec<u8>, r: &mut Reader) {
    for _ in 0..32 {
        if r.done() {
            return;
        }
        let op = r.byte() % 4;
        let at = usize::from(r.u16()) % (bytes.len() + 1);
        match op {
            0 => {
                let len = 1 + usize::from(r.byte() % 8);
                let src = r.take(len).to_vec();
                put(bytes, at, &src);
            }
            1 => {
                let value = match r.byte() % 10 {
                    0 => 0,
                    1 => 1,
                    2 => bytes.len() as u64,
                    3 => u64::MAX,
                    4 => 1 << 32,
                    5 => 1 << 63,
                    6 => f64::NAN.to_bits(),
                    7 => f64::INFINITY.to_bits(),
                    8 => (-1.0f64).to_bits(),
                    _ => r.u64(),
                };
                put(bytes, at & !7, &value.to_le_bytes());
            }
            2 => bytes.truncate(at),
            _ => {
                let len = usize::from(r.byte());
                let src = r.take(len).to_vec();
                bytes.extend_from_slice(&src);
            }
        }
    }
}

/// Writes `src` at `at`, growing `dst` when it runs past the end.
fn put(dst: &mut Vec<u8>, at: usize, src: &[u8]) {
    let end = at + src.len();
    if dst.len() < end {
        dst.resize(end, 0);
    }
    dst[at..end].copy_from_slice(src);
}

fn word(b: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(
        b.get(at..at.checked_add(8)?)?.try_into().ok()?,
    ))
}

fn set_word(b: &mut [u8], at: usize, v: u64) {
    if let Some(w) = b.get_mut(at..at + 8) {
        w.copy_from_slice(&v.to_le_bytes());
    }
}

/// Recomputes a part's checksums wherever its layout (`precompute/src/shard/part.rs`) can be
/// followed: the skeleton's hash in the header, the header's, every record's.
pub fn reseal_part(b: &mut [u8]) {
    let Some(head_len) = word(b, 8).and_then(|l| usize::try_from(l).ok()) else {
        return;
    };
    let Some(head_end) = 24usize.checked_add(head_len).filter(|&e| e <= b.len()) else {
        return;
    };
    // The header: version, scene hash, settings, shard, count, n, k, record rows, boundaries,
    // skeleton hash, skeleton length.
    let string = |at: usize| -> Option<usize> {
        let len = usize::try_from(word(b, at)?).ok()?;
        at.checked_add(8)?.checked_add(len)
    };
    let fields = (|| {
        let at = string(24)?;
        let at = string(at + 8)?;
        let k = word(b, at + 24)?;
        let boundaries = usize::try_from(word(b, at + 40)?).ok()?;
        let at = at
            .checked_add(48)?
            .checked_add(boundaries.checked_mul(8)?)?;
        Some((k, at))
    })();
    let Some((k, hash_at)) = fields.filter(|&(_, at)| at + 16 <= head_end) else {
        let sum = checksum(&b[24..head_end]);
        set_word(b, 16, sum);
        return;
    };
    let skeleton_len = word(b, hash_at + 8).unwrap_or(0);
    let skeleton_end = usize::try_from(skeleton_len)
        .ok()
        .and_then(|l| head_end.checked_add(l))
        .filter(|&e| e <= b.len());
    if let Some(end) = skeleton_end {
        let sum = checksum(&b[head_end..end]);
        set_word(b, hash_at, sum);
        let mut at = end;
        while let (Some(count), true) = (word(b, at + 8), at + 24 <= b.len()) {
            let payload = count
                .checked_mul(k)
                .and_then(|x| x.checked_mul(8))
                .and_then(|x| usize::try_from(x).ok())
                .and_then(|x| (at + 24).checked_add(x))
                .filter(|&e| e <= b.len());
            let Some(payload_end) = payload else {
                break;
            };
            let sum = checksum(&b[at + 24..payload_end]);
            set_word(b, at + 16, sum);
            if payload_end == at + 24 {
                break;
            }
            at = payload_end;
        }
    }
    let sum = checksum(&b[24..head_end]);
    set_word(b, 16, sum);
}

/// `shard_part`: parts of a sharded bake merged into an operator file. `data[0]`: bits 0-1
/// which parts (0: the one part of one shard; 1: both of two, bit 2 picks the part edited; 2:
/// the rest of the input as one part; 3: the first of two parts twice), bit 7 reseals the
/// edited part; the rest edits it ([`edit`]). A merge that succeeds must write a file the
/// runtime loads.
pub fn shard_part(data: &[u8], dir: &Path) -> bool {
    let mut r = Reader(data);
    let head = r.byte();
    let bases = base_parts();
    let mut parts: Vec<Vec<u8>> = match head % 4 {
        0 => vec![bases[0].clone()],
        2 => vec![r.0.to_vec()],
        3 => vec![bases[1].clone(), bases[1].clone()],
        _ => vec![bases[1].clone(), bases[2].clone()],
    };
    if head % 4 != 2 {
        let which = usize::from(head >> 2 & 1) % parts.len();
        edit(&mut parts[which], &mut r);
        if head & 0x80 != 0 {
            reseal_part(&mut parts[which]);
        }
    }
    let paths: Vec<PathBuf> = parts
        .iter()
        .enumerate()
        .map(|(i, bytes)| {
            let path = dir.join(format!("part-{i}.bin"));
            std::fs::write(&path, bytes).expect("cannot write the fuzz part");
            path
        })
        .collect();
    let out = dir.join("merged.lrr");
    let settings = MergeSettings {
        max_memory: Some(64 << 20),
        ..MergeSettings::default()
    };
    if shard::merge(&paths, &out, &settings, &Progress::hidden()).is_err() {
        return false;
    }
    if let Err(e) = lrr_runtime::Operator::load(&out) {
        panic!("a merge wrote a file the runtime refuses: {e}");
    }
    true
}

/// Sets a plan's body length and checksum (`precompute/src/shard/plan.rs`).
pub fn reseal_plan(b: &mut [u8]) {
    if b.len() < 24 {
        return;
    }
    let sum = checksum(&b[24..]);
    let len = (b.len() - 24) as u64;
    set_word(b, 8, len);
    set_word(b, 16, sum);
}

/// `shard_plan`: a plan read by a shard of [`SCENE`] (`lrr bake --shard I/N --plan PLAN`).
/// `data[0]`: bit 0 takes the rest of the input as the plan, else [`base_plan`] edited by the
/// rest; bit 1: shard 1 of 2, else 0 of 1; bit 7 reseals the edited plan. A plan the shard
/// accepts must bake.
pub fn shard_plan(data: &[u8], dir: &Path) -> bool {
    let mut r = Reader(data);
    let head = r.byte();
    let plan = if head & 1 != 0 {
        r.0.to_vec()
    } else {
        let mut plan = base_plan().to_vec();
        edit(&mut plan, &mut r);
        if head & 0x80 != 0 {
            reseal_plan(&mut plan);
        }
        plan
    };
    let path = dir.join("fuzz.plan");
    std::fs::write(&path, plan).expect("cannot write the fuzz plan");
    let spec = if head & 2 != 0 {
        ShardSpec { index: 1, count: 2 }
    } else {
        ShardSpec { index: 0, count: 1 }
    };
    let out = dir.join("plan-part.bin");
    let _ = std::fs::remove_file(checkpoint::path_for(&out));
    shard::bake_shard(
        scene(),
        &settings(None),
        spec,
        &out,
        Some(&path),
        &Progress::hidden(),
    )
    .is_ok()
}

/// `checkpoint_resume`: a refined bake of [`SCENE`] resumed (`lrr bake --resume`) from a
/// checkpoint the input spells. `data[0]`: bit 0 picks the checkpoint (the rows', or the first
/// pass's); bit 1 takes the rest of the input as the whole file; else the file is the valid
/// header followed by up to 16 records, each `index, length mode, value mode, checksum mode`
/// (see [`record`]). A bake that finishes must make a file that passes its checks.
pub fn checkpoint_resume(data: &[u8], dir: &Path) -> bool {
    let mut r = Reader(data);
    let head = r.byte();
    let which = usize::from(head & 1);
    let base = &base_checkpoints()[which];
    let file = if head & 2 != 0 {
        r.0.to_vec()
    } else {
        let mut file = base[..40].to_vec();
        for _ in 0..16 {
            if r.done() {
                break;
            }
            record(base, &mut file, &mut r);
        }
        file
    };
    let output = dir.join("resumed.lrr");
    let rows = checkpoint::path_for(&output);
    let first_pass = checkpoint::first_pass_path(&rows);
    let (fuzzed, other) = if which == 0 {
        (&rows, &first_pass)
    } else {
        (&first_pass, &rows)
    };
    std::fs::write(fuzzed, file).expect("cannot write the fuzz checkpoint");
    let _ = std::fs::remove_file(other);
    let mut s = settings(Some(lrr_precompute::refine::DEFAULT_BUDGET));
    s.checkpoint = Some(CheckpointSettings {
        path: rows.clone(),
        resume: true,
        block_rows: Some(BLOCK_ROWS),
    });
    let Ok(baked) = bake(scene(), &s, &Progress::hidden()) else {
        return false;
    };
    let file = lrr_precompute::write::operator_file(&baked)
        .expect("a bake resumed from a checkpoint makes a file that passes its checks");
    file.to_bytes()
        .expect("a bake resumed from a checkpoint passes the checks its encoding runs");
    true
}

/// The records of a valid checkpoint (after its 40-byte header): block index → f64 payload.
fn base_records(base: &[u8]) -> Vec<(u64, &[u8])> {
    let mut out = Vec::new();
    let mut at = 40;
    while let (Some(index), Some(len)) = (word(base, at), word(base, at + 8)) {
        let end = at + 24 + len as usize;
        out.push((index, &base[at + 24..end]));
        at = end;
    }
    out
}

/// One record appended to `file`: `index` (a byte: any block, or past the last), then the
/// length (mode 0-5: the base record's of that block, 6: a byte × 8, 7: a u16), the values
/// (0-3: the base's, 4: zeros, 5: raw f64s from the input, 6-7: the base's with up to three
/// set to NaN, ∞, −1, 2, 1e300 or a subnormal) and the checksum (right unless mode bit 0).
fn record(base: &[u8], file: &mut Vec<u8>, r: &mut Reader) {
    let index = u64::from(r.byte());
    let records = base_records(base);
    let valid: &[u8] = records
        .iter()
        .find(|(i, _)| *i == index)
        .map_or(&[][..], |(_, p)| p);
    let len = match r.byte() % 8 {
        0..=5 => valid.len(),
        6 => usize::from(r.byte()) * 8,
        _ => usize::from(r.u16()),
    };
    let mut payload: Vec<u8> = valid.iter().copied().cycle().take(len).collect();
    payload.resize(len, 0);
    match r.byte() % 8 {
        0..=3 => {}
        4 => payload.fill(0),
        5 => {
            for b in &mut payload {
                *b = r.byte();
            }
        }
        _ => {
            for _ in 0..1 + r.byte() % 3 {
                let value: f64 = match r.byte() % 6 {
                    0 => f64::NAN,
                    1 => f64::INFINITY,
                    2 => -1.0,
                    3 => 2.0,
                    4 => 1e300,
                    _ => f64::from_bits(1),
                };
                let at = 8 * (usize::from(r.byte()) % (len / 8).max(1));
                if at + 8 <= payload.len() {
                    payload[at..at + 8].copy_from_slice(&value.to_le_bytes());
                }
            }
        }
    }
    let bad_sum = r.byte() & 1 != 0;
    file.extend_from_slice(&index.to_le_bytes());
    file.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    let sum = checksum(&payload) ^ u64::from(bad_sum);
    file.extend_from_slice(&sum.to_le_bytes());
    file.extend_from_slice(&payload);
}
