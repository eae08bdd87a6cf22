//! The decoded operator file and its reading and writing.
//!
//! [`OperatorFile`] owns every section, decoded. `from_bytes` runs the container checks, then
//! checks each payload length against the dimensions, then [`validate`](OperatorFile::validate):
//! a value that comes back from `from_bytes` satisfies every invariant documented on the fields.

use std::path::Path;

use crate::atomic::write_atomic;
use crate::codec;
use crate::container::Container;
use crate::error::{ErrorKind, FormatError};
use crate::half::{f16_to_f32, f32_to_f16};
use crate::validate;

/// How `F_k` is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Precision {
    /// 4-byte IEEE single precision (DIMS code 0).
    F32,
    /// 2-byte IEEE binary16, see [`f32_to_f16`](crate::f32_to_f16) (DIMS code 1).
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
pub enum FkData {
    /// Single precision.
    F32(Vec<f32>),
    /// binary16 bits.
    F16(Vec<u16>),
}

impl FkData {
    /// Number of values.
    pub fn len(&self) -> usize {
        match self {
            FkData::F32(v) => v.len(),
            FkData::F16(v) => v.len(),
        }
    }

    /// Whether there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The precision the values are stored in.
    pub fn precision(&self) -> Precision {
        match self {
            FkData::F32(_) => Precision::F32,
            FkData::F16(_) => Precision::F16,
        }
    }

    /// Value `i` as f32 (exact for both precisions), `None` past the end.
    pub fn get(&self, i: usize) -> Option<f32> {
        match self {
            FkData::F32(v) => v.get(i).copied(),
            FkData::F16(v) => v.get(i).map(|&h| f16_to_f32(h)),
        }
    }

    /// All values as f32.
    pub fn to_f32(&self) -> Vec<f32> {
        match self {
            FkData::F32(v) => v.clone(),
            FkData::F16(v) => v.iter().map(|&h| f16_to_f32(h)).collect(),
        }
    }

    /// `values` stored in `precision` (rounded to nearest for binary16).
    pub fn from_f32(values: &[f32], precision: Precision) -> Self {
        match precision {
            Precision::F32 => FkData::F32(values.to_vec()),
            Precision::F16 => FkData::F16(values.iter().map(|&v| f32_to_f16(v)).collect()),
        }
    }
}

/// The operator itself, in one of the two [`Layout`]s.
#[derive(Debug, Clone, PartialEq)]
pub enum OperatorData {
    /// `F_k` and the cores: `B_c = E_c + rho_c ⊙ F_k M_c (Vᵀ E_c)`.
    Factored {
        /// `n * k` element-to-patch form factors `F_k`, finite, >= 0.
        fk: FkData,
        /// `channels * k * k` row-major: `M_c = (I - Vᵀ diag(rho_c) F_k)⁻¹`, finite.
        cores: Vec<f64>,
    },
    /// Plain `Y_c = -diag(rho_c) F_k M_c`: `B_c = E_c - Y_c (Vᵀ E_c)`.
    PlainYk {
        /// `channels * n * k` values, finite: channel-major, each channel an n x k row-major
        /// block with rows in file order.
        yk: FkData,
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
    pub fn matrix(&self) -> &FkData {
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

/// The fine mesh for display, one polygon per element, in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct Geometry {
    /// `n` entries, each 3 (triangle) or 4 (quad).
    pub vertex_count: Vec<u8>,
    /// `n * 4 * 3`: x, y, z of up to 4 vertices; the unused 4th vertex of a triangle is zeros.
    pub vertices: Vec<f32>,
    /// `n * 3`, unit length (within 1e-3).
    pub normals: Vec<f32>,
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
    /// Display geometry.
    pub geometry: Geometry,
    /// Light groups, possibly none (then no LIGHTS section is written).
    pub lights: Vec<LightGroup>,
}

impl OperatorFile {
    /// The layout of [`operator`](Self::operator).
    pub fn layout(&self) -> Layout {
        self.operator.layout()
    }

    /// Encodes the file. Runs [`validate`](Self::validate) first: an inconsistent struct gives an
    /// `Invalid` error and no bytes.
    pub fn to_bytes(&self) -> Result<Vec<u8>, FormatError> {
        self.validate()?;
        Ok(codec::encode(self))
    }

    /// Decodes and validates a file. Never panics, never reads out of bounds, and allocates about
    /// the size of `bytes` at most, whatever the bytes are.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, FormatError> {
        let container = Container::parse(bytes)?;
        let file = codec::decode(&container)?;
        file.validate()?;
        Ok(file)
    }

    /// Reads and decodes the file at `path`; every error message starts with the path.
    pub fn read(path: &Path) -> Result<Self, FormatError> {
        let bytes = std::fs::read(path).map_err(|e| {
            FormatError::new(
                ErrorKind::Io,
                format!("cannot read {}: {e}", path.display()),
            )
        })?;
        Self::from_bytes(&bytes).map_err(|e| e.context(path.display()))
    }

    /// Validates, encodes and writes the file atomically (see [`write_atomic`]): readers see the
    /// old file or the new one, never a mix.
    pub fn write(&self, path: &Path) -> Result<(), FormatError> {
        let bytes = self.to_bytes().map_err(|e| e.context(path.display()))?;
        write_atomic(path, &bytes)
    }

    /// Checks every invariant documented on the fields. Messages name the section, the index and
    /// the problem, e.g. `section FK: element 4, patch 1: value NaN must be finite and >= 0`.
    pub fn validate(&self) -> Result<(), FormatError> {
        validate::check(self)
    }
}
