//! Building a container: the writer side of [`Container`](crate::Container).

use std::io::{Seek, SeekFrom, Write};

use crate::checksum::{Xxh64, checksum};
use crate::container::{
    ALIGN, FLAG_REQUIRED, HEADER_CHECKSUM_OFFSET, HEADER_LEN, MAGIC, SECTION_ENTRY_LEN,
    VERSION_MAJOR, VERSION_MINOR, header_checksum,
};
use crate::error::{ErrorKind, FormatError};
use crate::kind;

/// A section whose payload is produced while the file is written (see
/// [`ContainerWriter::write_streamed`]): `len` bytes, handed over in pieces by `fill`.
pub(crate) struct Streamed<'a> {
    /// Where the section goes among those added (0: first).
    pub at: usize,
    pub kind: u32,
    pub required: bool,
    pub len: u64,
    /// Calls its argument with consecutive pieces of the payload.
    #[allow(clippy::type_complexity)]
    pub fill: &'a mut dyn FnMut(
        &mut dyn FnMut(&[u8]) -> Result<(), FormatError>,
    ) -> Result<(), FormatError>,
}

/// Builds a container: payloads are laid out in the order they are added.
#[derive(Debug, Clone)]
pub struct ContainerWriter {
    major: u16,
    minor: u16,
    sections: Vec<(u32, u32, Vec<u8>)>,
}

impl Default for ContainerWriter {
    fn default() -> Self {
        Self::new()
    }
}

impl ContainerWriter {
    /// An empty container of version [`VERSION_MAJOR`].[`VERSION_MINOR`].
    pub fn new() -> Self {
        ContainerWriter {
            major: VERSION_MAJOR,
            minor: VERSION_MINOR,
            sections: Vec::new(),
        }
    }

    /// Stamps another version into the header: for tests and for tools that write files for
    /// other readers. The layout written stays that of this version.
    pub fn set_version(&mut self, major: u16, minor: u16) {
        (self.major, self.minor) = (major, minor);
    }

    /// Appends a section.
    ///
    /// # Panics
    /// If a section of `kind` was already added (a programming mistake: readers refuse such files).
    pub fn add(&mut self, kind: u32, required: bool, payload: Vec<u8>) {
        assert!(
            self.sections.iter().all(|s| s.0 != kind),
            "section {} added twice",
            kind::describe(kind)
        );
        let flags = if required { FLAG_REQUIRED } else { 0 };
        self.sections.push((kind, flags, payload));
    }

    /// Sections added so far.
    pub(crate) fn len(&self) -> usize {
        self.sections.len()
    }

    /// The file: header, table, then each payload at the next multiple of [`ALIGN`]. The file
    /// ends with the last payload (no trailing padding).
    pub fn to_bytes(&self) -> Vec<u8> {
        let count = u32::try_from(self.sections.len()).expect("more than u32::MAX sections");
        let table_end =
            HEADER_LEN + (self.sections.len() * SECTION_ENTRY_LEN).next_multiple_of(ALIGN);
        let total: usize = self.sections.iter().map(|s| s.2.len() + ALIGN).sum();
        let mut out = Vec::with_capacity(table_end + total);
        out.resize(table_end, 0);
        let mut entries = Vec::with_capacity(self.sections.len());
        for (kind, flags, payload) in &self.sections {
            let offset = out.len().next_multiple_of(ALIGN);
            out.resize(offset, 0);
            out.extend_from_slice(payload);
            entries.push([
                u64::from(*kind) | u64::from(*flags) << 32,
                offset as u64,
                payload.len() as u64,
                checksum(payload),
                0,
            ]);
        }
        out[..8].copy_from_slice(&MAGIC);
        out[8..10].copy_from_slice(&self.major.to_le_bytes());
        out[10..12].copy_from_slice(&self.minor.to_le_bytes());
        out[12..16].copy_from_slice(&count.to_le_bytes());
        // Bytes 16..20: header flags, 0. 20..28: checksum, zero while hashing.
        for (i, entry) in entries.iter().enumerate() {
            let at = HEADER_LEN + i * SECTION_ENTRY_LEN;
            for (j, word) in entry.iter().enumerate() {
                out[at + 8 * j..at + 8 * j + 8].copy_from_slice(&word.to_le_bytes());
            }
        }
        let sum = header_checksum(&out[..table_end]);
        out[HEADER_CHECKSUM_OFFSET..HEADER_CHECKSUM_OFFSET + 8].copy_from_slice(&sum.to_le_bytes());
        out
    }

    /// Writes the container with one more section, `streamed`, whose payload is never held
    /// whole: the same bytes [`to_bytes`](Self::to_bytes) gives for the same sections. The
    /// header and table are written last (their checksums need the payloads), so `out` must
    /// start empty. A `fill` that hands over more or fewer than `len` bytes is an error.
    pub(crate) fn write_streamed(
        &self,
        out: &mut (impl Write + Seek),
        streamed: Streamed<'_>,
    ) -> Result<(), FormatError> {
        let io = |e: std::io::Error| FormatError::new(ErrorKind::Io, e.to_string());
        let count = self.sections.len() + 1;
        let count32 = u32::try_from(count).expect("more than u32::MAX sections");
        let table_end = HEADER_LEN + (count * SECTION_ENTRY_LEN).next_multiple_of(ALIGN);
        out.write_all(&vec![0u8; table_end]).map_err(io)?;
        let mut at = table_end as u64;
        let mut entries = Vec::with_capacity(count);
        let flags = |required: bool| if required { FLAG_REQUIRED } else { 0 };
        for i in 0..count {
            let offset = at.next_multiple_of(ALIGN as u64);
            out.write_all(&vec![0u8; (offset - at) as usize])
                .map_err(io)?;
            let (kind, flags, len, sum) = if i == streamed.at {
                let mut hash = Xxh64::new();
                let mut written = 0u64;
                (streamed.fill)(&mut |piece: &[u8]| {
                    written += piece.len() as u64;
                    if written > streamed.len {
                        return Err(FormatError::invalid(format!(
                            "section {}: more than the {} bytes announced",
                            kind::describe(streamed.kind),
                            streamed.len
                        )));
                    }
                    hash.update(piece);
                    out.write_all(piece).map_err(io)
                })?;
                if written != streamed.len {
                    return Err(FormatError::invalid(format!(
                        "section {}: {written} bytes written, {} announced",
                        kind::describe(streamed.kind),
                        streamed.len
                    )));
                }
                let kind = streamed.kind;
                (kind, flags(streamed.required), written, hash.finish())
            } else {
                let (kind, flags, payload) = &self.sections[i - usize::from(i > streamed.at)];
                out.write_all(payload).map_err(io)?;
                (*kind, *flags, payload.len() as u64, checksum(payload))
            };
            entries.push([
                u64::from(kind) | u64::from(flags) << 32,
                offset,
                len,
                sum,
                0,
            ]);
            at = offset + len;
        }
        let mut head = vec![0u8; table_end];
        head[..8].copy_from_slice(&MAGIC);
        head[8..10].copy_from_slice(&self.major.to_le_bytes());
        head[10..12].copy_from_slice(&self.minor.to_le_bytes());
        head[12..16].copy_from_slice(&count32.to_le_bytes());
        for (i, entry) in entries.iter().enumerate() {
            let at = HEADER_LEN + i * SECTION_ENTRY_LEN;
            for (j, word) in entry.iter().enumerate() {
                head[at + 8 * j..at + 8 * j + 8].copy_from_slice(&word.to_le_bytes());
            }
        }
        let sum = header_checksum(&head);
        head[HEADER_CHECKSUM_OFFSET..HEADER_CHECKSUM_OFFSET + 8]
            .copy_from_slice(&sum.to_le_bytes());
        out.seek(SeekFrom::Start(0)).map_err(io)?;
        out.write_all(&head).map_err(io)?;
        out.flush().map_err(io)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streamed_sections_give_the_bytes_of_whole_ones() {
        let payloads: Vec<Vec<u8>> = (0..4u8)
            .map(|i| (0..(i as usize * 50 + 3)).map(|j| j as u8 ^ i).collect())
            .collect();
        for at in 0..payloads.len() {
            let mut whole = ContainerWriter::new();
            let mut rest = ContainerWriter::new();
            for (i, p) in payloads.iter().enumerate() {
                whole.add(i as u32 + 1, i != 2, p.clone());
                if i != at {
                    rest.add(i as u32 + 1, i != 2, p.clone());
                }
            }
            let mut out = std::io::Cursor::new(Vec::new());
            let streamed = &payloads[at];
            rest.write_streamed(
                &mut out,
                Streamed {
                    at,
                    kind: at as u32 + 1,
                    required: at != 2,
                    len: streamed.len() as u64,
                    fill: &mut |emit| streamed.chunks(7).try_for_each(&mut *emit),
                },
            )
            .unwrap();
            assert_eq!(out.into_inner(), whole.to_bytes(), "streamed section {at}");
            // Too few bytes is an error.
            let e = rest
                .write_streamed(
                    &mut std::io::Cursor::new(Vec::new()),
                    Streamed {
                        at,
                        kind: at as u32 + 1,
                        required: true,
                        len: streamed.len() as u64 + 1,
                        fill: &mut |emit| emit(streamed),
                    },
                )
                .unwrap_err();
            assert!(e.to_string().contains("announced"), "{e}");
        }
    }
}
