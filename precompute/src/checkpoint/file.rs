//! Checkpoints of the form-factor stage, so a killed or interrupted bake resumes where it
//! stopped (`lrr bake … --resume`) and still writes the same bytes.
//!
//! Rows of `F_k` are computed in blocks; after each block its rows are appended to
//! `OUT.lrr.ckpt` and flushed. A record is `block index, byte length, checksum, f64 payload`;
//! a record cut short by a crash fails its length or checksum and is dropped on resume (with
//! everything after it), and so is one holding a value no bake writes (negative or not
//! finite). The header holds a key hashed from everything `F_k` depends on (the
//! scene geometry, mesh sizes, the mesh itself, samples, n, k, the lrr version), so a
//! checkpoint is never applied to a different bake. A successful bake deletes its checkpoint.
//! `--refine`'s first pass keeps its rows the same way in `OUT.lrr.first-pass.ckpt`
//! ([`first_pass_path`]).

use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

const MAGIC: &[u8; 8] = b"LRRCKPT1";
const HEADER: usize = 8 + 8 * 4;
const RECORD_HEADER: usize = 8 * 3;

/// A saved block: its index and its rows (row-major, k values per row).
pub(super) type SavedBlock = (u64, Vec<f64>);

/// An open checkpoint file.
pub struct Checkpoint {
    path: PathBuf,
    file: File,
    /// Rows taken from the file when resuming (0 for a fresh checkpoint).
    pub(crate) resumed_rows: u64,
    /// Rows the checkpoint covers (its shape's `n`).
    rows: u64,
}

/// What a checkpoint describes: the bake it belongs to and its block size.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shape {
    pub key: u64,
    pub n: u64,
    pub k: u64,
    pub block_rows: u64,
}

impl Shape {
    fn to_bytes(self) -> Vec<u8> {
        let mut b = MAGIC.to_vec();
        for v in [self.key, self.n, self.k, self.block_rows] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b
    }
}

/// The checkpoint path of an output file: `OUT.lrr.ckpt`.
pub fn path_for(output: &Path) -> PathBuf {
    let mut name = output.file_name().unwrap_or_default().to_os_string();
    name.push(".ckpt");
    output.with_file_name(name)
}

/// The checkpoint of `--refine`'s first pass beside a bake's checkpoint `path`
/// (`OUT.lrr.ckpt` → `OUT.lrr.first-pass.ckpt`): the rows of the unrefined mesh's `F_k`
/// that decide where the mesh is split, kept until the bake's output is written, so a resumed
/// bake rebuilds the same refined mesh without integrating them again.
pub fn first_pass_path(path: &Path) -> PathBuf {
    let name = path.file_name().unwrap_or_default().to_string_lossy();
    let stem = name.strip_suffix(".ckpt").unwrap_or(&name);
    path.with_file_name(format!("{stem}.first-pass.ckpt"))
}

impl Checkpoint {
    /// Starts a fresh checkpoint (replacing any old one).
    pub fn create(path: &Path, shape: Shape) -> Result<Self> {
        let mut file = File::create(path).map_err(|e| Error::io(path, e))?;
        file.write_all(&shape.to_bytes())
            .map_err(|e| Error::io(path, e))?;
        file.flush().map_err(|e| Error::io(path, e))?;
        Ok(Self {
            path: path.to_path_buf(),
            file,
            resumed_rows: 0,
            rows: shape.n,
        })
    }

    /// Opens an existing checkpoint to resume: returns the blocks it holds (index → rows).
    /// A checkpoint of another bake is an error; a torn last record is dropped.
    pub fn resume(path: &Path, shape: Shape) -> Result<(Self, Vec<SavedBlock>)> {
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .open(path)
            .map_err(|e| {
                Error::io(
                    path,
                    std::io::Error::new(
                        e.kind(),
                        format!("cannot resume: {e} (no interrupted bake to continue)"),
                    ),
                )
            })?;
        let mut bytes = Vec::new();
        file.read_to_end(&mut bytes)
            .map_err(|e| Error::io(path, e))?;
        if bytes.len() < HEADER || bytes[..HEADER] != shape.to_bytes()[..] {
            return Err(Error::Settings(format!(
                "{}: this checkpoint belongs to a different bake (the scene, its materials, the mesh \
                 sizes, the samples or the lrr version changed); delete it or bake without --resume",
                path.display()
            )));
        }
        let mut blocks = Vec::new();
        let mut at = HEADER;
        while let Some((index, rows, next)) = read_record(&bytes, at, shape) {
            blocks.push((index, rows));
            at = next;
        }
        // Drop a torn tail so new records follow the last good one.
        file.set_len(at as u64).map_err(|e| Error::io(path, e))?;
        file.seek(SeekFrom::End(0))
            .map_err(|e| Error::io(path, e))?;
        Ok((
            Self {
                path: path.to_path_buf(),
                file,
                resumed_rows: 0,
                rows: shape.n,
            },
            blocks,
        ))
    }

    /// Appends one finished block and flushes it to the operating system.
    pub fn append(&mut self, index: u64, rows: &[f64]) -> Result<()> {
        let mut payload = Vec::with_capacity(rows.len() * 8);
        for r in rows {
            payload.extend_from_slice(&r.to_le_bytes());
        }
        let mut record = Vec::with_capacity(RECORD_HEADER + payload.len());
        record.extend_from_slice(&index.to_le_bytes());
        record.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        record.extend_from_slice(&lrr_formats::checksum(&payload).to_le_bytes());
        record.extend_from_slice(&payload);
        self.file
            .write_all(&record)
            .map_err(|e| Error::io(&self.path, e))?;
        self.file.flush().map_err(|e| Error::io(&self.path, e))
    }

    /// Rows of `F_k` this run took from the checkpoint instead of computing them.
    pub fn resumed_rows(&self) -> u64 {
        self.resumed_rows
    }

    /// Rows the checkpoint covers.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// Deletes the checkpoint (after the output was written).
    pub fn remove(self) -> Result<()> {
        drop(self.file);
        std::fs::remove_file(&self.path).map_err(|e| Error::io(&self.path, e))
    }
}

fn read_u64(bytes: &[u8], at: usize) -> Option<u64> {
    bytes
        .get(at..at + 8)
        .map(|b| u64::from_le_bytes(b.try_into().expect("8 bytes")))
}

/// One record at `at`, validated against the shape; `None` at the end or on damage.
fn read_record(bytes: &[u8], at: usize, shape: Shape) -> Option<(u64, Vec<f64>, usize)> {
    let index = read_u64(bytes, at)?;
    let len = usize::try_from(read_u64(bytes, at + 8)?).ok()?;
    let sum = read_u64(bytes, at + 16)?;
    let blocks = shape.n.div_ceil(shape.block_rows.max(1));
    let rows_in_block = shape
        .block_rows
        .min(shape.n.checked_sub(index.checked_mul(shape.block_rows)?)?);
    if index >= blocks || len as u64 != rows_in_block.checked_mul(shape.k)?.checked_mul(8)? {
        return None;
    }
    let start = at + RECORD_HEADER;
    let payload = bytes.get(start..start.checked_add(len)?)?;
    if lrr_formats::checksum(payload) != sum {
        return None;
    }
    let rows: Vec<f64> = payload
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
        .collect();
    // Form factors are finite and >= 0; a record holding anything else was not written by a
    // bake (the `checkpoint_resume` fuzz target resumed a -1 into F_k, which the file's
    // checks then refused at the very end). Damage, like a torn record: dropped, recomputed.
    if !rows.iter().all(|v| v.is_finite() && *v >= 0.0) {
        return None;
    }
    Some((index, rows, start + len))
}

/// The key of a bake: a hash of everything its form factors depend on.
pub(super) fn hash_parts(parts: &[&[u8]]) -> u64 {
    let mut all = Vec::new();
    for p in parts {
        all.extend_from_slice(&(p.len() as u64).to_le_bytes());
        all.extend_from_slice(p);
    }
    lrr_formats::checksum(&all)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_survive_and_torn_tails_are_dropped() {
        let dir = std::env::temp_dir().join(format!("lrr-ckpt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("x.lrr.ckpt");
        let shape = Shape {
            key: 42,
            n: 5,
            k: 2,
            block_rows: 2,
        };
        let mut c = Checkpoint::create(&path, shape).unwrap();
        c.append(0, &[1.0, 2.0, 3.0, 4.0]).unwrap();
        c.append(2, &[9.0, 10.0]).unwrap();
        c.append(1, &[5.0, 6.0, 7.0, 8.0]).unwrap();
        drop(c);
        // Tear the last record.
        let len = std::fs::metadata(&path).unwrap().len();
        OpenOptions::new()
            .write(true)
            .open(&path)
            .unwrap()
            .set_len(len - 3)
            .unwrap();
        let (mut c, blocks) = Checkpoint::resume(&path, shape).unwrap();
        assert_eq!(
            blocks,
            vec![(0, vec![1.0, 2.0, 3.0, 4.0]), (2, vec![9.0, 10.0])]
        );
        c.append(1, &[5.0, 6.0, 7.0, 8.0]).unwrap();
        drop(c);
        let (_, blocks) = Checkpoint::resume(&path, shape).unwrap();
        assert_eq!(blocks.len(), 3);
        // A record with a value no bake writes is damage too: dropped with what follows.
        let (mut c, _) = Checkpoint::resume(&path, shape).unwrap();
        c.append(0, &[1.0, -1.0, 3.0, 4.0]).unwrap();
        c.append(2, &[f64::NAN, 10.0]).unwrap();
        drop(c);
        let (_, blocks) = Checkpoint::resume(&path, shape).unwrap();
        assert_eq!(blocks.len(), 3);
        let other = Shape { key: 43, ..shape };
        let e = Checkpoint::resume(&path, other).err().unwrap().to_string();
        assert!(e.contains("different bake"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
