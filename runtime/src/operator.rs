//! The loaded operator: the validated file behind an `Arc`, shared with evaluators.

use std::path::Path;
use std::sync::Arc;

use lrr_formats::{Layout, OperatorData, OperatorFile, Precision};

use crate::albedo;
use crate::error::RuntimeError;

/// A loaded operator, ready to evaluate frames.
///
/// Cloning is cheap (the file is shared); an albedo edit through
/// [`set_reflectance`](Self::set_reflectance) copies the file first if it is shared, so clones
/// and evaluators made before the edit keep the old albedo.
#[derive(Debug, Clone)]
pub struct Operator {
    file: Arc<OperatorFile>,
}

impl Operator {
    /// Reads and validates an operator file; errors start with the path.
    pub fn load(path: &Path) -> Result<Self, RuntimeError> {
        Self::from_file(OperatorFile::read(path)?)
    }

    /// Parses an operator file the application already holds in memory (never panics on any
    /// bytes: a damaged file gets an error).
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, RuntimeError> {
        Self::from_file(OperatorFile::from_bytes(bytes)?)
    }

    /// Wraps a decoded file (validated again).
    pub fn from_file(file: OperatorFile) -> Result<Self, RuntimeError> {
        file.validate()?;
        Ok(Self {
            file: Arc::new(file),
        })
    }

    /// Number of elements.
    pub fn n(&self) -> usize {
        self.file.n as usize
    }

    /// Number of patches.
    pub fn k(&self) -> usize {
        self.file.k as usize
    }

    /// Channels of the operator: 1 (grey: one core, or one `Y_k` block) or 3.
    pub fn channels(&self) -> usize {
        self.file.channels as usize
    }

    /// How the operator is stored.
    pub fn layout(&self) -> Layout {
        self.file.layout()
    }

    /// How the stored matrix (`F_k` or `Y_k`) is stored.
    pub fn precision(&self) -> Precision {
        self.file.precision
    }

    /// Bytes of the stored matrix a frame reads: `n·k·size`, times 3 for plain RGB.
    pub fn matrix_bytes(&self) -> usize {
        self.n() * self.k() * self.precision().size() * self.matrix_blocks()
    }

    /// `n × k` blocks of the stored matrix: 1, or `channels` for the plain layout.
    pub(crate) fn matrix_blocks(&self) -> usize {
        match self.file.operator {
            OperatorData::PlainYk { .. } => self.channels(),
            OperatorData::Factored { .. } => 1,
        }
    }

    /// The names of the light groups, in the order
    /// [`evaluate_groups`](Self::evaluate_groups) takes intensities.
    pub fn light_groups(&self) -> impl ExactSizeIterator<Item = &str> {
        self.file.lights.iter().map(|g| g.name.as_str())
    }

    /// The index of the light group called `name`.
    pub fn light_group(&self, name: &str) -> Option<usize> {
        self.file.lights.iter().position(|g| g.name == name)
    }

    /// The decoded file (after any albedo edit).
    pub fn file(&self) -> &OperatorFile {
        &self.file
    }

    /// The shared file, for evaluators.
    pub(crate) fn shared(&self) -> &Arc<OperatorFile> {
        &self.file
    }

    /// The bake's metadata (JSON text).
    pub fn metadata_json(&self) -> &str {
        &self.file.metadata_json
    }

    /// The emission the scene was baked with, per element in original id order.
    pub fn baked_emission(&self) -> Vec<[f32; 3]> {
        self.per_element(&self.file.emission)
    }

    /// The emission of light-group intensities `a_g` (one per
    /// [`light_groups`](Self::light_groups) entry, finite, >= 0) per element, original ids:
    /// `E = Σ_g a_g E_g` (what [`Operator::evaluate_groups`] bounces).
    pub fn group_emission(&self, intensities: &[f32]) -> Result<Vec<[f32; 3]>, RuntimeError> {
        let groups = &self.file.lights;
        if intensities.len() != groups.len() {
            return Err(crate::error::input(format!(
                "light group intensities: {} values for the file's {} groups",
                intensities.len(),
                groups.len()
            )));
        }
        if let Some(g) = intensities
            .iter()
            .position(|a| !(a.is_finite() && *a >= 0.0))
        {
            return Err(crate::error::input(format!(
                "light group intensity {g} is {}; intensities must be finite and >= 0",
                intensities[g]
            )));
        }
        let mut out = vec![[0.0f32; 3]; self.n()];
        for (g, &a) in groups.iter().zip(intensities) {
            for (&s, e) in g.positions.iter().zip(g.emission.chunks_exact(3)) {
                let o = &mut out[self.file.order[s as usize] as usize];
                for c in 0..3 {
                    o[c] += a * e[c];
                }
            }
        }
        Ok(out)
    }

    /// Reflectance per element in original id order (after any albedo edit).
    pub fn reflectance(&self) -> Vec<[f32; 3]> {
        self.per_element(&self.file.reflectance)
    }

    fn per_element(&self, file_order: &[f32]) -> Vec<[f32; 3]> {
        let mut out = vec![[0.0; 3]; self.n()];
        for (s, &id) in self.file.order.iter().enumerate() {
            let v = &file_order[3 * s..3 * s + 3];
            out[id as usize] = [v[0], v[1], v[2]];
        }
        out
    }

    /// Changes the reflectance (one RGB value per element, original ids, each channel in
    /// [0, 1)) and rebuilds the cores, O(nk + k³), without a re-bake. The operator then has 1
    /// channel if the new reflectance is grey, else 3.
    ///
    /// Errors (`Input`, each message says which): a plain `Y_k` operator (the reflectance is
    /// baked into `Y_k`); a wrong length or a value outside [0, 1); a numerically singular
    /// system (1-norm condition number above [`MAX_CONDITION`](crate::MAX_CONDITION), given in
    /// the message). On an error nothing changes.
    ///
    /// Evaluators made before the edit keep the old albedo (they share the old file, which this
    /// copies once); edit them with [`Evaluator::set_reflectance`](crate::Evaluator::set_reflectance)
    /// or make new ones.
    pub fn set_reflectance(&mut self, rho: &[[f32; 3]]) -> Result<(), RuntimeError> {
        let edit = albedo::rebuild(&self.file, rho)?;
        let file = Arc::make_mut(&mut self.file);
        file.channels = edit.channels as u32;
        file.reflectance = edit.reflectance;
        if let OperatorData::Factored { cores, .. } = &mut file.operator {
            *cores = edit.cores;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use lrr_formats::{Geometry, OperatorData, OperatorFile, Precision, StoredMatrix};

    use crate::Operator;

    /// Two facing "infinite plates" (F = 1 each way), ρ = 0.5, stored with the file order
    /// reversed (file position 0 holds element 1) to exercise the permutation.
    fn plates() -> Operator {
        let square = |z: f32| [0.0, 0.0, z, 1.0, 0.0, z, 1.0, 1.0, z, 0.0, 1.0, z];
        let mut vertices = square(1.0).to_vec();
        vertices.extend(square(0.0));
        let file = OperatorFile {
            metadata_json: "{}".into(),
            n: 2,
            k: 2,
            channels: 1,
            precision: Precision::F32,
            order: vec![1, 0],
            index: vec![0, 1, 2],
            weights: vec![1.0, 1.0],
            operator: OperatorData::Factored {
                fk: StoredMatrix::F32(vec![0.0, 1.0, 1.0, 0.0]),
                cores: vec![4.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0, 4.0 / 3.0],
            },
            reflectance: vec![0.5; 6],
            emission: vec![0.0; 6],
            geometry: Geometry {
                vertex_count: vec![4, 4],
                vertices,
                normals: vec![0.0, 0.0, -1.0, 0.0, 0.0, 1.0],
            },
            lights: Vec::new(),
            display: Default::default(),
        };
        Operator::from_file(file).unwrap()
    }

    #[test]
    fn two_plates_match_the_closed_form() {
        // B0 = E0 + ρ B1, B1 = ρ B0 with E = (1, 0): B = (4/3, 2/3).
        let op = plates();
        let mut out = [[0.0; 3]; 2];
        op.evaluate(&[[1.0, 2.0, 0.0], [0.0; 3]], &mut out).unwrap();
        let expected = [[4.0 / 3.0, 8.0 / 3.0, 0.0], [2.0 / 3.0, 4.0 / 3.0, 0.0]];
        for (b, e) in out.iter().zip(expected) {
            for c in 0..3 {
                assert!((b[c] - e[c]).abs() < 1e-6, "{out:?}");
            }
        }
    }

    #[test]
    fn bad_emission_is_an_error() {
        let op = plates();
        let mut out = [[0.0; 3]; 2];
        assert!(
            op.evaluate(&[[f32::NAN, 0.0, 0.0], [0.0; 3]], &mut out)
                .is_err()
        );
        assert!(
            op.evaluate(&[[-1.0, 0.0, 0.0], [0.0; 3]], &mut out)
                .is_err()
        );
        assert!(op.evaluate(&[[1.0, 0.0, 0.0]], &mut out).is_err());
        assert!(
            out.iter().flatten().all(|x| *x == 0.0),
            "nothing written on error"
        );
    }

    #[test]
    fn locate_tells_coincident_surfaces_apart_by_normal() {
        let op = plates();
        // File position 0 is element 1 (the top plate, facing down).
        assert_eq!(op.locate([0.5, 0.5, 0.9], [0.0, 0.0, -1.0]), Some(1));
        assert_eq!(op.locate([0.5, 0.5, 0.9], [0.0, 0.0, 1.0]), Some(0));
    }
}
