//! The radiosity of one frame as a field over the surface, what every export samples: the
//! value at a point of an element and at an element's corners, and which corners share one
//! exported vertex.
//!
//! The reconstruction is flat (the element's value everywhere on it) until the runtime's
//! smooth reconstruction lands; this file is the one place that switches.

use glam::DVec3;
use lrr_formats::{OperatorData, OperatorFile};

/// A frame's radiosity `B` (W/m² of exitance per channel, like the operator's), by file
/// position.
pub struct Field {
    /// `B` per file position.
    values: Vec<[f32; 3]>,
    /// Per file position: the element sees no patch and emits nothing, so it is black in every
    /// frame (the floor under a block): hidden from view, left out of lightmaps.
    hidden: Vec<bool>,
}

impl Field {
    /// The field of `radiosity` (per element, original ids) on `file`'s elements.
    pub fn new(file: &OperatorFile, radiosity: &[[f32; 3]]) -> Self {
        let values = file
            .order
            .iter()
            .map(|&id| radiosity[id as usize])
            .collect();
        Self {
            values,
            hidden: hidden(file),
        }
    }

    /// Whether the element at file position `s` is black in every frame because it sees
    /// nothing (its row of `F_k`, or of every `Y_c`, is zero) and emits nothing.
    pub fn hidden(&self, s: usize) -> bool {
        self.hidden[s]
    }

    /// `B` at `point` of the element at file position `s` (flat: the element's value).
    pub fn at(&self, s: usize, _point: DVec3) -> [f32; 3] {
        self.values[s]
    }

    /// `B` at corner `c` of the element at file position `s`.
    pub fn corner(&self, s: usize, _c: usize) -> [f32; 3] {
        self.values[s]
    }

    /// A key equal for corners that are one vertex of the exported mesh (same position and
    /// value): flat values share no corners.
    pub fn vertex_key(&self, s: usize, c: usize) -> u64 {
        (s as u64) << 2 | c as u64
    }

    /// How the values were reconstructed, for notes in the exported files.
    pub fn method(&self) -> &'static str {
        "flat (element values)"
    }
}

/// [`Field::hidden`] for every file position.
fn hidden(file: &OperatorFile) -> Vec<bool> {
    let (n, k) = (file.n as usize, file.k as usize);
    let (matrix, blocks) = match &file.operator {
        OperatorData::Factored { fk, .. } => (fk, 1),
        OperatorData::PlainYk { yk } => (yk, file.channels as usize),
    };
    (0..n)
        .map(|s| {
            let dark = file.emission[3 * s..3 * s + 3].iter().all(|&e| e == 0.0);
            let sees_nothing = (0..blocks).all(|c| {
                let row = (c * n + s) * k;
                (row..row + k).all(|i| matrix.get(i) == Some(0.0))
            });
            dark && sees_nothing
        })
        .collect()
}
