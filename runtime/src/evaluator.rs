//! The per-frame evaluator: persistent threads, scratch sized once, no allocation per frame.

use std::num::NonZeroUsize;
use std::sync::Arc;

use crate::albedo;
use crate::error::RuntimeError;
use crate::frame::Frame;
use crate::kernel::{self, LANES, SimdLevel};
use crate::operator::Operator;
use crate::pool::{FileWork, Pool, Task};
use crate::rgb::{Rgb, RgbMut};

/// Evaluates frames of one operator with a pool of threads that lives as long as the evaluator.
///
/// Every buffer is allocated by [`new`](Self::new) ([`scratch_bytes`](Self::scratch_bytes) says
/// how much); a frame allocates nothing. The rows of the stored matrix are cut into chunks (about
/// eight per thread) that the threads take from a shared queue, the caller's thread included;
/// the caller also runs the O(n) steps (segment sums first, `B` per original id of each chunk
/// as it comes back).
///
/// The evaluator keeps its own copy of the albedo (cores and reflectance): edit it with
/// [`set_reflectance`](Self::set_reflectance). The file itself is shared, read-only.
pub struct Evaluator {
    /// The shared file and this evaluator's albedo.
    frame: Frame,
    simd: SimdLevel,
    kp: usize,
    x: Vec<[f64; 3]>,
    /// `3 * kp`: the planes of `z`, copied to every worker.
    z: Vec<f32>,
    pool: Pool,
}

impl std::fmt::Debug for Evaluator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Evaluator")
            .field("n", &self.frame.file.n)
            .field("k", &self.frame.file.k)
            .field("threads", &self.threads())
            .field("simd", &self.simd)
            .finish()
    }
}

impl Evaluator {
    /// An evaluator of `op` with `threads` threads in all, the caller's included (0 = one per
    /// available core; more threads than elements are not started). The kernel implementation
    /// is the fastest this CPU supports ([`SimdLevel::detect`]).
    pub fn new(op: &Operator, threads: usize) -> Result<Self, RuntimeError> {
        Self::with_simd(op, threads, SimdLevel::detect())
    }

    /// [`new`](Self::new) with a chosen instruction set (e.g. [`SimdLevel::Scalar`] to compare);
    /// an unsupported one falls back to the scalar kernels.
    pub fn with_simd(op: &Operator, threads: usize, simd: SimdLevel) -> Result<Self, RuntimeError> {
        let file = Arc::clone(op.shared());
        let (n, k) = (file.n as usize, file.k as usize);
        let threads = match threads {
            0 => std::thread::available_parallelism().map_or(1, NonZeroUsize::get),
            t => t,
        }
        .clamp(1, n);
        let kp = kernel::padded(k);
        let bounds = chunk_bounds(n, threads);
        let work = FileWork {
            file: Arc::clone(&file),
            kp,
            simd,
        };
        let pool = Pool::start(Arc::new(work), &bounds, threads - 1, 3 * kp, (0, 0))?;
        Ok(Evaluator {
            frame: Frame::new(file, &bounds),
            simd,
            kp,
            x: vec![[0.0; 3]; k],
            z: vec![0.0; 3 * kp],
            pool,
        })
    }

    /// Threads in all, the caller's included.
    pub fn threads(&self) -> usize {
        self.pool.threads()
    }

    /// The instruction set the kernels of this evaluator run on.
    pub fn simd(&self) -> SimdLevel {
        self.simd
    }

    /// Bytes allocated by [`new`](Self::new) and reused by every frame: `W` (`3n` f32 over all
    /// chunks), `z` per thread, `X`, the permutation between ids and file order (16 bytes per
    /// run of consecutive ids, twice: cut by the chunks and whole) and the evaluator's copy of the albedo (`3n` f32 + the cores).
    pub fn scratch_bytes(&self) -> usize {
        self.pool.bytes() + 4 * self.z.len() + 24 * self.x.len() + self.frame.bytes()
    }

    /// Radiosity `out` for the per-element emission `emission` (both in original id order,
    /// interleaved or planar). Emission must be finite and non-negative; on an error nothing
    /// is written.
    pub fn evaluate(&mut self, emission: Rgb<'_>, mut out: RgbMut<'_>) -> Result<(), RuntimeError> {
        let n = self.frame.file.n as usize;
        emission.check(n, "emission")?;
        out.check(n, "output")?;
        self.frame.segment_sums(&emission, &mut self.x, self.simd)?;
        self.gather_and_finish(Some(&emission), &mut out)
    }

    /// Radiosity for light-group intensities `a_g` (one per
    /// [`Operator::light_groups`] entry, finite and non-negative): `E = Σ_g a_g E_g` and
    /// `Vᵀ E = Σ_g a_g x_g` from the stored groups, so no O(n) pass over an emission.
    pub fn evaluate_groups(
        &mut self,
        intensities: &[f32],
        mut out: RgbMut<'_>,
    ) -> Result<(), RuntimeError> {
        out.check(self.frame.file.n as usize, "output")?;
        self.frame.group_sums(intensities, &mut self.x)?;
        self.gather_and_finish(None, &mut out)?;
        self.frame.add_group_emission(intensities, &mut out);
        Ok(())
    }

    /// Changes the reflectance this evaluator uses (one RGB value per element, original ids, in
    /// [0, 1)) and rebuilds its cores: O(nk + k³), see [`Operator::set_reflectance`] for the
    /// errors. The operator and its other evaluators are not affected.
    pub fn set_reflectance(&mut self, rho: &[[f32; 3]]) -> Result<(), RuntimeError> {
        let edit = albedo::rebuild(&self.frame.file, rho)?;
        self.frame.set_albedo(edit, rho);
        Ok(())
    }

    /// The memory-read roofline of a frame: reads every byte of the stored matrix a frame
    /// reads, with the same threads and chunks, and returns a wrapping sum of the stored words
    /// (exact modulo 2³² for f32, 2¹⁶ for f16) so that no read can be optimised away. For
    /// benchmarks.
    pub fn read_pass(&mut self) -> Result<u64, RuntimeError> {
        self.pool.read_sum(&self.z)
    }

    /// Steps 2–4 of a frame once `X` is in `self.x`.
    fn gather_and_finish(
        &mut self,
        e: Option<&Rgb<'_>>,
        out: &mut RgbMut<'_>,
    ) -> Result<(), RuntimeError> {
        self.frame.core_product(&self.x, &mut self.z, self.kp);
        let frame = &self.frame;
        self.pool
            .run(Task::Gather, &self.z, |chunk| frame.finish(chunk, e, out))
    }
}

/// The evaluator and the one-call evaluations of an [`Operator`], defined here so that
/// `operator.rs` stays below this file.
impl Operator {
    /// A persistent evaluator with `threads` threads in all (the caller's included; 0 = one per
    /// available core). See [`Evaluator`].
    pub fn evaluator(&self, threads: usize) -> Result<Evaluator, RuntimeError> {
        Evaluator::new(self, threads)
    }

    /// Radiosity for the baked emission, per element in original id order.
    pub fn evaluate_baked(&self) -> Vec<[f32; 3]> {
        let e = self.baked_emission();
        let mut out = vec![[0.0; 3]; self.n()];
        self.evaluate(&e, &mut out)
            .expect("the baked emission is valid by construction");
        out
    }

    /// Radiosity for an RGB emission per element (original id order) into `out` (same order),
    /// on this thread. Emission must be finite and non-negative; on an error nothing is written.
    /// Allocates scratch per call: for frames, use an [`Evaluator`].
    pub fn evaluate(
        &self,
        emission: &[[f32; 3]],
        out: &mut [[f32; 3]],
    ) -> Result<(), RuntimeError> {
        self.evaluate_rgb(Rgb::triples(emission), RgbMut::triples(out))
    }

    /// [`evaluate`](Self::evaluate) with interleaved or planar buffers.
    pub fn evaluate_rgb(&self, emission: Rgb<'_>, out: RgbMut<'_>) -> Result<(), RuntimeError> {
        Evaluator::new(self, 1)?.evaluate(emission, out)
    }

    /// Radiosity for light-group intensities (one per [`light_groups`](Self::light_groups)
    /// entry), on this thread: `E = Σ_g a_g E_g`, `Vᵀ E = Σ_g a_g x_g` without an O(n) pass.
    pub fn evaluate_groups(
        &self,
        intensities: &[f32],
        out: RgbMut<'_>,
    ) -> Result<(), RuntimeError> {
        Evaluator::new(self, 1)?.evaluate_groups(intensities, out)
    }
}

/// Chunk bounds: about eight chunks per thread (so a thread the OS preempts delays the frame by
/// one chunk at most), at least 512 rows each, on multiples of 8 rows so the SIMD kernel rarely
/// takes its 1-row path; one chunk for one thread.
pub(crate) fn chunk_bounds(n: usize, threads: usize) -> Vec<usize> {
    let chunks = if threads == 1 {
        1
    } else {
        (8 * threads).min(n.div_ceil(512)).max(1)
    };
    let mut bounds: Vec<usize> = (0..=chunks)
        .map(|c| (n * c / chunks).next_multiple_of(LANES).min(n))
        .collect();
    bounds.dedup();
    bounds
}
