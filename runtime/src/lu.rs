//! Dense LU factorisation with partial pivoting in f64, for the k×k cores of an albedo edit
//! (the runtime has no linear-algebra dependency). O(k³); row-major throughout.

/// `P A = L U` of a k×k matrix: unit lower `L` and upper `U` packed in one array.
pub(crate) struct Lu {
    k: usize,
    lu: Vec<f64>,
    /// Row `i` of `P A` is row `perm[i]` of `A`.
    perm: Vec<usize>,
}

impl Lu {
    /// Factors `a` (row-major k×k). `Err(column)` when a pivot is exactly zero there.
    pub(crate) fn factor(mut a: Vec<f64>, k: usize) -> Result<Self, usize> {
        let mut perm: Vec<usize> = (0..k).collect();
        for j in 0..k {
            let pivot = (j..k)
                .max_by(|&x, &y| a[x * k + j].abs().total_cmp(&a[y * k + j].abs()))
                .unwrap_or(j);
            if a[pivot * k + j] == 0.0 || !a[pivot * k + j].is_finite() {
                return Err(j);
            }
            if pivot != j {
                for q in 0..k {
                    a.swap(j * k + q, pivot * k + q);
                }
                perm.swap(j, pivot);
            }
            let (top, bottom) = a.split_at_mut((j + 1) * k);
            let row_j = &top[j * k..];
            let d = row_j[j];
            for row in bottom.chunks_exact_mut(k) {
                let l = row[j] / d;
                row[j] = l;
                if l != 0.0 {
                    for (x, u) in row[j + 1..].iter_mut().zip(&row_j[j + 1..]) {
                        *x -= l * u;
                    }
                }
            }
        }
        Ok(Lu { k, lu: a, perm })
    }

    /// Solves `A x = b` in place.
    pub(crate) fn solve(&self, b: &mut [f64]) {
        let k = self.k;
        let mut x: Vec<f64> = self.perm.iter().map(|&i| b[i]).collect();
        for i in 0..k {
            let row = &self.lu[i * k..i * k + i];
            x[i] -= row.iter().zip(&x[..i]).map(|(l, x)| l * x).sum::<f64>();
        }
        for i in (0..k).rev() {
            let row = &self.lu[i * k..(i + 1) * k];
            let tail: f64 = row[i + 1..]
                .iter()
                .zip(&x[i + 1..])
                .map(|(u, x)| u * x)
                .sum();
            x[i] = (x[i] - tail) / row[i];
        }
        b.copy_from_slice(&x);
    }

    /// `A⁻¹`, row-major.
    pub(crate) fn inverse(&self) -> Vec<f64> {
        let k = self.k;
        let mut inv = vec![0.0; k * k];
        let mut col = vec![0.0; k];
        for j in 0..k {
            col.fill(0.0);
            col[j] = 1.0;
            self.solve(&mut col);
            for (i, v) in col.iter().enumerate() {
                inv[i * k + j] = *v;
            }
        }
        inv
    }
}

/// The 1-norm (largest column sum of absolute values) of a row-major k×k matrix.
pub(crate) fn norm1(a: &[f64], k: usize) -> f64 {
    let mut sums = vec![0.0f64; k];
    for row in a.chunks_exact(k) {
        for (s, v) in sums.iter_mut().zip(row) {
            *s += v.abs();
        }
    }
    sums.into_iter().fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_of_a_matrix_that_needs_pivoting() {
        let a = vec![0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0];
        let inv = Lu::factor(a.clone(), 3).unwrap().inverse();
        for i in 0..3 {
            for j in 0..3 {
                let p: f64 = (0..3).map(|q| a[i * 3 + q] * inv[q * 3 + j]).sum();
                assert!(
                    (p - f64::from(u8::from(i == j))).abs() < 1e-14,
                    "{i} {j}: {p}"
                );
            }
        }
        assert_eq!(norm1(&a, 3), 4.0);
    }

    #[test]
    fn singular_matrix_names_the_column() {
        let a = vec![1.0, 2.0, 2.0, 4.0];
        assert_eq!(Lu::factor(a, 2).err(), Some(1));
    }
}
