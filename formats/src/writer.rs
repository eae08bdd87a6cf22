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

/// Hands a section's payload to its argument in consecutive pieces.
type Pieces<'a> =
    dyn Fn(&mut dyn FnMut(&[u8]) -> Result<(), FormatError>) -> Result<(), FormatError> + 'a;

/// A section's payload: held, or made as the container is written (so that a writer holds one
/// section's bytes at a time, or one piece of them, rather than the whole file).
enum Payload<'a> {
    Held(Vec<u8>),
    Made(Box<Pieces<'a>>),
}

/// Builds a container: payloads are laid out in the order they are added.
pub struct ContainerWriter<'a> {
    major: u16,
    minor: u16,
    sections: Vec<(u32, u32, Payload<'a>)>,
}

impl std::fmt::Debug for ContainerWriter<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let kinds: Vec<String> = self.sections.iter().map(|s| kind::describe(s.0)).collect();
        f.debug_struct("ContainerWriter")
            .field("version", &(self.major, self.minor))
            .field("sections", &kinds)
            .finish()
    }
}

impl Default for ContainerWriter<'_> {
    fn default() -> Self {
        Self::new()
    }
}

impl<'a> ContainerWriter<'a> {
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
        self.push(kind, required, Payload::Held(payload));
    }

    /// Appends a section whose payload `encode` makes when the container is written, and
    /// which is dropped once written.
    pub(crate) fn add_encoded(
        &mut self,
        kind: u32,
        required: bool,
        encode: impl Fn() -> Vec<u8> + 'a,
    ) {
        self.add_pieces(kind, required, move |emit| emit(&encode()));
    }

    /// Appends a section whose payload `pieces` hands over in consecutive pieces when the
    /// container is written. It must hand over the same bytes each time it is called, and fail
    /// only where its argument does.
    pub(crate) fn add_pieces(
        &mut self,
        kind: u32,
        required: bool,
        pieces: impl Fn(&mut dyn FnMut(&[u8]) -> Result<(), FormatError>) -> Result<(), FormatError>
        + 'a,
    ) {
        self.push(kind, required, Payload::Made(Box::new(pieces)));
    }

    fn push(&mut self, kind: u32, required: bool, payload: Payload<'a>) {
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
        let mut out = std::io::Cursor::new(Vec::new());
        self.write_to(&mut out, None).expect(
            "a container written to memory cannot fail: its pieces fail only where the writer does",
        );
        out.into_inner()
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
        self.write_to(out, Some(streamed))
    }

    /// Writes the container (with `streamed` among its sections, when given) to `out`, which
    /// must start empty: the payloads one after another, each made, written and dropped in
    /// turn, then the header and table (their checksums need the payloads).
    pub(crate) fn write_to(
        &self,
        out: &mut (impl Write + Seek),
        mut streamed: Option<Streamed<'_>>,
    ) -> Result<(), FormatError> {
        let io = |e: std::io::Error| FormatError::new(ErrorKind::Io, e.to_string());
        let count = self.sections.len() + usize::from(streamed.is_some());
        let count32 = u32::try_from(count).expect("more than u32::MAX sections");
        let table_end = HEADER_LEN + (count * SECTION_ENTRY_LEN).next_multiple_of(ALIGN);
        out.write_all(&vec![0u8; table_end]).map_err(io)?;
        let mut at = table_end as u64;
        let mut entries = Vec::with_capacity(count);
        let flags = |required: bool| if required { FLAG_REQUIRED } else { 0 };
        let mut held = self.sections.iter();
        for i in 0..count {
            let offset = at.next_multiple_of(ALIGN as u64);
            out.write_all(&vec![0u8; (offset - at) as usize])
                .map_err(io)?;
            let (kind, flags, len, sum) = match streamed.as_mut().filter(|s| s.at == i) {
                Some(streamed) => {
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
                    (
                        streamed.kind,
                        flags(streamed.required),
                        written,
                        hash.finish(),
                    )
                }
                None => {
                    let (kind, flags, payload) = held.next().expect("a section for each entry");
                    let (len, sum) = match payload {
                        Payload::Held(bytes) => {
                            out.write_all(bytes).map_err(io)?;
                            (bytes.len() as u64, checksum(bytes))
                        }
                        Payload::Made(pieces) => {
                            let mut hash = Xxh64::new();
                            let mut written = 0u64;
                            pieces(&mut |piece: &[u8]| {
                                written += piece.len() as u64;
                                hash.update(piece);
                                out.write_all(piece).map_err(io)
                            })?;
                            (written, hash.finish())
                        }
                    };
                    (*kind, *flags, len, sum)
                }
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
        // Bytes 16..20: header flags, 0. 20..28: checksum, zero while hashing.
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
