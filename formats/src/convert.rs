//! From the factored layout to the papers' plain per-channel `Y_k`.
//!
//! `Y_c(s, q) = -rho_c(s) Σ_p F(s, p) M_c(p, q)`, accumulated in f64 and rounded once to the
//! file's precision. One k-length row of `F_k` times a k x k core per element and channel:
//! O(channels · n · k²), split over std threads by rows.

use std::num::NonZeroUsize;

use crate::error::FormatError;
use crate::file::{OperatorData, OperatorFile, Precision, StoredMatrix};
use crate::half::f32_to_f16;

impl OperatorFile {
    /// The same operator in the plain layout ([`Layout::PlainYk`](crate::Layout::PlainYk)):
    /// every other section is kept. Evaluating the result gives what evaluating `self` gives, up
    /// to the rounding of `Y_k` to the file's precision.
    ///
    /// The plain file has 1 channel when `self` has one core and grey reflectance (r = g = b for
    /// every element), else 3 (`Y_c = -diag(rho_c) F_k M_0` for each channel when one core
    /// serves coloured reflectance). `threads` = 0 uses every available core.
    ///
    /// Errors: `self` is already plain or invalid (`Invalid`); a `Y_k` value beyond the
    /// binary16 range (65504) in an f16 file (`Invalid`: convert an f32 file instead).
    pub fn to_plain_yk(&self, threads: usize) -> Result<OperatorFile, FormatError> {
        let (channels, yk) = self.plain_yk(threads)?;
        Ok(OperatorFile {
            channels,
            operator: OperatorData::PlainYk { yk },
            ..self.clone_without_operator()
        })
    }

    /// [`to_plain_yk`](Self::to_plain_yk) in place of `self`: every other section moves into
    /// the result rather than being copied, and `F_k` is dropped once `Y_k` is made.
    pub fn into_plain_yk(mut self, threads: usize) -> Result<OperatorFile, FormatError> {
        let (channels, yk) = self.plain_yk(threads)?;
        self.channels = channels;
        self.operator = OperatorData::PlainYk { yk };
        Ok(self)
    }

    /// The plain layout's channels and `Y_k` (see [`to_plain_yk`](Self::to_plain_yk)).
    fn plain_yk(&self, threads: usize) -> Result<(u32, StoredMatrix), FormatError> {
        self.validate()?;
        let OperatorData::Factored { fk, cores } = &self.operator else {
            return Err(FormatError::invalid(
                "to_plain_yk: the operator is already in the plain Y_k layout",
            ));
        };
        let (n, k) = (self.n as usize, self.k as usize);
        let grey = self
            .reflectance
            .chunks_exact(3)
            .all(|r| r[0] == r[1] && r[1] == r[2]);
        let channels = if self.channels == 1 && grey { 1 } else { 3 };
        let plan = Plan {
            fk,
            cores,
            core_channels: self.channels as usize,
            reflectance: &self.reflectance,
            k,
        };
        let mut yk = vec![0.0f32; channels * n * k];
        let threads = match threads {
            0 => std::thread::available_parallelism().map_or(1, NonZeroUsize::get),
            t => t,
        }
        .clamp(1, n);
        std::thread::scope(|scope| {
            for (rows, blocks) in split_rows(&mut yk, channels, n, k, threads) {
                let plan = &plan;
                scope.spawn(move || plan.rows(rows, blocks));
            }
        });
        let yk = match self.precision {
            Precision::F32 => StoredMatrix::F32(yk),
            Precision::F16 => StoredMatrix::F16(to_f16(&yk, n, k)?),
        };
        Ok((channels as u32, yk))
    }

    /// A copy of every field but the operator (left as an empty plain `Y_k`).
    fn clone_without_operator(&self) -> OperatorFile {
        OperatorFile {
            metadata_json: self.metadata_json.clone(),
            n: self.n,
            k: self.k,
            channels: self.channels,
            precision: self.precision,
            order: self.order.clone(),
            index: self.index.clone(),
            weights: self.weights.clone(),
            operator: OperatorData::PlainYk {
                yk: StoredMatrix::F32(Vec::new()),
            },
            reflectance: self.reflectance.clone(),
            emission: self.emission.clone(),
            geometry: self.geometry.clone(),
            lights: self.lights.clone(),
            display: self.display.clone(),
        }
    }
}

/// What every thread reads.
struct Plan<'a> {
    fk: &'a StoredMatrix,
    cores: &'a [f64],
    core_channels: usize,
    reflectance: &'a [f32],
    k: usize,
}

impl Plan<'_> {
    /// Rows `rows` of every channel block; `blocks[c]` holds those rows of channel `c`.
    fn rows(&self, rows: std::ops::Range<usize>, mut blocks: Vec<&mut [f32]>) {
        let k = self.k;
        let mut f = vec![0.0f64; k];
        let mut t = vec![0.0f64; k];
        for (i, s) in rows.enumerate() {
            for (q, v) in f.iter_mut().enumerate() {
                *v = f64::from(self.fk.get(s * k + q).unwrap_or(0.0));
            }
            for (c, block) in blocks.iter_mut().enumerate() {
                let core = if self.core_channels == 1 { 0 } else { c };
                let m = &self.cores[core * k * k..(core + 1) * k * k];
                t.fill(0.0);
                for (fp, m_row) in f.iter().zip(m.chunks_exact(k)) {
                    if *fp != 0.0 {
                        t.iter_mut().zip(m_row).for_each(|(t, m)| *t += fp * m);
                    }
                }
                let rho = -f64::from(self.reflectance[3 * s + c]);
                let out = &mut block[i * k..(i + 1) * k];
                out.iter_mut()
                    .zip(&t)
                    .for_each(|(y, t)| *y = (rho * t) as f32);
            }
        }
    }
}

/// Splits `yk` (channel-major, `n x k` per channel) into `threads` row ranges, each with its
/// slice of every channel block.
fn split_rows(
    yk: &mut [f32],
    channels: usize,
    n: usize,
    k: usize,
    threads: usize,
) -> Vec<(std::ops::Range<usize>, Vec<&mut [f32]>)> {
    let bounds: Vec<usize> = (0..=threads).map(|t| n * t / threads).collect();
    let mut parts: Vec<(std::ops::Range<usize>, Vec<&mut [f32]>)> = bounds
        .windows(2)
        .map(|w| (w[0]..w[1], Vec::with_capacity(channels)))
        .collect();
    for block in yk.chunks_mut(n * k).take(channels) {
        let mut rest = block;
        for (rows, slices) in parts.iter_mut() {
            let (head, tail) = std::mem::take(&mut rest).split_at_mut(rows.len() * k);
            slices.push(head);
            rest = tail;
        }
    }
    parts
}

/// Rounds to binary16, refusing values beyond its range.
fn to_f16(yk: &[f32], n: usize, k: usize) -> Result<Vec<u16>, FormatError> {
    if let Some(i) = yk.iter().position(|v| v.abs() > 65504.0) {
        return Err(FormatError::invalid(format!(
            "to_plain_yk: Y_k of channel {}, element {}, patch {} is {}, beyond the binary16 \
             range (65504): convert an f32 file instead",
            i / (n * k),
            i / k % n,
            i % k,
            yk[i]
        )));
    }
    Ok(yk.iter().map(|&v| f32_to_f16(v)).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testdata::sample;

    /// The definition, one entry at a time.
    fn expected(f: &OperatorFile, c: usize, s: usize, q: usize) -> f64 {
        let OperatorData::Factored { fk, cores } = &f.operator else {
            unreachable!()
        };
        let k = f.k as usize;
        let core = if f.channels == 1 { 0 } else { c };
        let sum: f64 = (0..k)
            .map(|p| f64::from(fk.get(s * k + p).unwrap()) * cores[core * k * k + p * k + q])
            .sum();
        -f64::from(f.reflectance[3 * s + c]) * sum
    }

    #[test]
    fn plain_matches_the_definition_for_any_thread_count() {
        for (precision, channels) in [(Precision::F32, 3), (Precision::F32, 1)] {
            let f = sample(precision, channels);
            let one = f.to_plain_yk(1).unwrap();
            for threads in [2, 3, 7, 0] {
                assert_eq!(f.to_plain_yk(threads).unwrap(), one);
            }
            assert_eq!(f.clone().into_plain_yk(2).unwrap(), one);
            // The sample's reflectance is coloured: 3 blocks even from one core.
            assert_eq!(one.channels, 3);
            one.validate().unwrap();
            let OperatorData::PlainYk { yk } = &one.operator else {
                unreachable!()
            };
            for c in 0..3 {
                for s in 0..6 {
                    for q in 0..2 {
                        let got = f64::from(yk.get((c * 6 + s) * 2 + q).unwrap());
                        let want = expected(&f, c, s, q);
                        assert!((got - want).abs() <= 1e-7 * want.abs(), "{got} vs {want}");
                    }
                }
            }
            assert_eq!(one.lights, f.lights);
            assert_eq!(one.geometry, f.geometry);
        }
    }

    #[test]
    fn grey_single_core_stays_single_and_f16_rounds() {
        let mut f = sample(Precision::F16, 1);
        f.reflectance = vec![0.5; 18];
        let plain = f.to_plain_yk(2).unwrap();
        assert_eq!(plain.channels, 1);
        assert_eq!(plain.precision, Precision::F16);
        let OperatorData::PlainYk { yk } = &plain.operator else {
            unreachable!()
        };
        assert_eq!(yk.len(), 12);
        let want = expected(&f, 0, 3, 1);
        let got = f64::from(yk.get(3 * 2 + 1).unwrap());
        assert!((got - want).abs() <= want.abs() / 2048.0, "{got} vs {want}");
        assert_eq!(f.into_plain_yk(1).unwrap(), plain);
        let e = plain.to_plain_yk(1).unwrap_err();
        assert!(e.message.contains("already"), "{e}");
        let e = plain.into_plain_yk(1).unwrap_err();
        assert!(e.message.contains("already"), "{e}");
    }
}
