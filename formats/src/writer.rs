//! Building a container: the writer side of [`Container`](crate::Container).

use crate::checksum::checksum;
use crate::container::{
    ALIGN, FLAG_REQUIRED, HEADER_CHECKSUM_OFFSET, HEADER_LEN, MAGIC, SECTION_ENTRY_LEN,
    VERSION_MAJOR, VERSION_MINOR, header_checksum,
};
use crate::kind;

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
}
