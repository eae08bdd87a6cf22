//! Section LIGHTS: the light groups, their byte encoding (tabled in the crate docs), decoding
//! and invariants.
//!
//! Decoding first walks the records with checked arithmetic, keeping only their offsets (at most
//! one small entry per 32 bytes of payload), and copies values out only once every record has
//! been found inside the payload: a hostile count or length costs an error, not memory.

use crate::bytes::{self, u32_at};
use crate::error::FormatError;
use crate::file::{LightGroup, OperatorFile};

/// Bytes before the first record.
const HEAD: usize = 8;

/// How far a stored `x` may be from the one recomputed from the weights and the emission,
/// relative to the recomputed value (the sums of non-negative terms differ only by rounding).
pub(crate) const X_TOLERANCE: f64 = 1e-5;

/// Encodes `groups` (validated); the caller leaves the section out when there are none.
pub(crate) fn encode(groups: &[LightGroup]) -> Vec<u8> {
    let mut out = Vec::new();
    bytes::put_u32s(&mut out, &[groups.len() as u32, 0]);
    for g in groups {
        bytes::put_u32s(&mut out, &[g.name.len() as u32, g.positions.len() as u32]);
        bytes::put_f64s(&mut out, &g.x);
        out.extend_from_slice(g.name.as_bytes());
        out.resize(out.len().next_multiple_of(8), 0);
        bytes::put_u32s(&mut out, &g.positions);
        bytes::put_f32s(&mut out, &g.emission);
    }
    out
}

/// Where one record's fields lie in the payload.
struct Record {
    x: (usize, usize),
    name: (usize, usize),
    positions: (usize, usize),
    emission: (usize, usize),
}

/// Decodes the payload for `k` patches; lengths and UTF-8 are checked, values are not.
pub(crate) fn decode(payload: &[u8], k: usize) -> Result<Vec<LightGroup>, FormatError> {
    let records = layout(payload, k)?;
    let mut groups = Vec::with_capacity(records.len());
    for (g, r) in records.iter().enumerate() {
        let name = std::str::from_utf8(slice(payload, r.name)).map_err(|e| {
            corrupt(format!(
                "group {g}: the name is not valid UTF-8 (at byte {})",
                e.valid_up_to()
            ))
        })?;
        groups.push(LightGroup {
            name: name.to_string(),
            positions: bytes::u32s(slice(payload, r.positions)),
            emission: bytes::f32s(slice(payload, r.emission)),
            x: bytes::f64s(slice(payload, r.x)),
        });
    }
    Ok(groups)
}

fn slice(payload: &[u8], range: (usize, usize)) -> &[u8] {
    payload.get(range.0..range.1).unwrap_or_default()
}

fn corrupt(message: String) -> FormatError {
    FormatError::corrupt(format!("section LIGHTS (kind 12): {message}"))
}

/// Walks the records without allocating more than one small entry per record that fits.
fn layout(payload: &[u8], k: usize) -> Result<Vec<Record>, FormatError> {
    let count = u32_at(payload, 0).ok_or_else(|| {
        corrupt(format!(
            "{} bytes, too short for the group count",
            payload.len()
        ))
    })?;
    let x_len = k
        .checked_mul(24)
        .ok_or_else(|| FormatError::limits("section LIGHTS: k * 24 overflows"))?;
    let mut at = HEAD;
    // Each record takes at least 32 bytes: the capacity is bounded by the payload, not the count.
    let mut records = Vec::with_capacity((count as usize).min(payload.len() / 32));
    for g in 0..count as usize {
        let past_end = |what: &str| {
            corrupt(format!(
                "group {g} (at byte {at}): {what} runs past the end of the payload ({} bytes)",
                payload.len()
            ))
        };
        let (name_len, m) = match (u32_at(payload, at), u32_at(payload, at + 4)) {
            (Some(l), Some(m)) => (l as usize, m as usize),
            _ => return Err(past_end("the record header")),
        };
        if name_len == 0 || m == 0 {
            return Err(corrupt(format!(
                "group {g}: name length {name_len} and position count {m} must both be at least 1"
            )));
        }
        let mut cursor = at + 8;
        let mut take = |len: Option<usize>, what: &str| -> Result<(usize, usize), FormatError> {
            let end = len
                .and_then(|l| cursor.checked_add(l))
                .filter(|&end| end <= payload.len())
                .ok_or_else(|| past_end(what))?;
            let range = (cursor, end);
            cursor = end;
            Ok(range)
        };
        let x = take(Some(x_len), "x")?;
        let name = take(Some(name_len.next_multiple_of(8)), "the name")?;
        let positions = take(m.checked_mul(4), "the positions")?;
        let emission = take(m.checked_mul(12), "the emission")?;
        records.push(Record {
            x,
            name: (name.0, name.0 + name_len),
            positions,
            emission,
        });
        at = cursor;
    }
    if at != payload.len() {
        return Err(corrupt(format!(
            "{count} groups end at byte {at}, but the payload has {} bytes",
            payload.len()
        )));
    }
    Ok(records)
}

/// The invariants of [`LightGroup`]; messages name the group (index and name) and the problem.
pub(crate) fn check(f: &OperatorFile) -> Result<(), FormatError> {
    let mut names: Vec<(&str, usize)> = f
        .lights
        .iter()
        .enumerate()
        .map(|(i, g)| (g.name.as_str(), i))
        .collect();
    names.sort_unstable();
    if let Some(w) = names.windows(2).find(|w| w[0].0 == w[1].0) {
        return Err(FormatError::invalid(format!(
            "section LIGHTS: groups {} and {} are both named {:?}: names must be unique",
            w[0].1.min(w[1].1),
            w[0].1.max(w[1].1),
            w[0].0
        )));
    }
    let mut x = Vec::new();
    for (i, g) in f.lights.iter().enumerate() {
        check_group(f, g, &mut x).map_err(|m| {
            FormatError::invalid(format!("section LIGHTS: group {i} {:?}: {m}", g.name))
        })?;
    }
    Ok(())
}

/// One group against the file's dimensions, index and weights; `x` is scratch.
fn check_group(f: &OperatorFile, g: &LightGroup, x: &mut Vec<f64>) -> Result<(), String> {
    check_members(f, g)?;
    let k = f.k as usize;
    if g.x.len() != 3 * k {
        return Err(format!(
            "k = {k} patches need {} x values, found {}",
            3 * k,
            g.x.len()
        ));
    }
    if let Some(j) = g.x.iter().position(|v| !v.is_finite()) {
        return Err(format!(
            "x of patch {} channel {}: value {} must be finite",
            j / 3,
            j % 3,
            g.x[j]
        ));
    }
    segment_sums(&f.index, &f.weights, &g.positions, &g.emission, x);
    for (j, (&stored, &expected)) in g.x.iter().zip(x.iter()).enumerate() {
        if (stored - expected).abs() > X_TOLERANCE * expected {
            return Err(format!(
                "x of patch {} channel {} is {stored}, but the weights and the emission give \
                 {expected} (x must be Vᵀ E_g within {X_TOLERANCE} relative)",
                j / 3,
                j % 3
            ));
        }
    }
    Ok(())
}

/// Name, positions and emission: everything but `x`.
fn check_members(f: &OperatorFile, g: &LightGroup) -> Result<(), String> {
    let n = f.n as usize;
    if g.name.is_empty() {
        return Err("the name is empty".into());
    }
    if g.positions.is_empty() {
        return Err("no positions: a group needs at least one element".into());
    }
    if g.emission.len() != 3 * g.positions.len() {
        return Err(format!(
            "{} positions need {} emission values, found {}",
            g.positions.len(),
            3 * g.positions.len(),
            g.emission.len()
        ));
    }
    for (j, pair) in g.positions.windows(2).enumerate() {
        if pair[1] <= pair[0] {
            return Err(format!(
                "positions[{j}] = {} and positions[{}] = {}: positions must increase strictly",
                pair[0],
                j + 1,
                pair[1]
            ));
        }
    }
    if let Some(&last) = g.positions.last().filter(|&&p| p as usize >= n) {
        return Err(format!("position {last} is not below n = {n}"));
    }
    if let Some(j) = g
        .emission
        .iter()
        .position(|&e| !(e.is_finite() && e >= 0.0))
    {
        return Err(format!(
            "emission of position {} channel {}: value {} must be finite and >= 0",
            g.positions[j / 3],
            j % 3,
            g.emission[j]
        ));
    }
    Ok(())
}

/// `x[3 p + c] = Σ_{s ∈ positions ∩ p} w_s e_s,c` in f64. `positions` are valid, increasing.
pub(crate) fn segment_sums(
    index: &[u32],
    weights: &[f32],
    positions: &[u32],
    emission: &[f32],
    x: &mut Vec<f64>,
) {
    let k = index.len().saturating_sub(1);
    x.clear();
    x.resize(3 * k, 0.0);
    let mut p = 0;
    for (&s, e) in positions.iter().zip(emission.chunks_exact(3)) {
        while p + 1 < k && index[p + 1] <= s {
            p += 1;
        }
        let w = f64::from(weights[s as usize]);
        for c in 0..3 {
            x[3 * p + c] += w * f64::from(e[c]);
        }
    }
}

impl OperatorFile {
    /// A light group of this file's elements: `positions` (file order, strictly increasing) and
    /// their RGB `emission` at intensity 1 (3 values per position). Computes `x = Vᵀ E_g` from
    /// the index and the weights, so the group is valid for this file. Errors (`Invalid`) name
    /// the problem. Push the group onto [`lights`](Self::lights) to store it.
    pub fn light_group(
        &self,
        name: impl Into<String>,
        positions: Vec<u32>,
        emission: Vec<f32>,
    ) -> Result<LightGroup, FormatError> {
        let mut group = LightGroup {
            name: name.into(),
            positions,
            emission,
            x: Vec::new(),
        };
        check_members(self, &group)
            .map_err(|m| FormatError::invalid(format!("light group {:?}: {m}", group.name)))?;
        segment_sums(
            &self.index,
            &self.weights,
            &group.positions,
            &group.emission,
            &mut group.x,
        );
        Ok(group)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::file::Precision;
    use crate::testdata::sample;

    fn lamp() -> LightGroup {
        sample(Precision::F32, 3)
            .light_group("lamp", vec![1, 4], vec![1.0, 2.0, 3.0, 0.5, 0.5, 0.0])
            .unwrap()
    }

    #[test]
    fn x_is_v_transpose_e() {
        let g = lamp();
        // Position 1 (patch 0, w = 0.25), position 4 (patch 1, w = 0.3).
        let expected = [0.25, 0.5, 0.75, 0.15, 0.15, 0.0];
        for (x, e) in g.x.iter().zip(expected) {
            assert!((x - e).abs() < 1e-7, "{:?}", g.x);
        }
    }

    #[test]
    fn encoding_is_as_documented() {
        let g = lamp();
        let bytes = encode(std::slice::from_ref(&g));
        // 8 head + 8 record head + 48 x + 8 name + 8 positions + 24 emission.
        assert_eq!(bytes.len(), 8 + 8 + 48 + 8 + 8 + 24);
        assert_eq!(u32_at(&bytes, 0), Some(1));
        assert_eq!(u32_at(&bytes, 8), Some(4));
        assert_eq!(u32_at(&bytes, 12), Some(2));
        assert_eq!(&bytes[64..72], b"lamp\0\0\0\0");
        assert_eq!(u32_at(&bytes, 76), Some(4));
        assert_eq!(decode(&bytes, 2).unwrap(), vec![g]);
        assert_eq!(decode(&encode(&[]), 2).unwrap(), vec![]);
    }

    #[test]
    fn hostile_payloads_are_refused() {
        let good = encode(&[lamp()]);
        for len in 0..good.len() {
            assert!(decode(&good[..len], 2).is_err(), "prefix {len}");
        }
        let mut huge = good.clone();
        huge[..4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(decode(&huge, 2).unwrap_err().message.contains("group 1"));
        let mut long_name = good.clone();
        long_name[8..12].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(
            decode(&long_name, 2)
                .unwrap_err()
                .message
                .contains("the name")
        );
        let mut empty = good.clone();
        empty[12..16].copy_from_slice(&0u32.to_le_bytes());
        assert!(
            decode(&empty, 2)
                .unwrap_err()
                .message
                .contains("at least 1")
        );
        let mut trailing = good.clone();
        trailing.extend_from_slice(&[0; 8]);
        assert!(
            decode(&trailing, 2)
                .unwrap_err()
                .message
                .contains("payload has")
        );
        let mut bad_utf8 = good;
        bad_utf8[64] = 0xFF;
        assert!(decode(&bad_utf8, 2).unwrap_err().message.contains("UTF-8"));
    }

    #[test]
    fn invariants_name_group_and_problem() {
        type Edit = fn(&mut OperatorFile);
        let cases: [(Edit, &str); 8] = [
            (
                |f| f.lights[1].name = "lamp".into(),
                "groups 0 and 1 are both named",
            ),
            (
                |f| f.lights[0].positions = vec![4, 1],
                "positions must increase",
            ),
            (|f| f.lights[0].positions[1] = 6, "not below n = 6"),
            (|f| f.lights[0].emission[2] = -1.0, "channel 2: value -1"),
            (
                |f| f.lights[0].x[3] = f64::NAN,
                "x of patch 1 channel 0: value NaN",
            ),
            (|f| f.lights[0].x[0] *= 1.001, "x must be Vᵀ E_g"),
            (
                |f| f.lights[0].emission.pop().map(drop).unwrap(),
                "need 6 emission",
            ),
            (|f| f.lights[1].name.clear(), "the name is empty"),
        ];
        for (edit, expected) in cases {
            let mut f = sample(Precision::F32, 3);
            f.lights = vec![
                lamp(),
                LightGroup {
                    name: "sun".into(),
                    ..lamp()
                },
            ];
            f.validate().unwrap();
            edit(&mut f);
            let e = f.validate().unwrap_err();
            assert!(e.message.contains(expected), "{e} (expected {expected:?})");
            assert!(e.message.starts_with("section LIGHTS: group"), "{e}");
        }
    }

    #[test]
    fn light_group_refuses_bad_input() {
        let f = sample(Precision::F32, 1);
        let e = f.light_group("", vec![0], vec![1.0; 3]).unwrap_err();
        assert!(e.message.contains("the name is empty"), "{e}");
        let e = f.light_group("a", vec![2, 2], vec![1.0; 6]).unwrap_err();
        assert!(e.message.contains("increase strictly"), "{e}");
        let e = f.light_group("a", vec![9], vec![1.0; 3]).unwrap_err();
        assert!(e.message.contains("not below n"), "{e}");
        let e = f.light_group("a", vec![0], vec![f32::NAN; 3]).unwrap_err();
        assert!(e.message.contains("finite"), "{e}");
        let e = f.light_group("a", vec![0], vec![1.0; 2]).unwrap_err();
        assert!(e.message.contains("emission values"), "{e}");
    }
}
