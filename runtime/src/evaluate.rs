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
