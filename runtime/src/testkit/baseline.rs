//! The papers' "full" baseline, for benchmarks only: a dense `V_k`.
//!
//! [`DenseV`] stores `V_k` as a dense n×k matrix (one non-zero per row, the element's weight)
//! and the plain per-channel `Y_k`, both in the operator's precision, and evaluates `X = V_kᵀ E`
//! as a dense product (O(nk) instead of the index vector's O(n)) and then `B_c = E_c - Y_c X_c`.
//! It reads `(1 + blocks) · n·k·size` bytes per frame (blocks: 3 `Y_c`, or 1 for grey) against
//! `n·k·size` for the factored layout. Do not use it to render: it exists so that benchmarks can
//! show what the sparse `V` and the factored layout save.
//!
//! It is engineered like the [`Evaluator`](crate::Evaluator), so that a speed-up over it is the
//! gain of the layout and not of the code: the same persistent pool (chunks of rows taken
//! from a queue, buffers allocated once, no allocation per frame), the same AVX2 + FMA + F16C
//! gather with its software prefetch for `Y_k` (one channel per block), and for `V_kᵀ E` the
//! kernel `transposed` (AVX2, FMA, the same prefetch; per chunk f32 sums flushed to f64 every
//! 256 rows, then the chunks' sums added on the caller's thread as they come back).
//! `V_k`'s rows are in original id order, so that pass streams the emission as given; the
//! emission is copied once per frame into a buffer the threads share (persistent threads cannot
//! borrow the caller's slice), the counterpart of the evaluator's O(n) segment sums.

use std::num::NonZeroUsize;
use std::ops::Range;
use std::sync::{Arc, PoisonError, RwLock};

use lrr_formats::{OperatorData, StoredMatrix, f32_to_f16};

use crate::error::{RuntimeError, input};
use crate::evaluator::chunk_bounds;
use crate::kernel::{self, Gather, Rows, SimdLevel};
use crate::operator::Operator;
use crate::pool::{Chunk, Pool, Task, Work};
use crate::rgb::{Rgb, RgbMut};

/// Rows of `V` summed in f32 before the partial `X` is added in f64.
const FLUSH_ROWS: usize = 256;

/// The dense-`V` baseline (see the [module docs](self)).
pub struct DenseV {
    n: usize,
    k: usize,
    kp: usize,
    work: Arc<DenseWork>,
    pool: Pool,
    /// File row `s` is element `order[s]`.
    order: Vec<u32>,
    /// `X`, `k` rows of 3 channels.
    x: Vec<f64>,
    /// `3 * kp`: the planes of `X` as f32, the gather's input.
    z: Vec<f32>,
}

impl std::fmt::Debug for DenseV {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DenseV")
            .field("n", &self.n)
            .field("k", &self.k)
            .field("blocks", &self.work.blocks)
            .field("threads", &self.pool.threads())
            .finish()
    }
}

/// What the threads read: `V_k`, `Y_k` and the frame's emission.
struct DenseWork {
    n: usize,
    k: usize,
    kp: usize,
    /// `Y_k` blocks: 1 (grey) or 3.
    blocks: usize,
    /// n×k, rows in original id order.
    v: StoredMatrix,
    /// `blocks` × n×k, rows in file order.
    y: StoredMatrix,
    /// This frame's emission, interleaved, original id order (written between frames).
    e: RwLock<Vec<f32>>,
    simd: SimdLevel,
}

impl DenseV {
    /// Materialises `V_k` and `Y_k` of `op` in its precision (converting a factored operator to
    /// the plain layout: `O(channels · n · k²)`). `threads` as for the
    /// [`Evaluator`](crate::Evaluator), with the same chunks.
    pub fn new(op: &Operator, threads: usize) -> Result<Self, RuntimeError> {
        let file = op.file();
        let (n, k) = (op.n(), op.k());
        let threads = match threads {
            0 => std::thread::available_parallelism().map_or(1, NonZeroUsize::get),
            t => t,
        }
        .clamp(1, n);
        let plain;
        let file = match file.operator {
            OperatorData::PlainYk { .. } => file,
            OperatorData::Factored { .. } => {
                plain = file.to_plain_yk(threads)?;
                &plain
            }
        };
        let mut v = vec![0.0f32; n * k];
        for p in 0..k {
            for s in file.index[p] as usize..file.index[p + 1] as usize {
                v[file.order[s] as usize * k + p] = file.weights[s];
            }
        }
        let y = file.operator.matrix().clone();
        let v = match y {
            StoredMatrix::F32(_) => StoredMatrix::F32(v),
            StoredMatrix::F16(_) => StoredMatrix::F16(v.iter().map(|&w| f32_to_f16(w)).collect()),
        };
        let kp = kernel::padded(k);
        let work = Arc::new(DenseWork {
            n,
            k,
            kp,
            blocks: file.channels as usize,
            v,
            y,
            e: RwLock::new(vec![0.0; 3 * n]),
            simd: SimdLevel::detect(),
        });
        let bounds = chunk_bounds(n, threads);
        let dyn_work: Arc<dyn Work> = Arc::clone(&work) as Arc<dyn Work>;
        let pool = Pool::start(dyn_work, &bounds, threads - 1, 3 * kp, (3 * k, 3 * kp))?;
        Ok(DenseV {
            n,
            k,
            kp,
            work,
            pool,
            order: file.order.clone(),
            x: vec![0.0; 3 * k],
            z: vec![0.0; 3 * kp],
        })
    }

    /// Bytes read per frame: `V_k` and every `Y_c`, in the operator's precision.
    pub fn bytes_per_frame(&self) -> usize {
        matrix_bytes(&self.work.v) + matrix_bytes(&self.work.y)
    }

    /// `B_c = E_c - Y_c (V_kᵀ E_c)` for `emission` (original ids) into `out`. Emission must be
    /// finite and non-negative; on an error nothing is written.
    pub fn evaluate(&mut self, emission: Rgb<'_>, mut out: RgbMut<'_>) -> Result<(), RuntimeError> {
        emission.check(self.n, "emission")?;
        out.check(self.n, "output")?;
        {
            let mut e = self.work.e.write().unwrap_or_else(PoisonError::into_inner);
            let mut bad = None;
            for (i, ei) in e.chunks_exact_mut(3).enumerate() {
                let v = emission.at(i);
                if bad.is_none() && !v.iter().all(|&c| kernel::emission_ok(c)) {
                    bad = Some(i);
                }
                ei.copy_from_slice(&v);
            }
            if let Some(id) = bad {
                return Err(input(format!(
                    "emission of element {id} is {:?}: emission must be finite and non-negative",
                    emission.at(id)
                )));
            }
        }
        let (x, z, kp, pool) = (&mut self.x, &mut self.z, self.kp, &mut self.pool);
        x.fill(0.0);
        pool.run(Task::Partial, z, |chunk| {
            for (xq, p) in x.iter_mut().zip(&chunk.partial) {
                *xq += p;
            }
        })?;
        for (c, plane) in z.chunks_exact_mut(kp).enumerate() {
            for (zq, xq) in plane.iter_mut().zip(x.chunks_exact(3)) {
                *zq = xq[c] as f32;
            }
        }
        let order = &self.order;
        pool.run(Task::Gather, z, |chunk| {
            for (s, w) in chunk.rows.clone().zip(chunk.w.chunks_exact(3)) {
                let id = order[s] as usize;
                let e = emission.at(id);
                let b = std::array::from_fn(|c| (f64::from(e[c]) - f64::from(w[c])) as f32);
                out.set(id, b);
            }
        })
    }

    /// The memory-read roofline of a frame of this baseline: reads every byte of `V_k` and
    /// `Y_k` with the same threads and chunks (as [`Evaluator::read_pass`](crate::Evaluator::read_pass)
    /// does for the factored frame) and returns a wrapping sum of the stored words.
    pub fn read_pass(&mut self) -> Result<u64, RuntimeError> {
        self.pool.read_sum(&self.z)
    }
}

fn matrix_bytes(m: &StoredMatrix) -> usize {
    match m {
        StoredMatrix::F32(v) => 4 * v.len(),
        StoredMatrix::F16(v) => 2 * v.len(),
    }
}

/// Rows `rows` of block `b` of `m` (`k` columns, `n` rows per block).
fn rows_of<'a>(m: &'a StoredMatrix, n: usize, k: usize, b: usize, rows: &Range<usize>) -> Rows<'a> {
    let (start, end) = ((b * n + rows.start) * k, (b * n + rows.end) * k);
    match m {
        StoredMatrix::F32(v) => Rows::F32(&v[start..end]),
        StoredMatrix::F16(v) => Rows::F16(&v[start..end]),
    }
}

impl Work for DenseWork {
    fn run(&self, task: Task, chunk: &mut Chunk, z: &[f32]) {
        let (n, k, kp) = (self.n, self.k, self.kp);
        let rows = chunk.rows.clone();
        match task {
            Task::Partial => {
                // The chunk's `V_kᵀ E`: f32 sums over FLUSH_ROWS rows, added in f64.
                let e = self.e.read().unwrap_or_else(PoisonError::into_inner);
                chunk.partial.fill(0.0);
                for start in rows.clone().step_by(FLUSH_ROWS) {
                    let part = start..(start + FLUSH_ROWS).min(rows.end);
                    chunk.scratch.fill(0.0);
                    let m = rows_of(&self.v, n, k, 0, &part);
                    let es = &e[3 * part.start..3 * part.end];
                    kernel::transposed(self.simd, m, k, es, &mut chunk.scratch, kp);
                    for (q, p) in chunk.partial.chunks_exact_mut(3).enumerate() {
                        for c in 0..3 {
                            p[c] += f64::from(chunk.scratch[c * kp + q]);
                        }
                    }
                }
            }
            Task::Gather if self.blocks == 1 => {
                let g = Gather {
                    m: rows_of(&self.y, n, k, 0, &rows),
                    k,
                    z,
                    kp,
                    offset: 0,
                };
                kernel::gather::<3>(self.simd, &g, &mut chunk.w);
            }
            Task::Gather => {
                for c in 0..3 {
                    let g = Gather {
                        m: rows_of(&self.y, n, k, c, &rows),
                        k,
                        z: &z[c * kp..],
                        kp,
                        offset: c,
                    };
                    kernel::gather::<1>(self.simd, &g, &mut chunk.w);
                }
            }
            Task::Read => {
                let blocks = (0..self.blocks).map(|b| rows_of(&self.y, n, k, b, &rows));
                chunk.sum = std::iter::once(rows_of(&self.v, n, k, 0, &rows))
                    .chain(blocks)
                    .map(|m| kernel::read_sum(self.simd, m))
                    .fold(0, u64::wrapping_add);
            }
        }
    }
}
