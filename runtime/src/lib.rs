//! # lrr-runtime: relight a baked scene
//!
//! Loads an lrr operator file and evaluates the low-rank radiosity solution
//!
//! ```text
//! B_c = E_c + ρ_c ⊙ F_k M_c (Vᵀ E_c)          (c = r, g, b)
//! ```
//!
//! for any emission `E`, in O(nk): `X = Vᵀ E` is a segment sum over the index vector, `M_c X_c`
//! a k×k product, and one pass over `F_k` serves all three channels. No third-party
//! dependencies; no unsafe code.
//!
//! ```no_run
//! let op = lrr_runtime::Operator::load(std::path::Path::new("cornell.lrr")).unwrap();
//! let mut emission = op.baked_emission();      // per element, original ids, RGB exitance
//! emission.iter_mut().for_each(|e| e[0] *= 2.0); // make the lights redder
//! let mut radiosity = vec![[0.0f32; 3]; op.n()];
//! op.evaluate(&emission, &mut radiosity).unwrap();
//! ```

#![forbid(unsafe_code)]
// Indexed loops over RGB channels read like the maths they implement.
#![allow(clippy::needless_range_loop)]

mod error;
mod evaluate;
mod locate;

pub use error::RuntimeError;
pub use lrr_formats::{FormatError, OperatorFile};

use std::path::Path;

/// A loaded operator, ready to evaluate frames.
#[derive(Debug, Clone)]
pub struct Operator {
    file: OperatorFile,
    /// `F_k` decoded to f32 (n×k row-major, file order).
    fk: Vec<f32>,
}

impl Operator {
    /// Reads and validates an operator file.
    pub fn load(path: &Path) -> Result<Self, RuntimeError> {
        Self::from_file(OperatorFile::read(path)?)
    }

    /// Parses an operator file the application already holds in memory.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, RuntimeError> {
        Self::from_file(OperatorFile::from_bytes(bytes)?)
    }

    /// Wraps a decoded file (validated again).
    pub fn from_file(file: OperatorFile) -> Result<Self, RuntimeError> {
        file.validate()?;
        let fk = file.fk.to_f32();
        Ok(Self { file, fk })
    }

    /// Number of elements.
    pub fn n(&self) -> usize {
        self.file.n as usize
    }

    /// Number of patches.
    pub fn k(&self) -> usize {
        self.file.k as usize
    }

    /// Number of k×k cores (1 for a grey scene, 3 for RGB).
    pub fn channels(&self) -> usize {
        self.file.channels as usize
    }

    /// The decoded file.
    pub fn file(&self) -> &OperatorFile {
        &self.file
    }

    /// The bake's metadata (JSON text).
    pub fn metadata_json(&self) -> &str {
        &self.file.metadata_json
    }

    /// The emission the scene was baked with, per element in original id order.
    pub fn baked_emission(&self) -> Vec<[f32; 3]> {
        let mut out = vec![[0.0; 3]; self.n()];
        for (s, &id) in self.file.order.iter().enumerate() {
            let e = &self.file.emission[3 * s..3 * s + 3];
            out[id as usize] = [e[0], e[1], e[2]];
        }
        out
    }

    /// Reflectance per element in original id order.
    pub fn reflectance(&self) -> Vec<[f32; 3]> {
        let mut out = vec![[0.0; 3]; self.n()];
        for (s, &id) in self.file.order.iter().enumerate() {
            let r = &self.file.reflectance[3 * s..3 * s + 3];
            out[id as usize] = [r[0], r[1], r[2]];
        }
        out
    }

    /// Radiosity for the baked emission, per element in original id order.
    pub fn evaluate_baked(&self) -> Vec<[f32; 3]> {
        let e = self.baked_emission();
        let mut out = vec![[0.0; 3]; self.n()];
        self.evaluate(&e, &mut out)
            .expect("the baked emission is valid by construction");
        out
    }
}
