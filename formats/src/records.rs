//! The shape shared by the display sections of named records (MATERIALS, POINT_LIGHTS, CAMERAS,
//! DIRECT_LIGHTS;
//! tabled in the crate docs): an 8-byte head (record count, reserved), the records (fixed size,
//! each holding the byte length of its name), a fixed-size block (MATERIALS: the material of
//! every element), then the names, UTF-8, back to back.
//!
//! Decoding checks that the records and the block lie inside the payload before it looks at a
//! name, and every name length against the bytes left, with checked arithmetic: a hostile count
//! or length costs an error, never memory.

use crate::bytes::{self, u32_at};
use crate::error::FormatError;
use crate::kind;

/// Bytes before the first record.
pub(crate) const HEAD: usize = 8;

/// A decoded table: the records' bytes, the block and the names.
#[derive(Debug)]
pub(crate) struct Table<'a> {
    /// `count` slices of the record length each.
    pub records: Vec<&'a [u8]>,
    /// The fixed-size block after the records.
    pub block: &'a [u8],
    /// One name per record.
    pub names: Vec<String>,
}

/// The layout of one section's table.
pub(crate) struct Shape {
    /// The section kind (for messages).
    pub kind: u32,
    /// What one record is, for messages ("material").
    pub what: &'static str,
    /// Bytes per record, a multiple of 4.
    pub record_len: usize,
    /// Offset of the name length (u32) inside a record.
    pub name_at: usize,
}

impl Shape {
    fn corrupt(&self, message: String) -> FormatError {
        FormatError::corrupt(format!("section {}: {message}", kind::describe(self.kind)))
    }

    /// Splits `payload`; `block_len` is the size of the block (None: it overflowed).
    pub(crate) fn decode<'a>(
        &self,
        payload: &'a [u8],
        block_len: Option<usize>,
    ) -> Result<Table<'a>, FormatError> {
        let len = payload.len();
        let count = u32_at(payload, 0)
            .ok_or_else(|| self.corrupt(format!("{len} bytes, too short for the head")))?
            as usize;
        let records_end = count
            .checked_mul(self.record_len)
            .and_then(|r| r.checked_add(HEAD));
        let block_end = records_end
            .zip(block_len)
            .and_then(|(r, b)| r.checked_add(b))
            .filter(|&end| end <= len)
            .ok_or_else(|| {
                self.corrupt(format!(
                    "{count} {}s of {} bytes and their fixed block run past the end of the \
                     payload ({len} bytes)",
                    self.what, self.record_len
                ))
            })?;
        let records_end = records_end.unwrap_or_default();
        let records: Vec<&[u8]> = payload[HEAD..records_end]
            .chunks_exact(self.record_len)
            .collect();
        let block = &payload[records_end..block_end];
        let mut names = Vec::with_capacity(count);
        let mut at = block_end;
        for (i, record) in records.iter().enumerate() {
            let name_len = u32_at(record, self.name_at).unwrap_or_default() as usize;
            let end = at
                .checked_add(name_len)
                .filter(|&end| end <= len)
                .ok_or_else(|| {
                    self.corrupt(format!(
                        "{} {i}: its name of {name_len} bytes at byte {at} runs past the end of \
                         the payload ({len} bytes)",
                        self.what
                    ))
                })?;
            let name = std::str::from_utf8(&payload[at..end]).map_err(|e| {
                self.corrupt(format!(
                    "{} {i}: the name is not valid UTF-8 (at byte {})",
                    self.what,
                    e.valid_up_to()
                ))
            })?;
            names.push(name.to_string());
            at = end;
        }
        if at != len {
            return Err(self.corrupt(format!(
                "{count} {}s and their names end at byte {at}, but the payload has {len} bytes",
                self.what
            )));
        }
        Ok(Table {
            records,
            block,
            names,
        })
    }
}

/// The head of a table of `count` records.
pub(crate) fn put_head(out: &mut Vec<u8>, count: usize) {
    bytes::put_u32s(out, &[count as u32, 0]);
}

/// Three `f32` and a `u32`: one 16-byte row of a record.
pub(crate) fn put_row(out: &mut Vec<u8>, v: [f32; 3], word: u32) {
    bytes::put_f32s(out, &v);
    bytes::put_u32s(out, &[word]);
}

/// Three `f32` and one more `f32`.
pub(crate) fn put_row_f(out: &mut Vec<u8>, v: [f32; 3], last: f32) {
    bytes::put_f32s(out, &v);
    bytes::put_f32s(out, &[last]);
}

/// The names, back to back.
pub(crate) fn put_names<'a>(out: &mut Vec<u8>, names: impl Iterator<Item = &'a str>) {
    names.for_each(|name| out.extend_from_slice(name.as_bytes()));
}

#[cfg(test)]
mod tests {
    use super::*;

    const SHAPE: Shape = Shape {
        kind: kind::CAMERAS,
        what: "camera",
        record_len: 8,
        name_at: 4,
    };

    fn table(names: &[&str], block: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        put_head(&mut out, names.len());
        for name in names {
            bytes::put_u32s(&mut out, &[7, name.len() as u32]);
        }
        out.extend_from_slice(block);
        put_names(&mut out, names.iter().copied());
        out
    }

    #[test]
    fn names_and_block_come_back() {
        let bytes = table(&["a", "", "ünï"], &[1, 2, 3, 4]);
        let t = SHAPE.decode(&bytes, Some(4)).unwrap();
        assert_eq!(t.names, ["a", "", "ünï"]);
        assert_eq!(t.block, [1, 2, 3, 4]);
        assert_eq!(t.records.len(), 3);
        assert_eq!(u32_at(t.records[2], 0), Some(7));
    }

    #[test]
    fn hostile_tables_are_refused() {
        let good = table(&["front", "top"], &[0; 4]);
        for len in 0..good.len() {
            assert!(SHAPE.decode(&good[..len], Some(4)).is_err(), "prefix {len}");
        }
        let mut huge = good.clone();
        huge[..4].copy_from_slice(&u32::MAX.to_le_bytes());
        let e = SHAPE.decode(&huge, Some(4)).unwrap_err();
        assert!(e.message.contains("run past the end"), "{e}");
        let e = SHAPE.decode(&good, None).unwrap_err();
        assert!(e.message.contains("run past the end"), "{e}");
        let mut long_name = good.clone();
        long_name[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
        let e = SHAPE.decode(&long_name, Some(4)).unwrap_err();
        assert!(
            e.message.contains("camera 0: its name of 4294967295"),
            "{e}"
        );
        let mut trailing = good.clone();
        trailing.push(b'x');
        let e = SHAPE.decode(&trailing, Some(4)).unwrap_err();
        assert!(e.message.contains("end at byte 36"), "{e}");
        let mut bad = good;
        bad[28] = 0xFF;
        let e = SHAPE.decode(&bad, Some(4)).unwrap_err();
        assert!(
            e.message
                .starts_with("section CAMERAS (kind 16): camera 0: the name is not valid UTF-8"),
            "{e}"
        );
    }
}
