//! The bodies of the operator file targets (`operator_bytes`, `operator_mutated`), shared with
//! the replay test: `fuzz_targets/*.rs` call them through this crate, and
//! `tests/tests/e2e/fuzz_replay.rs` includes this file with `#[path]` and runs every seed and
//! every committed crash input through the same functions, so CI replays them on the stable
//! toolchain without cargo-fuzz.
//!
//! Each function takes the fuzzer's bytes and returns whether the input was accepted; refusing
//! it (an `Err`) is fine, panicking is the bug the fuzzer looks for. The functions use only the
//! public APIs of lrr-formats and lrr-runtime.

use lrr_formats::{Container, ContainerWriter, checksum, kind};
use lrr_runtime::Operator;

use super::reader::Reader;

/// `operator_bytes`: any bytes through the loader. A file that loads must evaluate its own
/// baked emission and locate a point: both are infallible on a validated operator. A file with
/// lightmap coordinates must also build a small lightmap over them (16 × 16 texels, whatever
/// atlas the file names: a hostile ATLAS could ask for 16384², which the allocation meter would
/// rightly flag) and fill it from that frame.
pub fn operator_bytes(data: &[u8]) -> bool {
    let Ok(op) = Operator::from_bytes(data) else {
        return false;
    };
    let emission = op.baked_emission();
    let mut radiosity = vec![[0.0f32; 3]; op.n()];
    if let Err(e) = op.evaluate(&emission, &mut radiosity) {
        panic!("a loaded operator refuses its own baked emission: {e}");
    }
    assert!(
        op.locate([0.5, 0.5, 0.0], [0.0, 0.0, 1.0]).is_some(),
        "a loaded operator has no element to locate"
    );
    if op.file().display.lightmap.is_some() {
        let mut map =
            lrr_runtime::Lightmap::with_size(op.file(), 16, 16, 2, None).unwrap_or_else(|e| {
                panic!("a loaded operator's lightmap coordinates are refused: {e}")
            });
        let mut texels = vec![[0.0f32; 3]; 16 * 16];
        if let Err(e) = map.fill(&radiosity, &mut texels) {
            panic!("a lightmap refuses its own operator's frame: {e}");
        }
        assert!(texels.iter().flatten().all(|v| v.is_finite()) || !radiosity_finite(&radiosity));
    }
    true
}

fn radiosity_finite(b: &[[f32; 3]]) -> bool {
    b.iter().flatten().all(|v| v.is_finite())
}

/// `operator_mutated`: a valid operator file edited as the fuzzer's bytes say, then loaded. See
/// [`mutate`] for how the bytes are read.
pub fn operator_mutated(data: &[u8]) -> bool {
    operator_bytes(&mutate(data))
}

/// Builds a file from a valid base and edits read from `data`, so that the fuzzer gets past the
/// checksums into the decoder and the validator:
///
/// 1. byte 0 picks the base ([`base_file`]: precision, channels, shape) and whether the raw
///    edits of step 3 are resealed (bit 7);
/// 2. section edits, one opcode byte each, applied to the base's sections, which are then
///    re-packed with [`ContainerWriter`] (valid layout and checksums): overwrite bytes, set a
///    u32 / f32 / f64 to an interesting value, truncate, append, add, remove, re-kind or swap
///    sections;
/// 3. after opcode 10, raw edits of the packed bytes (header and section table included):
///    overwrite, set a u64, truncate, append; with the reseal bit the checksums are recomputed
///    afterwards wherever the table allows, so damaged offsets and lengths reach the layout
///    checks instead of failing the header checksum.
pub fn mutate(data: &[u8]) -> Vec<u8> {
    mutate_from(data, base_file)
}

/// [`mutate`] with the bases `base(variant)` (the trace target's files with display sections).
pub fn mutate_from(data: &[u8], base: impl Fn(u8) -> Vec<u8>) -> Vec<u8> {
    let mut r = Reader(data);
    let variant = r.byte();
    let base = base(variant);
    let container = Container::parse(&base).expect("the base files are valid");
    let mut sections: Vec<(u32, bool, Vec<u8>)> = container
        .sections()
        .iter()
        .map(|s| {
            (
                s.kind,
                s.required(),
                container.section(s.kind).unwrap().to_vec(),
            )
        })
        .collect();
    while !r.done() {
        let op = r.byte() % 11;
        if op == 10 {
            break;
        }
        edit_section(&mut sections, op, &mut r);
    }
    let mut writer = ContainerWriter::new();
    let (major, minor) = container.version();
    writer.set_version(major, minor);
    for (kind, required, payload) in sections {
        writer.add(kind, required, payload);
    }
    let mut bytes = writer.to_bytes();
    while !r.done() {
        edit_raw(&mut bytes, &mut r);
    }
    if variant & 0x80 != 0 {
        reseal(&mut bytes);
    }
    bytes
}

/// One step-2 edit (see [`mutate`]); edits that do not apply are skipped.
fn edit_section(sections: &mut Vec<(u32, bool, Vec<u8>)>, op: u8, r: &mut Reader) {
    let count = sections.len();
    let which = usize::from(r.byte());
    let kinds: Vec<u32> = sections.iter().map(|s| s.0).collect();
    if op == 7 {
        // Add a section of a small kind code (known up to format 1.3's LIGHTMAP, 18, or unknown).
        let kind = u32::from(r.byte() % 20);
        let required = r.byte() & 1 == 1;
        let len = usize::from(r.byte() % 64);
        let payload = r.take(len).to_vec();
        if !kinds.contains(&kind) {
            sections.push((kind, required, payload));
        }
        return;
    }
    if count == 0 {
        return;
    }
    let s = which % count;
    let payload = &mut sections[s].2;
    match op {
        0 => {
            let at = usize::from(r.u16()) % (payload.len() + 1);
            let len = 1 + usize::from(r.byte() % 8);
            put(payload, at, r.take(len));
        }
        1 => {
            let at = 4 * (usize::from(r.u16()) % (payload.len() / 4 + 1));
            put(payload, at, &interesting_u32(r).to_le_bytes());
        }
        2 => {
            let at = 4 * (usize::from(r.u16()) % (payload.len() / 4 + 1));
            put(payload, at, &interesting_f32(r).to_le_bytes());
        }
        3 => {
            let at = 8 * (usize::from(r.u16()) % (payload.len() / 8 + 1));
            put(payload, at, &f64::from(interesting_f32(r)).to_le_bytes());
        }
        4 => {
            let len = usize::from(r.u16()) % (payload.len() + 1);
            payload.truncate(len);
        }
        5 => {
            let len = usize::from(r.byte());
            payload.extend_from_slice(r.take(len));
        }
        6 => {
            sections.remove(s);
        }
        8 => {
            let kind = u32::from(r.byte() % 20);
            if kinds.contains(&kind) {
                sections[s].1 = !sections[s].1;
            } else {
                sections[s].0 = kind;
            }
        }
        _ => {
            let t = usize::from(r.byte()) % count;
            sections.swap(s, t);
        }
    }
}

/// One step-3 edit of the packed bytes.
fn edit_raw(bytes: &mut Vec<u8>, r: &mut Reader) {
    let op = r.byte() % 4;
    let at = usize::from(r.u16()) % (bytes.len() + 1);
    match op {
        0 => {
            let len = 1 + usize::from(r.byte() % 8);
            put(bytes, at, r.take(len));
        }
        1 => {
            let value = match r.byte() % 8 {
                0 => 0,
                1 => 64,
                2 => bytes.len() as u64,
                3 => (bytes.len() as u64).next_multiple_of(64),
                4 => u64::MAX,
                5 => 1 << 32,
                6 => 1 << 63,
                _ => u64::from(r.u32()),
            };
            put(bytes, at & !7, &value.to_le_bytes());
        }
        2 => bytes.truncate(at),
        _ => {
            let len = usize::from(r.byte());
            bytes.extend_from_slice(r.take(len));
        }
    }
}

/// Recomputes every payload checksum the table lets us find, then the header checksum (layout:
/// lrr_formats' crate docs). Does nothing when the table does not fit in the bytes.
pub fn reseal(bytes: &mut [u8]) {
    let word = |b: &[u8], at: usize, n: usize| -> Option<u64> {
        let mut v = [0u8; 8];
        v[..n].copy_from_slice(b.get(at..at.checked_add(n)?)?);
        Some(u64::from_le_bytes(v))
    };
    let Some(count) = word(bytes, 12, 4) else {
        return;
    };
    let table_end = 64 + (count * 40).next_multiple_of(64);
    if table_end > bytes.len() as u64 {
        return;
    }
    let table_end = table_end as usize;
    for i in 0..count as usize {
        let at = 64 + 40 * i;
        let (Some(offset), Some(length)) = (word(bytes, at + 8, 8), word(bytes, at + 16, 8)) else {
            return;
        };
        let payload = offset
            .checked_add(length)
            .and_then(|end| bytes.get(offset as usize..usize::try_from(end).ok()?));
        if let Some(payload) = payload {
            let sum = checksum(payload);
            bytes[at + 24..at + 32].copy_from_slice(&sum.to_le_bytes());
        }
    }
    let mut head = bytes[..table_end].to_vec();
    head[20..28].fill(0);
    let sum = checksum(&head);
    bytes[20..28].copy_from_slice(&sum.to_le_bytes());
}

/// Writes `src` at `at`, growing `dst` when it runs past the end.
fn put(dst: &mut Vec<u8>, at: usize, src: &[u8]) {
    let end = at + src.len();
    if dst.len() < end {
        dst.resize(end, 0);
    }
    dst[at..end].copy_from_slice(src);
}

fn interesting_u32(r: &mut Reader) -> u32 {
    match r.byte() % 12 {
        0 => 0,
        1 => 1,
        2 => 2,
        3 => 3,
        4 => 5,
        5 => 6,
        6 => 7,
        7 => u32::MAX,
        8 => 1 << 31,
        9 => 1 << 16,
        10 => 0x3f80_0000, // 1.0f32
        _ => r.u32(),
    }
}

fn interesting_f32(r: &mut Reader) -> f32 {
    match r.byte() % 14 {
        0 => f32::NAN,
        1 => f32::INFINITY,
        2 => f32::NEG_INFINITY,
        3 => -1.0,
        4 => -0.0,
        5 => 0.0,
        6 => 0.5,
        7 => 1.0,
        8 => 1.000_000_1,
        9 => 2.0,
        10 => 1e30,
        11 => f32::MIN_POSITIVE,
        12 => f32::from_bits(1), // subnormal
        _ => f32::from_bits(r.u32()),
    }
}

/// A valid version 1.0 operator file, encoded by hand from the layout in lrr_formats' crate docs
/// (not through `OperatorFile`, so that this harness does not follow every change of that
/// struct; readers of major 1 read 1.0 files). `variant` bit 0: binary16 `F_k`; bit 1: three
/// cores instead of one; bit 2: n = 3 elements in k = 3 patches instead of n = 6 in k = 2.
pub fn base_file(variant: u8) -> Vec<u8> {
    let f16 = variant & 1 != 0;
    let channels: u32 = if variant & 2 != 0 { 3 } else { 1 };
    let (n, k, order, index): (u32, u32, &[u32], &[u32]) = if variant & 4 != 0 {
        (3, 3, &[2, 0, 1], &[0, 1, 2, 3])
    } else {
        (6, 2, &[3, 0, 5, 1, 4, 2], &[0, 3, 6])
    };
    let (nu, ku) = (n as usize, k as usize);
    let u32s = |v: &[u32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let f32s = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    // Weights: each patch's elements share its area equally.
    let weights: Vec<f32> = (0..ku)
        .flat_map(|p| {
            let size = index[p + 1] - index[p];
            (0..size).map(move |_| 1.0 / size as f32)
        })
        .collect();
    let fk: Vec<f32> = (0..nu * ku).map(|i| 0.05 * (i % 5) as f32).collect();
    let fk_bytes = if f16 {
        fk.iter()
            .flat_map(|&v| lrr_formats::f32_to_f16(v).to_le_bytes())
            .collect()
    } else {
        f32s(&fk)
    };
    let cores: Vec<u8> = (0..channels as usize * ku * ku)
        .flat_map(|i| (1.0 + i as f64 / 8.0).to_le_bytes())
        .collect();
    let reflectance: Vec<f32> = (0..3 * nu).map(|i| (i % 10) as f32 / 20.0).collect();
    let emission: Vec<f32> = (0..3 * nu).map(|i| if i < 3 { 5.0 } else { 0.0 }).collect();
    // Geometry: element e is the unit square (quads, even e) or its lower triangle at x = e.
    let mut geometry: Vec<u8> = (0..nu).map(|e| if e % 2 == 0 { 4 } else { 3 }).collect();
    geometry.resize(nu.next_multiple_of(4), 0);
    let mut vertices = Vec::new();
    for e in 0..nu {
        let x = e as f32;
        vertices.extend([x, 0.0, 0.0, x + 1.0, 0.0, 0.0, x + 1.0, 1.0, 0.0]);
        vertices.extend(if e % 2 == 0 { [x, 1.0, 0.0] } else { [0.0; 3] });
    }
    geometry.extend(f32s(&vertices));
    geometry.extend(f32s(&[0.0, 0.0, 1.0].repeat(nu)));
    let dims = u32s(&[n, k, channels, u32::from(f16), 0, 0, 0, 0]);
    let mut w = ContainerWriter::new();
    w.set_version(1, 0);
    w.add(kind::METADATA, true, br#"{"scene":"fuzz base"}"#.to_vec());
    w.add(kind::DIMS, true, dims);
    w.add(kind::ORDER, true, u32s(order));
    w.add(kind::INDEX, true, u32s(index));
    w.add(kind::WEIGHTS, true, f32s(&weights));
    w.add(kind::FK, true, fk_bytes);
    w.add(kind::CORES, true, cores);
    w.add(kind::REFLECTANCE, true, f32s(&reflectance));
    w.add(kind::EMISSION, true, f32s(&emission));
    w.add(kind::GEOMETRY, true, geometry);
    w.to_bytes()
}
