//! The papers' "full" baseline, for benchmarks only: a dense `V_k`.
//!
//! [`DenseV`] stores `V_k` as a dense n×k f32 matrix (one non-zero per row, the element's
//! weight) and the plain per-channel `Y_k` in f32, and evaluates `X = V_kᵀ E` as a dense
//! product (O(nk) instead of the index vector's O(n)) and then `B_c = E_c - Y_c X_c`. It reads
//! `(1 + channels) · n·k·4` bytes per frame against `n·k·size` for the factored layout. Do not
//! use it to render: it exists so that benchmarks can show what the sparse `V` and the factored
//! layout save.
//!
//! Threads are scoped per frame (spawning costs microseconds against frames of milliseconds).
//! The `Y_k` pass uses the [`Evaluator`](crate::Evaluator)'s kernels; the `V_k` pass is an f32
//! axpy per row that the compiler vectorises, flushed to f64 every 256 rows.

use lrr_formats::{OperatorData, StoredMatrix};

use crate::error::{RuntimeError, input};
use crate::kernel::{self, Gather, Rows, SimdLevel};
use crate::operator::Operator;
use crate::rgb::{Rgb, RgbMut};

/// Rows of `V` summed in f32 before the partial `X` is added in f64.
const FLUSH_ROWS: usize = 256;

/// The dense-`V` baseline (see the [module docs](self)).
#[derive(Debug, Clone)]
pub struct DenseV {
    n: usize,
    k: usize,
    /// `Y_k` blocks: 1 (grey) or 3.
    blocks: usize,
    /// n×k, rows in file order.
    v: Vec<f32>,
    /// `blocks` × n×k, f32.
    y: Vec<f32>,
    order: Vec<u32>,
    threads: usize,
    simd: SimdLevel,
}

impl DenseV {
    /// Materialises `V_k` and `Y_k` of `op` (converting a factored operator to the plain
    /// layout: `O(channels · n · k²)`). `threads` as for the [`Evaluator`](crate::Evaluator).
    pub fn new(op: &Operator, threads: usize) -> Result<Self, RuntimeError> {
        let file = op.file();
        let (n, k) = (op.n(), op.k());
        let plain;
        let file = match file.operator {
            OperatorData::PlainYk { .. } => file,
            OperatorData::Factored { .. } => {
                plain = file.to_plain_yk(threads)?;
                &plain
            }
        };
        let y = match file.operator.matrix() {
            StoredMatrix::F32(v) => v.clone(),
            m @ StoredMatrix::F16(_) => m.to_f32(),
        };
        let mut v = vec![0.0f32; n * k];
        for p in 0..k {
            for s in file.index[p] as usize..file.index[p + 1] as usize {
                v[s * k + p] = file.weights[s];
            }
        }
        let threads = match threads {
            0 => std::thread::available_parallelism().map_or(1, |t| t.get()),
            t => t,
        }
        .clamp(1, n);
        Ok(DenseV {
            n,
            k,
            blocks: file.channels as usize,
            v,
            y,
            order: file.order.clone(),
            threads,
            simd: SimdLevel::detect(),
        })
    }

    /// Bytes read per frame: `V_k` and every `Y_c`.
    pub fn bytes_per_frame(&self) -> usize {
        4 * (self.v.len() + self.y.len())
    }

    /// `B_c = E_c - Y_c (V_kᵀ E_c)` for `emission` (original ids) into `out`.
    pub fn evaluate(&self, emission: Rgb<'_>, mut out: RgbMut<'_>) -> Result<(), RuntimeError> {
        emission.check(self.n, "emission")?;
        out.check(self.n, "output")?;
        if let Some(id) =
            (0..self.n).find(|&i| !emission.at(i).iter().all(|c| c.is_finite() && *c >= 0.0))
        {
            return Err(input(format!(
                "emission of element {id} is {:?}: emission must be finite and non-negative",
                emission.at(id)
            )));
        }
        let kp = kernel::padded(self.k);
        let mut z = vec![0.0f32; 3 * kp];
        let x = self.dense_x(&emission);
        for (c, plane) in z.chunks_exact_mut(kp).enumerate() {
            for (zq, xq) in plane.iter_mut().zip(&x) {
                *zq = xq[c] as f32;
            }
        }
        let mut w = vec![0.0f32; 3 * self.n];
        let rows = self.n.div_ceil(self.threads);
        std::thread::scope(|scope| {
            for (t, w) in w.chunks_mut(3 * rows).enumerate() {
                let (z, start) = (&z, t * rows);
                scope.spawn(move || self.gather(start..start + w.len() / 3, z, kp, w));
            }
        });
        for (s, ws) in w.chunks_exact(3).enumerate() {
            let id = self.order[s] as usize;
            let e = emission.at(id);
            out.set(
                id,
                std::array::from_fn(|c| (f64::from(e[c]) - f64::from(ws[c])) as f32),
            );
        }
        Ok(())
    }

    /// `X = V_kᵀ E`, dense: every row of `V` is read, zeros included.
    fn dense_x(&self, emission: &Rgb<'_>) -> Vec<[f64; 3]> {
        let rows = self.n.div_ceil(self.threads);
        let partials: Vec<Vec<[f64; 3]>> = std::thread::scope(|scope| {
            let handles: Vec<_> = (0..self.threads)
                .map(|t| {
                    let range = t * rows..((t + 1) * rows).min(self.n);
                    scope.spawn(move || self.dense_x_rows(range, emission))
                })
                .collect();
            handles.into_iter().filter_map(|h| h.join().ok()).collect()
        });
        let mut x = vec![[0.0f64; 3]; self.k];
        for part in partials {
            for (xq, pq) in x.iter_mut().zip(part) {
                for c in 0..3 {
                    xq[c] += pq[c];
                }
            }
        }
        x
    }

    /// The partial `V_kᵀ E` of some rows: f32 axpys (vectorised over columns), flushed to f64
    /// every [`FLUSH_ROWS`] rows.
    fn dense_x_rows(&self, rows: std::ops::Range<usize>, emission: &Rgb<'_>) -> Vec<[f64; 3]> {
        let k = self.k;
        let mut total = vec![[0.0f64; 3]; k];
        let mut acc = vec![vec![0.0f32; k]; 3];
        for (i, s) in rows.enumerate() {
            let e = emission.at(self.order[s] as usize);
            let row = &self.v[s * k..(s + 1) * k];
            for (c, acc) in acc.iter_mut().enumerate() {
                acc.iter_mut().zip(row).for_each(|(a, v)| *a += v * e[c]);
            }
            if (i + 1) % FLUSH_ROWS == 0 {
                flush(&mut acc, &mut total);
            }
        }
        flush(&mut acc, &mut total);
        total
    }

    /// `W` of some rows from every `Y_c` block.
    fn gather(&self, rows: std::ops::Range<usize>, z: &[f32], kp: usize, w: &mut [f32]) {
        let (n, k) = (self.n, self.k);
        let block = |c: usize| Rows::F32(&self.y[(c * n + rows.start) * k..(c * n + rows.end) * k]);
        if self.blocks == 1 {
            let g = Gather {
                m: block(0),
                k,
                z,
                kp,
                offset: 0,
            };
            kernel::gather::<3>(self.simd, &g, w);
        } else {
            for c in 0..3 {
                let g = Gather {
                    m: block(c),
                    k,
                    z: &z[c * kp..],
                    kp,
                    offset: c,
                };
                kernel::gather::<1>(self.simd, &g, w);
            }
        }
    }
}

fn flush(acc: &mut [Vec<f32>], total: &mut [[f64; 3]]) {
    for (c, acc) in acc.iter_mut().enumerate() {
        for (t, a) in total.iter_mut().zip(acc.iter_mut()) {
            t[c] += f64::from(*a);
            *a = 0.0;
        }
    }
}
