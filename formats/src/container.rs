//! The container: a 64-byte header, a section table, and 64-byte aligned checksummed payloads.
//!
//! This level knows nothing of operators: it checks the structure (magic, version, bounds,
//! alignment, overlaps, checksums, duplicate and unknown required kinds) and hands out payload
//! slices that borrow the input. [`OperatorFile`](crate::OperatorFile) decodes the payloads.

use crate::bytes::{align_up, u16_at, u32_at, u64_at};
use crate::checksum::checksum;
use crate::error::{ErrorKind, FormatError};
use crate::kind;

#[cfg(test)]
use crate::writer::ContainerWriter;

/// The first 8 bytes of every operator file: `\x89LRR\r\n\x1a\n`.
pub const MAGIC: [u8; 8] = *b"\x89LRR\r\n\x1a\n";
/// The major format version this crate reads and writes; files of another major are refused.
pub const VERSION_MAJOR: u16 = 1;
/// The newest minor format version this crate writes (files without the display sections of
/// 1.2 are stamped 1.1, files without LIGHTMAP and FACES 1.2, files without FACES 1.3); files of
/// any minor version are read.
pub const VERSION_MINOR: u16 = 6;
/// Bytes in the header.
pub const HEADER_LEN: usize = 64;
/// Bytes per section table entry.
pub const SECTION_ENTRY_LEN: usize = 40;
/// Alignment of the end of the section table and of every payload offset.
pub const ALIGN: usize = 64;
/// Byte offset of the header checksum inside the header.
pub const HEADER_CHECKSUM_OFFSET: usize = 20;
/// Section flag bit 0: a reader that does not know the kind must refuse the file.
pub const FLAG_REQUIRED: u32 = 1;

/// One entry of the section table, as stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Section {
    /// The kind code (see [`kind`]).
    pub kind: u32,
    /// Flags; bit 0 is [`FLAG_REQUIRED`], the others are reserved and ignored.
    pub flags: u32,
    /// Offset of the payload from the start of the file, a multiple of [`ALIGN`].
    pub offset: u64,
    /// Length of the payload in bytes.
    pub length: u64,
    /// [`checksum`](crate::checksum()) of the payload.
    pub checksum: u64,
}

impl Section {
    /// Whether a reader that does not know this kind must refuse the file.
    pub fn required(&self) -> bool {
        self.flags & FLAG_REQUIRED != 0
    }
}

/// A parsed container borrowing its bytes: every section is in bounds, aligned, non-overlapping,
/// of a unique kind and matches its checksum.
///
/// ```
/// use lrr_formats::{Container, ContainerWriter};
/// let mut writer = ContainerWriter::new();
/// writer.add(lrr_formats::kind::METADATA, true, b"{}".to_vec());
/// writer.add(0x1000, false, vec![1, 2, 3]); // unknown to readers, optional: skipped by them
/// let bytes = writer.to_bytes();
/// let container = Container::parse(&bytes)?;
/// assert_eq!(container.version(), (1, lrr_formats::VERSION_MINOR));
/// assert_eq!(container.section(lrr_formats::kind::METADATA), Some(&b"{}"[..]));
/// assert_eq!(container.kinds().collect::<Vec<_>>(), [1, 0x1000]);
/// # Ok::<(), lrr_formats::FormatError>(())
/// ```
#[derive(Debug, Clone)]
pub struct Container<'a> {
    major: u16,
    minor: u16,
    sections: Vec<Section>,
    payloads: Vec<&'a [u8]>,
}

impl<'a> Container<'a> {
    /// Checks the structure of `bytes` and indexes its sections. Never panics; allocates at most
    /// about the size of the section table.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, FormatError> {
        check_magic(bytes)?;
        let (major, minor, count) = read_header(bytes)?;
        let table_end = table_end(count)?;
        if bytes.len() < table_end {
            return Err(FormatError::truncated(format!(
                "the section table of {count} entries ends at byte {table_end}, \
                 but the file has only {} bytes",
                bytes.len()
            )));
        }
        let head = bytes.get(..table_end).unwrap_or_default();
        let (stored, computed) = (stored_header_checksum(head), header_checksum(head));
        if stored != computed {
            return Err(FormatError::corrupt(format!(
                "header checksum mismatch (stored {stored:#018x}, computed {computed:#018x}): \
                 the file is corrupt"
            )));
        }
        let sections = read_table(bytes, count)?;
        let payloads = check_layout(bytes, table_end, &sections)?;
        for (section, payload) in sections.iter().zip(&payloads) {
            let computed = checksum(payload);
            if computed != section.checksum {
                return Err(FormatError::corrupt(format!(
                    "section {}: checksum mismatch (stored {:#018x}, computed {computed:#018x}): \
                     the file is corrupt",
                    kind::describe(section.kind),
                    section.checksum
                )));
            }
        }
        if let Some(s) = sections
            .iter()
            .find(|s| s.required() && !kind::is_known(s.kind))
        {
            return Err(FormatError::new(
                ErrorKind::UnsupportedVersion,
                format!(
                    "section kind {} is marked required but is unknown to this reader \
                     (the file has format version {major}.{minor}, this reader {VERSION_MAJOR}.\
                     {VERSION_MINOR}): re-bake with this version of lrr or upgrade the runtime",
                    s.kind
                ),
            ));
        }
        Ok(Container {
            major,
            minor,
            sections,
            payloads,
        })
    }

    /// `(major, minor)` format version of the file.
    pub fn version(&self) -> (u16, u16) {
        (self.major, self.minor)
    }

    /// The payload of the section of `kind`, if present.
    pub fn section(&self, kind: u32) -> Option<&'a [u8]> {
        let i = self.sections.iter().position(|s| s.kind == kind)?;
        self.payloads.get(i).copied()
    }

    /// The kinds present, in table order (unknown optional kinds included).
    pub fn kinds(&self) -> impl Iterator<Item = u32> {
        self.sections.iter().map(|s| s.kind)
    }

    /// The section table entries, in table order.
    pub fn sections(&self) -> &[Section] {
        &self.sections
    }
}

fn check_magic(bytes: &[u8]) -> Result<(), FormatError> {
    let n = bytes.len().min(MAGIC.len());
    if bytes.get(..n) != MAGIC.get(..n) {
        return Err(FormatError::new(
            ErrorKind::NotLrr,
            "not an lrr operator file (it does not start with the lrr magic bytes)",
        ));
    }
    if n < MAGIC.len() {
        return Err(FormatError::truncated(format!(
            "the file has only {} bytes: too short to be an lrr operator file",
            bytes.len()
        )));
    }
    Ok(())
}

/// `(major, minor, section count)`, refusing a short header or another major version.
fn read_header(bytes: &[u8]) -> Result<(u16, u16, u32), FormatError> {
    let short = || {
        FormatError::truncated(format!(
            "the header needs {HEADER_LEN} bytes, but the file has only {}",
            bytes.len()
        ))
    };
    let head = bytes.get(..HEADER_LEN).ok_or_else(short)?;
    let major = u16_at(head, 8).ok_or_else(short)?;
    let minor = u16_at(head, 10).ok_or_else(short)?;
    let count = u32_at(head, 12).ok_or_else(short)?;
    if major != VERSION_MAJOR {
        return Err(FormatError::new(
            ErrorKind::UnsupportedVersion,
            format!(
                "this file has lrr operator format version {major}.{minor}, but this reader \
                 supports version {VERSION_MAJOR}.x (up to {VERSION_MAJOR}.{VERSION_MINOR}): \
                 re-bake with this version of lrr or upgrade the runtime"
            ),
        ));
    }
    Ok((major, minor, count))
}

/// End of the padded section table: the first byte a payload may use.
fn table_end(count: u32) -> Result<usize, FormatError> {
    let table = u64::from(count) * SECTION_ENTRY_LEN as u64;
    align_up(table, ALIGN as u64)
        .and_then(|t| t.checked_add(HEADER_LEN as u64))
        .and_then(|t| usize::try_from(t).ok())
        .ok_or_else(|| {
            FormatError::limits(format!("a section table of {count} entries is too large"))
        })
}

fn stored_header_checksum(head: &[u8]) -> u64 {
    u64_at(head, HEADER_CHECKSUM_OFFSET).unwrap_or_default()
}

/// Checksum of the header (its checksum field read as zero) and the padded section table.
pub(crate) fn header_checksum(head_and_table: &[u8]) -> u64 {
    let mut sealed = head_and_table.to_vec();
    if let Some(field) = sealed.get_mut(HEADER_CHECKSUM_OFFSET..HEADER_CHECKSUM_OFFSET + 8) {
        field.fill(0);
    }
    checksum(&sealed)
}

/// Reads `count` entries; the caller checked that the table lies inside `bytes`.
fn read_table(bytes: &[u8], count: u32) -> Result<Vec<Section>, FormatError> {
    let mut sections = Vec::with_capacity(count as usize);
    for i in 0..count as usize {
        let at = HEADER_LEN + i * SECTION_ENTRY_LEN;
        let entry = || -> Option<Section> {
            Some(Section {
                kind: u32_at(bytes, at)?,
                flags: u32_at(bytes, at + 4)?,
                offset: u64_at(bytes, at + 8)?,
                length: u64_at(bytes, at + 16)?,
                checksum: u64_at(bytes, at + 24)?,
            })
        };
        let section = entry().ok_or_else(|| {
            FormatError::truncated(format!("section table entry {i} lies past the end"))
        })?;
        sections.push(section);
    }
    Ok(sections)
}

/// Checks bounds, alignment, uniqueness and overlaps; returns the payload of each section.
fn check_layout<'a>(
    bytes: &'a [u8],
    table_end: usize,
    sections: &[Section],
) -> Result<Vec<&'a [u8]>, FormatError> {
    let mut payloads = Vec::with_capacity(sections.len());
    let mut ranges = Vec::with_capacity(sections.len());
    for s in sections {
        let range = payload_range(s, table_end, bytes.len())?;
        payloads.push(bytes.get(range.0..range.1).unwrap_or_default());
        if range.1 > range.0 {
            ranges.push((range.0, range.1, s.kind));
        }
    }
    let mut kinds: Vec<u32> = sections.iter().map(|s| s.kind).collect();
    kinds.sort_unstable();
    if let Some(pair) = kinds.windows(2).find(|w| w[0] == w[1]) {
        return Err(FormatError::corrupt(format!(
            "section {} appears more than once in the section table",
            kind::describe(pair[0])
        )));
    }
    ranges.sort_unstable();
    if let Some(w) = ranges.windows(2).find(|w| w[1].0 < w[0].1) {
        let ((a0, a1, a), (b0, b1, b)) = (w[0], w[1]);
        return Err(FormatError::corrupt(format!(
            "sections {} (bytes {a0}..{a1}) and {} (bytes {b0}..{b1}) overlap",
            kind::describe(a),
            kind::describe(b)
        )));
    }
    let end = ranges.iter().map(|r| r.1).max().unwrap_or(0).max(table_end);
    if bytes.len() > end {
        return Err(FormatError::corrupt(format!(
            "{} unexpected bytes after the last section (which ends at byte {end})",
            bytes.len() - end
        )));
    }
    Ok(payloads)
}

/// The byte range of one payload, checked against the table and the end of the file.
fn payload_range(s: &Section, table_end: usize, len: usize) -> Result<(usize, usize), FormatError> {
    let name = kind::describe(s.kind);
    if s.offset & (ALIGN as u64 - 1) != 0 {
        return Err(FormatError::corrupt(format!(
            "section {name}: offset {} is not a multiple of {ALIGN}",
            s.offset
        )));
    }
    if s.offset < table_end as u64 {
        return Err(FormatError::corrupt(format!(
            "section {name}: offset {} lies inside the header and section table \
             (which end at byte {table_end})",
            s.offset
        )));
    }
    let end = s.offset.checked_add(s.length).ok_or_else(|| {
        FormatError::corrupt(format!(
            "section {name}: offset {} + length {} overflows",
            s.offset, s.length
        ))
    })?;
    if end > len as u64 {
        return Err(FormatError::truncated(format!(
            "section {name}: bytes {}..{end} lie past the end of the file ({len} bytes)",
            s.offset
        )));
    }
    // Both fit in `len`, a usize.
    Ok((s.offset as usize, end as usize))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_sections() -> Vec<u8> {
        let mut w = ContainerWriter::new();
        w.add(kind::METADATA, true, b"{\"a\":1}".to_vec());
        w.add(kind::ORDER, true, vec![7; 100]);
        w.to_bytes()
    }

    /// Recomputes the header checksum after a deliberate edit of the header or table.
    fn reseal(bytes: &mut [u8]) {
        let count = u32_at(bytes, 12).unwrap();
        let end = table_end(count).unwrap();
        let sum = header_checksum(&bytes[..end]);
        bytes[HEADER_CHECKSUM_OFFSET..HEADER_CHECKSUM_OFFSET + 8]
            .copy_from_slice(&sum.to_le_bytes());
    }

    fn entry_field(bytes: &mut [u8], entry: usize, field: usize) -> &mut [u8] {
        let at = HEADER_LEN + entry * SECTION_ENTRY_LEN + field;
        &mut bytes[at..at + 8]
    }

    #[test]
    fn layout_is_as_documented() {
        let bytes = two_sections();
        assert_eq!(&bytes[..8], b"\x89LRR\r\n\x1a\n");
        assert_eq!(u16_at(&bytes, 8), Some(1));
        assert_eq!(u16_at(&bytes, 10), Some(VERSION_MINOR));
        assert_eq!(u32_at(&bytes, 12), Some(2));
        assert_eq!(u32_at(&bytes, 16), Some(0));
        // Table of 80 bytes padded to 128: payloads at 192 and 256.
        assert_eq!(u32_at(&bytes, 64), Some(kind::METADATA));
        assert_eq!(u32_at(&bytes, 68), Some(FLAG_REQUIRED));
        assert_eq!(u64_at(&bytes, 72), Some(192));
        assert_eq!(u64_at(&bytes, 80), Some(7));
        assert_eq!(u64_at(&bytes, 88), Some(checksum(b"{\"a\":1}")));
        assert_eq!(u64_at(&bytes, 96), Some(0));
        assert_eq!(u64_at(&bytes, 64 + 40 + 8), Some(256));
        assert_eq!(bytes.len(), 356);
        let c = Container::parse(&bytes).unwrap();
        assert_eq!(c.section(kind::ORDER), Some(&[7u8; 100][..]));
        assert_eq!(c.section(kind::FK), None);
        assert!(c.sections().iter().all(Section::required));
    }

    #[test]
    fn empty_container_and_empty_payloads() {
        let bytes = ContainerWriter::new().to_bytes();
        assert_eq!(bytes.len(), HEADER_LEN);
        assert_eq!(Container::parse(&bytes).unwrap().kinds().count(), 0);
        let mut w = ContainerWriter::new();
        w.add(kind::METADATA, true, Vec::new());
        w.add(kind::DIMS, true, Vec::new());
        let bytes = w.to_bytes();
        let c = Container::parse(&bytes).unwrap();
        assert_eq!(c.section(kind::DIMS), Some(&[][..]));
    }

    #[test]
    fn structural_damage_is_refused() {
        let good = two_sections();
        type Edit = fn(&mut Vec<u8>);
        let cases: [(&str, Edit, ErrorKind); 6] = [
            (
                "misaligned",
                |b| entry_field(b, 1, 8).copy_from_slice(&257u64.to_le_bytes()),
                ErrorKind::Corrupt,
            ),
            (
                "overlap",
                |b| entry_field(b, 1, 8).copy_from_slice(&192u64.to_le_bytes()),
                ErrorKind::Corrupt,
            ),
            (
                "inside table",
                |b| entry_field(b, 0, 8).copy_from_slice(&64u64.to_le_bytes()),
                ErrorKind::Corrupt,
            ),
            (
                "past end",
                |b| entry_field(b, 1, 16).copy_from_slice(&101u64.to_le_bytes()),
                ErrorKind::Truncated,
            ),
            (
                "huge length",
                |b| entry_field(b, 1, 16).copy_from_slice(&u64::MAX.to_le_bytes()),
                ErrorKind::Corrupt,
            ),
            (
                "duplicate",
                |b| b[64 + 40..64 + 44].copy_from_slice(&kind::METADATA.to_le_bytes()),
                ErrorKind::Corrupt,
            ),
        ];
        for (name, edit, expected) in cases {
            let mut bytes = good.clone();
            edit(&mut bytes);
            reseal(&mut bytes);
            let err = Container::parse(&bytes).unwrap_err();
            assert_eq!(err.kind, expected, "{name}: {err}");
        }
        let mut long = good.clone();
        long.push(0);
        assert_eq!(
            Container::parse(&long).unwrap_err().kind,
            ErrorKind::Corrupt
        );
    }

    #[test]
    fn huge_section_count_is_truncated_not_allocated() {
        let mut bytes = ContainerWriter::new().to_bytes();
        bytes[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
        assert_eq!(
            Container::parse(&bytes).unwrap_err().kind,
            ErrorKind::Truncated
        );
    }

    #[test]
    fn short_inputs() {
        assert_eq!(
            Container::parse(b"").unwrap_err().kind,
            ErrorKind::Truncated
        );
        assert_eq!(
            Container::parse(b"\x89LR").unwrap_err().kind,
            ErrorKind::Truncated
        );
        assert_eq!(Container::parse(b"PK").unwrap_err().kind, ErrorKind::NotLrr);
        assert_eq!(
            Container::parse(&MAGIC).unwrap_err().kind,
            ErrorKind::Truncated
        );
    }

    #[test]
    #[should_panic(expected = "added twice")]
    fn adding_a_kind_twice_panics() {
        let mut w = ContainerWriter::new();
        w.add(kind::FK, true, Vec::new());
        w.add(kind::FK, false, Vec::new());
    }
}
