//! Evaluation of `B = E + ρ ⊙ F_k M (Vᵀ E)` (reference version: straightforward loops, f64
//! accumulation; the next issue makes it fast).

use crate::{Operator, RuntimeError};

impl Operator {
    /// Radiosity for an RGB emission per element (original id order) into `out` (same order).
    /// Emission must be finite and non-negative.
    pub fn evaluate(
        &self,
        emission: &[[f32; 3]],
        out: &mut [[f32; 3]],
    ) -> Result<(), RuntimeError> {
        let (n, k) = (self.n(), self.k());
        if emission.len() != n || out.len() != n {
            return Err(RuntimeError::Input(format!(
                "emission and output must hold one RGB value per element: expected {n}, got {} and {}",
                emission.len(),
                out.len()
            )));
        }
        if let Some((i, e)) = emission
            .iter()
            .enumerate()
            .find(|(_, e)| e.iter().any(|c| !c.is_finite() || *c < 0.0))
        {
            return Err(RuntimeError::Input(format!(
                "emission of element {i} is {e:?}; emission must be finite and non-negative"
            )));
        }
        let f = &self.file;
        // X = Vᵀ E: weighted segment sums over the index vector.
        let mut x = vec![[0.0f64; 3]; k];
        for (p, xp) in x.iter_mut().enumerate() {
            for s in f.index[p] as usize..f.index[p + 1] as usize {
                let e = emission[f.order[s] as usize];
                let w = f64::from(f.weights[s]);
                for c in 0..3 {
                    xp[c] += w * f64::from(e[c]);
                }
            }
        }
        // Z_c = M_c X_c.
        let mut z = vec![[0.0f64; 3]; k];
        for c in 0..3 {
            let core = if self.channels() == 1 { 0 } else { c };
            let m = &f.cores[core * k * k..(core + 1) * k * k];
            for (p, zp) in z.iter_mut().enumerate() {
                zp[c] = m[p * k..(p + 1) * k]
                    .iter()
                    .zip(&x)
                    .map(|(a, xq)| a * xq[c])
                    .sum();
            }
        }
        // W = F_k Z, then B = E + ρ ⊙ W.
        for s in 0..n {
            let row = &self.fk[s * k..(s + 1) * k];
            let mut w = [0.0f64; 3];
            for (fq, zq) in row.iter().zip(&z) {
                let fq = f64::from(*fq);
                for c in 0..3 {
                    w[c] += fq * zq[c];
                }
            }
            let id = f.order[s] as usize;
            let e = emission[id];
            for c in 0..3 {
                out[id][c] = (f64::from(e[c]) + f64::from(f.reflectance[3 * s + c]) * w[c]) as f32;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use lrr_formats::{FkData, Geometry, Layout, OperatorFile, Precision};

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
            layout: Layout::Factored,
            order: vec![1, 0],
            index: vec![0, 1, 2],
            weights: vec![1.0, 1.0],
            fk: FkData::F32(vec![0.0, 1.0, 1.0, 0.0]),
            cores: vec![4.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0, 4.0 / 3.0],
            reflectance: vec![0.5; 6],
            emission: vec![0.0; 6],
            geometry: Geometry {
                vertex_count: vec![4, 4],
                vertices,
                normals: vec![0.0, 0.0, -1.0, 0.0, 0.0, 1.0],
            },
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
