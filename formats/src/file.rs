//! The typed operator file: every section decoded into plain data.
//!
//! [`OperatorFile`] owns every section; the invariants documented on its fields are checked by
//! [`validate`](OperatorFile::validate) (`validate.rs`), the bytes are read and written by
//! `codec.rs` ([`OperatorFile::from_bytes`], [`OperatorFile::to_bytes`]). This module holds the
//! types alone and imports nothing of the crate but the binary16 conversions, the polygons and
//! the display types.

use crate::display::Display;
use crate::geometry::{FacesRef, Geometry};
use crate::half::{f16_to_f32, f32_to_f16};

/// The largest 1-norm condition number `‖A‖₁ ‖A⁻¹‖₁` of a system `A = I - Vᵀ diag(ρ_c) F_k`
/// whose inverse may become a core: beyond it the f64 inverse has fewer than about 4 correct
/// digits. The bake and the runtime's albedo edit refuse such systems as numerically singular;
/// the reader cannot check it (the file holds the inverse, not the system).
pub const MAX_CONDITION: f64 = 1e12;

/// How `F_k` is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Precision {
    /// 4-byte IEEE single precision (DIMS code 0).
    F32,
    /// 2-byte IEEE binary16, see [`f32_to_f16`] (DIMS code 1).
    F16,
}

impl Precision {
    /// The code stored in DIMS.
    pub fn code(self) -> u32 {
        match self {
            Precision::F32 => 0,
            Precision::F16 => 1,
        }
    }

    /// The precision of a DIMS code, `None` if unknown.
    pub fn from_code(code: u32) -> Option<Self> {
        match code {
            0 => Some(Precision::F32),
            1 => Some(Precision::F16),
            _ => None,
        }
    }

    /// Bytes per stored value.
    pub fn size(self) -> usize {
        match self {
            Precision::F32 => 4,
            Precision::F16 => 2,
        }
    }
}

/// How the operator is stored (DIMS word 4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Layout {
    /// Shared `F_k` (n x k) plus `channels` k x k cores `M_c` (DIMS code 0): sections FK and CORES.
    Factored,
    /// The papers' plain per-channel `Y_c = -diag(rho_c) F_k M_c` (DIMS code 1): section YK, so
    /// `B_c = E_c - Y_c (Vᵀ E_c)`. Reads `channels` times the bytes of `Factored` per RGB frame
    /// and bakes the reflectance in (no albedo edits); kept for comparison with the papers.
    PlainYk,
}

impl Layout {
    /// The code stored in DIMS.
    pub fn code(self) -> u32 {
        match self {
            Layout::Factored => 0,
            Layout::PlainYk => 1,
        }
    }

    /// The layout of a DIMS code, `None` if unknown.
    pub fn from_code(code: u32) -> Option<Self> {
        match code {
            0 => Some(Layout::Factored),
            1 => Some(Layout::PlainYk),
            _ => None,
        }
    }
}

/// A stored matrix in the file's [`Precision`]: the form factors `F_k` of the factored layout
/// (n x k, row-major: row = element in file order, column = patch), or the `channels` n x k
/// blocks of `Y_k` of the plain layout, one after the other.
#[derive(Debug, Clone, PartialEq)]
pub enum StoredMatrix {
    /// Single precision.
    F32(Vec<f32>),
    /// binary16 bits.
    F16(Vec<u16>),
}

impl StoredMatrix {
    /// Number of values.
    pub fn len(&self) -> usize {
        match self {
            StoredMatrix::F32(v) => v.len(),
            StoredMatrix::F16(v) => v.len(),
        }
    }

    /// Whether there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The precision the values are stored in.
    pub fn precision(&self) -> Precision {
        match self {
            StoredMatrix::F32(_) => Precision::F32,
            StoredMatrix::F16(_) => Precision::F16,
        }
    }

    /// Value `i` as f32 (exact for both precisions), `None` past the end.
    pub fn get(&self, i: usize) -> Option<f32> {
        match self {
            StoredMatrix::F32(v) => v.get(i).copied(),
            StoredMatrix::F16(v) => v.get(i).map(|&h| f16_to_f32(h)),
        }
    }

    /// All values as f32.
    pub fn to_f32(&self) -> Vec<f32> {
        match self {
            StoredMatrix::F32(v) => v.clone(),
            StoredMatrix::F16(v) => v.iter().map(|&h| f16_to_f32(h)).collect(),
        }
    }

    /// `values` stored in `precision` (rounded to nearest for binary16).
    pub fn from_f32(values: &[f32], precision: Precision) -> Self {
        match precision {
            Precision::F32 => StoredMatrix::F32(values.to_vec()),
            Precision::F16 => StoredMatrix::F16(values.iter().map(|&v| f32_to_f16(v)).collect()),
        }
    }
}

/// The operator itself, in one of the two [`Layout`]s.
#[derive(Debug, Clone, PartialEq)]
pub enum OperatorData {
    /// `F_k` and the cores: `B_c = E_c + rho_c ⊙ F_k M_c (Vᵀ E_c)`.
    Factored {
        /// `n * k` element-to-patch form factors `F_k`, finite, >= 0.
        fk: StoredMatrix,
        /// `channels * k * k` row-major: `M_c = (I - Vᵀ diag(rho_c) F_k)⁻¹`, finite, from a
        /// system of condition number at most [`MAX_CONDITION`].
        cores: Vec<f64>,
    },
    /// Plain `Y_c = -diag(rho_c) F_k M_c`: `B_c = E_c - Y_c (Vᵀ E_c)`.
    PlainYk {
        /// `channels * n * k` values, finite: channel-major, each channel an n x k row-major
        /// block with rows in file order.
        yk: StoredMatrix,
    },
}

impl OperatorData {
    /// The layout of this data.
    pub fn layout(&self) -> Layout {
        match self {
            OperatorData::Factored { .. } => Layout::Factored,
            OperatorData::PlainYk { .. } => Layout::PlainYk,
        }
    }

    /// The stored matrix a frame reads: `F_k`, or all channels of `Y_k`.
    pub fn matrix(&self) -> &StoredMatrix {
        match self {
            OperatorData::Factored { fk, .. } => fk,
            OperatorData::PlainYk { yk } => yk,
        }
    }
}

/// A named group of emitting elements (section LIGHTS): a frame given only per-group intensities
/// `a_g` has `E = Σ_g a_g E_g` and `Vᵀ E = Σ_g a_g x_g` without an O(n) pass.
///
/// Build one with [`OperatorFile::light_group`], which computes `x` from the file.
#[derive(Debug, Clone, PartialEq)]
pub struct LightGroup {
    /// Non-empty UTF-8, unique within the file.
    pub name: String,
    /// File positions of the group's elements, strictly increasing, `< n`, at least one.
    pub positions: Vec<u32>,
    /// `3 * positions.len()`: RGB exitance of each position at intensity 1, finite, >= 0.
    pub emission: Vec<f32>,
    /// `k * 3`: `x_g = Vᵀ E_g` per patch and channel (`x[3 p + c]`), finite; agrees with the
    /// weights and `emission` within 1e-5 relative (see [`OperatorFile::light_group`]).
    pub x: Vec<f64>,
}

/// The whole operator file, decoded. Elements are stored in *file order* (sorted by patch).
#[derive(Debug, Clone, PartialEq)]
pub struct OperatorFile {
    /// UTF-8 JSON text written by the precompute (not parsed here).
    pub metadata_json: String,
    /// Number of elements (fine mesh).
    pub n: u32,
    /// Number of patches (coarse mesh), at least 1 and at most `n`.
    pub k: u32,
    /// Number of channels of the operator: 1 (grey scene) or 3 (RGB). Factored: the number of
    /// cores; plain: the number of `Y_c` blocks.
    pub channels: u32,
    /// How the matrix of `operator` is stored; must agree with it.
    pub precision: Precision,
    /// `n`: file position -> original element id (a permutation of `0..n`).
    pub order: Vec<u32>,
    /// `k + 1` offsets: patch `p` holds file positions `index[p]..index[p + 1]`; `index[0] = 0`,
    /// `index[k] = n`, strictly increasing (every patch non-empty).
    pub index: Vec<u32>,
    /// `n`: `w_e = A_e / A_P(e)`, finite, in (0, 1].
    pub weights: Vec<f32>,
    /// The operator: `F_k` with cores, or plain `Y_k`.
    pub operator: OperatorData,
    /// `n * 3` RGB reflectance per element (file order), finite, in [0, 1].
    pub reflectance: Vec<f32>,
    /// `n * 3` RGB emitted exitance per element (file order), finite, >= 0.
    pub emission: Vec<f32>,
    /// One planar polygon per element, in file order: what its form factors were computed on
    /// (its area, normal and centroid), and what is drawn unless `display.faces` is present.
    pub geometry: Geometry,
    /// Light groups, possibly none (then no LIGHTS section is written).
    pub lights: Vec<LightGroup>,
    /// For display (format 1.2, all optional): smooth weights, materials, point lights, cameras,
    /// BVH, lightmap coordinates (1.3), display faces (1.4). `Display::default()` writes none
    /// of them.
    pub display: Display,
}

impl OperatorFile {
    /// The layout of [`operator`](Self::operator).
    pub fn layout(&self) -> Layout {
        self.operator.layout()
    }

    /// The display faces: section FACES when present, else GEOMETRY's polygons (face `f` shows
    /// element `f`). What every reader draws, traces, smooths and exports; SMOOTH's corners,
    /// LIGHTMAP and the BVH's triangle ids are defined on them.
    pub fn faces(&self) -> FacesRef<'_> {
        FacesRef::new(&self.geometry, self.display.faces.as_ref())
    }
}
