//! The part file of one shard: `lrr bake SCENE --shard i/N -o part-i.bin`.
//!
//! Layout, little-endian:
//!
//! | bytes | what |
//! |---|---|
//! | 8 | magic `LRRPART1` |
//! | 8 + 8 | header length, XXH64 of the header |
//! | header | lrr version, scene content hash, bake settings, shard i and N, n, k, the N + 1 row boundaries of every shard, rows per record, length and XXH64 of the skeleton |
//! | skeleton | everything of the operator file but `F_k` and the cores (`write::Skeleton`): the same in every part |
//! | records | the shard's rows of `F_k` in f64, in records of at most `record_rows` rows: first row, row count, XXH64 of the payload, payload |
//!
//! The header fixes the length of the whole file, so a truncated part is named before
//! anything is read; each record's checksum catches damage inside. Parts are written
//! atomically, like operator files.

use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Write};
use std::ops::Range;
use std::path::{Path, PathBuf};

use lrr_formats::{Display, Geometry, Xxh64, checksum};

use crate::error::{Error, Result};
use crate::write::{Skeleton, SurfaceRanges};

const MAGIC: &[u8; 8] = b"LRRPART1";
const RECORD_HEADER: u64 = 24;
/// Headers above this are damage, not parts (a real one is 100 bytes plus 8 per shard).
const MAX_HEADER: u64 = 1 << 24;

/// What a part says about itself: the bake it belongs to and which rows it holds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PartHeader {
    /// `lrr VERSION` of the binary that baked it.
    pub version: String,
    /// Hash of the scene's content (geometry, materials, surfaces, name).
    pub scene_hash: u64,
    /// The settings that decide `F_k` and the file, as text (mesh sizes, method, samples,
    /// visibility).
    pub settings: String,
    /// This part's shard, from 0.
    pub shard: usize,
    /// Number of shards.
    pub count: usize,
    /// Elements and patches of the bake.
    pub n: usize,
    /// Patches of the bake.
    pub k: usize,
    /// `count + 1` row boundaries: shard `i` holds rows `boundaries[i]..boundaries[i + 1]`.
    pub boundaries: Vec<usize>,
    /// Rows per record.
    pub record_rows: usize,
    /// XXH64 of the skeleton.
    pub skeleton_hash: u64,
    /// Bytes of the skeleton.
    pub skeleton_len: u64,
}

impl PartHeader {
    /// The rows of `F_k` (file positions) this part holds.
    pub fn rows(&self) -> Range<usize> {
        self.boundaries[self.shard]..self.boundaries[self.shard + 1]
    }

    /// Length of a complete part with this header; `None` past `u64::MAX` (a damaged header:
    /// the `shard_part` fuzz target found a skeleton length near 2⁶⁴ overflowing the sum).
    fn file_len(&self, header_len: u64) -> Option<u64> {
        let rows = self.rows().len() as u64;
        let records = rows.div_ceil(self.record_rows.max(1) as u64);
        24u64
            .checked_add(header_len)?
            .checked_add(self.skeleton_len)?
            .checked_add(records.checked_mul(RECORD_HEADER)?)?
            .checked_add(rows.checked_mul(self.k as u64)?.checked_mul(8)?)
    }

    fn to_bytes(&self) -> Vec<u8> {
        let mut e = Enc::default();
        e.str(&self.version);
        e.u64(self.scene_hash);
        e.str(&self.settings);
        for v in [self.shard, self.count, self.n, self.k, self.record_rows] {
            e.u64(v as u64);
        }
        e.u64s(self.boundaries.iter().map(|&b| b as u64));
        e.u64(self.skeleton_hash);
        e.u64(self.skeleton_len);
        e.0
    }

    fn from_bytes(bytes: &[u8]) -> std::result::Result<Self, String> {
        let mut d = Dec::new(bytes);
        let version = d.str()?;
        let scene_hash = d.u64()?;
        let settings = d.str()?;
        let [shard, count, n, k, record_rows] = [(); 5].map(|_| d.usize());
        let (shard, count, n, k, record_rows) = (shard?, count?, n?, k?, record_rows?);
        let boundaries: Vec<usize> = d.u64s()?.into_iter().map(|b| b as usize).collect();
        let header = Self {
            version,
            scene_hash,
            settings,
            shard,
            count,
            n,
            k,
            boundaries,
            record_rows,
            skeleton_hash: d.u64()?,
            skeleton_len: d.u64()?,
        };
        d.end()?;
        let b = &header.boundaries;
        // `count + 1` would overflow for a count of usize::MAX (the `shard_part` fuzz target).
        let consistent = shard < count
            && b.len().checked_sub(1) == Some(count)
            && b.first() == Some(&0)
            && b.last() == Some(&n)
            && b.windows(2).all(|w| w[0] <= w[1])
            && record_rows > 0
            && n.checked_mul(k).and_then(|x| x.checked_mul(8)).is_some();
        if !consistent {
            return Err("its header is inconsistent (shard, boundaries or sizes)".into());
        }
        Ok(header)
    }
}

/// Writes a part atomically: `rows` holds the header's rows of `F_k`, row-major.
pub(crate) fn write(path: &Path, header: &PartHeader, skeleton: &[u8], rows: &[f64]) -> Result<()> {
    let head = header.to_bytes();
    let k = header.k.max(1);
    let first = header.rows().start;
    lrr_formats::write_atomic_with(path, &mut |file| {
        let io = |e: std::io::Error| {
            lrr_formats::FormatError::new(
                lrr_formats::ErrorKind::Io,
                format!("cannot write {}: {e}", path.display()),
            )
        };
        let mut out = BufWriter::new(file);
        out.write_all(MAGIC).map_err(io)?;
        for v in [head.len() as u64, checksum(&head)] {
            out.write_all(&v.to_le_bytes()).map_err(io)?;
        }
        out.write_all(&head).map_err(io)?;
        out.write_all(skeleton).map_err(io)?;
        for (r, record) in rows.chunks(header.record_rows * k).enumerate() {
            let payload: Vec<u8> = record.iter().flat_map(|v| v.to_le_bytes()).collect();
            let start = first + r * header.record_rows;
            for v in [start as u64, (record.len() / k) as u64, checksum(&payload)] {
                out.write_all(&v.to_le_bytes()).map_err(io)?;
            }
            out.write_all(&payload).map_err(io)?;
        }
        out.flush().map_err(io)
    })?;
    Ok(())
}

/// An open part: its header read and its length checked.
pub(crate) struct PartReader {
    pub path: PathBuf,
    pub header: PartHeader,
    file: BufReader<File>,
}

impl PartReader {
    /// Opens a part and reads its header; a file that is no part, or has another length than
    /// its header implies (truncated), is an error naming it.
    pub(crate) fn open(path: &Path) -> Result<Self> {
        let bad = |m: String| Error::part(path, m);
        let file = File::open(path).map_err(|e| Error::io(path, e))?;
        let len = file.metadata().map_err(|e| Error::io(path, e))?.len();
        let mut file = BufReader::with_capacity(1 << 16, file);
        let mut start = [0u8; 24];
        if len < 24 || file.read_exact(&mut start).is_err() || &start[..8] != MAGIC {
            return Err(bad(format!(
                "not a part of a sharded bake ({len} bytes, no LRRPART1 header): pass the files \
                 written by `lrr bake SCENE --shard i/N -o PART`"
            )));
        }
        let word = |i: usize| u64::from_le_bytes(start[i..i + 8].try_into().expect("8 bytes"));
        let (head_len, head_sum) = (word(8), word(16));
        if head_len > MAX_HEADER || head_len > len - 24 {
            return Err(bad(format!(
                "truncated or damaged: its header claims {head_len} bytes, the file has {len}"
            )));
        }
        let mut head = vec![0u8; head_len as usize];
        file.read_exact(&mut head).map_err(|e| Error::io(path, e))?;
        if checksum(&head) != head_sum {
            return Err(bad("damaged: the header's checksum does not match".into()));
        }
        let header = PartHeader::from_bytes(&head).map_err(|m| bad(format!("damaged: {m}")))?;
        let expected = header.file_len(head_len).ok_or_else(|| {
            bad(format!(
                "damaged: the sizes in its header (skeleton {} bytes, rows {}..{} of {} \
                 patches) add up past 2^64 bytes; bake this shard again",
                header.skeleton_len,
                header.rows().start,
                header.rows().end,
                header.k
            ))
        })?;
        if len != expected {
            let what = if len < expected {
                "truncated"
            } else {
                "too long"
            };
            return Err(bad(format!(
                "{what}: {len} bytes, but a complete part of shard {}/{} (rows {}..{}) has \
                 {expected}; bake this shard again",
                header.shard,
                header.count,
                header.rows().start,
                header.rows().end
            )));
        }
        Ok(Self {
            path: path.to_path_buf(),
            header,
            file,
        })
    }

    /// Reads the skeleton (next after the header), checked against its hash.
    pub(crate) fn skeleton(&mut self) -> Result<Skeleton> {
        let mut bytes = vec![0u8; self.header.skeleton_len as usize];
        self.file
            .read_exact(&mut bytes)
            .map_err(|e| Error::io(&self.path, e))?;
        if checksum(&bytes) != self.header.skeleton_hash {
            return Err(Error::part(
                &self.path,
                "damaged: the skeleton's checksum does not match",
            ));
        }
        decode_skeleton(&bytes).map_err(|m| Error::part(&self.path, format!("damaged: {m}")))
    }

    /// Skips the skeleton.
    pub(crate) fn skip_skeleton(&mut self) -> Result<()> {
        let len = self.header.skeleton_len as i64;
        self.file
            .seek_relative(len)
            .map_err(|e| Error::io(&self.path, e))
    }

    /// Hands this part's rows to `f` in order, at most `chunk_rows` rows at a time; a record
    /// whose checksum fails is an error naming its rows (after `f` has seen them: callers
    /// write nothing final before every part has been read).
    pub(crate) fn rows(
        &mut self,
        chunk_rows: usize,
        f: &mut dyn FnMut(&[f64]) -> Result<()>,
    ) -> Result<()> {
        let k = self.header.k;
        let range = self.header.rows();
        let mut next = range.start;
        let mut bytes = Vec::new();
        let mut values = Vec::new();
        while next < range.end {
            let mut head = [0u8; RECORD_HEADER as usize];
            self.file
                .read_exact(&mut head)
                .map_err(|e| Error::io(&self.path, e))?;
            let word = |i: usize| u64::from_le_bytes(head[i..i + 8].try_into().expect("8 bytes"));
            let (first, count, sum) = (word(0) as usize, word(8) as usize, word(16));
            let expected = self.header.record_rows.min(range.end - next);
            if first != next || count != expected {
                return Err(Error::part(
                    &self.path,
                    format!(
                        "damaged: the record of rows from {next} says rows {first}, {count} of them"
                    ),
                ));
            }
            let mut hash = Xxh64::new();
            let mut left = count;
            while left > 0 {
                let take = left.min(chunk_rows.max(1));
                bytes.resize(take * k * 8, 0);
                self.file
                    .read_exact(&mut bytes)
                    .map_err(|e| Error::io(&self.path, e))?;
                hash.update(&bytes);
                values.clear();
                values.extend(
                    bytes
                        .chunks_exact(8)
                        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes"))),
                );
                f(&values)?;
                left -= take;
            }
            if hash.finish() != sum {
                return Err(Error::part(
                    &self.path,
                    format!(
                        "damaged: rows {first}..{} fail their checksum; bake shard {}/{} again",
                        first + count,
                        self.header.shard,
                        self.header.count
                    ),
                ));
            }
            next += count;
        }
        Ok(())
    }
}

/// The skeleton's bytes.
pub(crate) fn encode_skeleton(s: &Skeleton) -> Vec<u8> {
    let mut e = Enc::default();
    e.str(&s.scene_name);
    e.str(&s.method);
    match s.refinement {
        None => e.u64(0),
        Some([t, a]) => {
            e.u64(1);
            e.u64(t.to_bits());
            e.u64(a.to_bits());
        }
    }
    e.u64(s.element_size.to_bits());
    e.u64(s.patch_size.to_bits());
    e.u64(u64::from(s.samples));
    e.str(&s.visibility);
    e.u64(s.surfaces.len() as u64);
    for name in &s.surfaces {
        e.str(name);
    }
    e.u64(s.surface_ranges.len() as u64);
    for r in &s.surface_ranges {
        e.str(&r.name);
        e.u64s(r.elements.as_flattened().iter().map(|&v| u64::from(v)));
    }
    e.u64(s.channels as u64);
    e.u64s(s.order.iter().map(|&v| u64::from(v)));
    e.u64s(s.index.iter().map(|&v| u64::from(v)));
    e.f64s(&s.weights);
    e.f64s(s.reflectance.as_flattened());
    e.f64s(s.emission.as_flattened());
    e.u64s(s.surface_at.iter().map(|&v| u64::from(v)));
    e.bytes(&s.geometry.vertex_count);
    e.f32s(&s.geometry.vertices);
    e.f32s(&s.geometry.normals);
    e.bytes(&s.display.to_container_bytes());
    match s.refine {
        None => e.u64(0),
        Some((budget, split)) => {
            e.u64(1);
            e.u64(budget.to_bits());
            e.u64(split as u64);
        }
    }
    e.0
}

/// The skeleton from its bytes (checked by its hash first: errors here are damage that
/// slipped through, or a bug, never a panic).
fn decode_skeleton(bytes: &[u8]) -> std::result::Result<Skeleton, String> {
    let mut d = Dec::new(bytes);
    let scene_name = d.str()?;
    let method = d.str()?;
    let refinement = match d.u64()? {
        0 => None,
        _ => Some([d.f64()?, d.f64()?]),
    };
    let (element_size, patch_size) = (d.f64()?, d.f64()?);
    let samples = u32::try_from(d.u64()?).map_err(|_| "samples out of range")?;
    let visibility = d.str()?;
    let surfaces = (0..d.count(8)?)
        .map(|_| d.str())
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let mut surface_ranges = Vec::new();
    for _ in 0..d.count(16)? {
        let name = d.str()?;
        let ends = d.u32s()?;
        let elements = ends.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
        surface_ranges.push(SurfaceRanges { name, elements });
    }
    let channels = d.usize()?;
    let rgb = |v: Vec<f64>| v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let mut skeleton = Skeleton {
        scene_name,
        method,
        refinement,
        refine: None, // read after the display, below
        element_size,
        patch_size,
        samples,
        visibility,
        surfaces,
        surface_ranges,
        channels,
        order: d.u32s()?,
        index: d.u32s()?,
        weights: d.f64s()?,
        reflectance: rgb(d.f64s()?),
        emission: rgb(d.f64s()?),
        surface_at: d.u32s()?,
        geometry: Geometry {
            vertex_count: d.bytes()?,
            vertices: d.f32s()?,
            normals: d.f32s()?,
        },
        display: Display::default(),
    };
    let n = skeleton.order.len();
    skeleton.display = Display::from_container_bytes(&d.bytes()?, n as u32)
        .map_err(|e| format!("the display sections: {e}"))?;
    skeleton.refine = match d.u64()? {
        0 => None,
        _ => Some((d.f64()?, d.usize()?)),
    };
    d.end()?;
    let sizes_agree = [
        skeleton.weights.len(),
        skeleton.reflectance.len(),
        skeleton.emission.len(),
        skeleton.surface_at.len(),
        skeleton.geometry.vertex_count.len(),
    ]
    .iter()
    .all(|&l| l == n)
        && skeleton.index.len() >= 2
        && skeleton.index[0] == 0
        && skeleton.index.windows(2).all(|w| w[0] <= w[1])
        && skeleton.index.last() == Some(&(n as u32))
        && skeleton
            .surface_at
            .iter()
            .all(|&s| (s as usize) < skeleton.surfaces.len())
        // Grey or RGB cores: the `shard_part` fuzz target found 4 channels indexing past an
        // element's RGB reflectance when the merge summed the systems (`cores::Systems`).
        && matches!(skeleton.channels, 1 | 3);
    if !sizes_agree {
        return Err(
            "the skeleton's arrays disagree in length (or its channels are not 1 or 3)".into(),
        );
    }
    Ok(skeleton)
}

/// Little-endian encoding: numbers, and length-prefixed strings and arrays.
#[derive(Default)]
pub(super) struct Enc(pub(super) Vec<u8>);

impl Enc {
    pub(super) fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    pub(super) fn str(&mut self, s: &str) {
        self.bytes(s.as_bytes());
    }
    pub(super) fn bytes(&mut self, b: &[u8]) {
        self.u64(b.len() as u64);
        self.0.extend_from_slice(b);
    }
    pub(super) fn u64s(&mut self, v: impl ExactSizeIterator<Item = u64>) {
        self.u64(v.len() as u64);
        v.for_each(|x| self.u64(x));
    }
    pub(super) fn f64s(&mut self, v: &[f64]) {
        self.u64(v.len() as u64);
        v.iter().for_each(|x| self.u64(x.to_bits()));
    }
    pub(super) fn f32s(&mut self, v: &[f32]) {
        self.u64(v.len() as u64);
        v.iter()
            .for_each(|x| self.0.extend_from_slice(&x.to_le_bytes()));
    }
}

/// The reader of [`Enc`]: every length is checked against the bytes left before allocating.
pub(super) struct Dec<'a> {
    bytes: &'a [u8],
    at: usize,
}

pub(super) type Decoded<T> = std::result::Result<T, String>;

impl<'a> Dec<'a> {
    pub(super) fn new(bytes: &'a [u8]) -> Self {
        Self { bytes, at: 0 }
    }
    pub(super) fn take(&mut self, n: usize) -> Decoded<&'a [u8]> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let end = end.ok_or_else(|| format!("ends early (at byte {})", self.at))?;
        let out = &self.bytes[self.at..end];
        self.at = end;
        Ok(out)
    }
    pub(super) fn u64(&mut self) -> Decoded<u64> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }
    pub(super) fn usize(&mut self) -> Decoded<usize> {
        usize::try_from(self.u64()?).map_err(|_| "a size out of range".to_string())
    }
    pub(super) fn f64(&mut self) -> Decoded<f64> {
        Ok(f64::from_bits(self.u64()?))
    }
    /// A count of items of at least `min_bytes` each.
    pub(super) fn count(&mut self, min_bytes: usize) -> Decoded<usize> {
        let n = self.usize()?;
        if n.saturating_mul(min_bytes) > self.bytes.len() - self.at {
            return Err(format!("a count of {n} exceeds the bytes left"));
        }
        Ok(n)
    }
    pub(super) fn bytes(&mut self) -> Decoded<Vec<u8>> {
        let n = self.count(1)?;
        Ok(self.take(n)?.to_vec())
    }
    pub(super) fn str(&mut self) -> Decoded<String> {
        String::from_utf8(self.bytes()?).map_err(|_| "a name is not UTF-8".to_string())
    }
    pub(super) fn u64s(&mut self) -> Decoded<Vec<u64>> {
        let n = self.count(8)?;
        (0..n).map(|_| self.u64()).collect()
    }
    pub(super) fn u32(&mut self) -> Decoded<u32> {
        u32::try_from(self.u64()?).map_err(|_| "an index out of range".to_string())
    }
    pub(super) fn u32s(&mut self) -> Decoded<Vec<u32>> {
        self.u64s()?
            .into_iter()
            .map(|v| u32::try_from(v).map_err(|_| "an index out of range".to_string()))
            .collect()
    }
    pub(super) fn f64s(&mut self) -> Decoded<Vec<f64>> {
        let n = self.count(8)?;
        (0..n).map(|_| self.f64()).collect()
    }
    pub(super) fn f32s(&mut self) -> Decoded<Vec<f32>> {
        let n = self.count(4)?;
        Ok(self
            .take(n * 4)?
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect())
    }
    pub(super) fn end(&self) -> Decoded<()> {
        if self.at == self.bytes.len() {
            Ok(())
        } else {
            Err(format!("{} bytes left over", self.bytes.len() - self.at))
        }
    }
}
