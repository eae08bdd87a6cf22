//! The persistent worker threads of an [`Evaluator`](crate::Evaluator).
//!
//! The rows of the stored matrix are cut into chunks (a few per thread), each with its own `W`
//! buffer, allocated once. A frame puts every chunk into a shared queue, wakes the workers (each
//! gets a copy of `z` in its [`Job`]) and takes chunks itself: whoever is free takes the next
//! one, so a thread the OS preempts (or the caller, busy with `B` of finished chunks) does not
//! hold the frame up. Chunks and jobs travel through bounded channels whose slots are allocated
//! up front; moving a `Vec` moves three words, so a frame allocates nothing.
//!
//! Why workers write into chunk buffers and not into the caller's output: without `unsafe`, a
//! thread that outlives the call cannot hold the caller's borrowed slice. The caller reads `W`
//! back in the O(n) step it runs anyway (`B` per original id), chunk by chunk as they come back,
//! while the others still gather: that is `1/k` of the bytes the gather reads.

use std::ops::Range;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::Duration;

use lrr_formats::OperatorFile;

use crate::error::RuntimeError;
use crate::kernel::SimdLevel;
use crate::pass;

/// What a frame computes per chunk.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Task {
    /// `W` of the chunk's rows from `z`.
    Gather,
    /// The read roofline of the chunk's rows, into `sum`.
    Read,
    /// A partial product over the chunk's rows into `partial` (the dense-`V` baseline's
    /// `Vᵀ E`; an operator file has no such task).
    #[cfg_attr(not(feature = "testkit"), allow(dead_code))]
    Partial,
}

/// What the threads compute: the stored matrix of an operator file ([`FileWork`]) or, for the
/// benchmarks' baseline, another matrix with the same chunks and threads.
pub(crate) trait Work: Send + Sync {
    /// Runs `task` over `chunk.rows`, into the chunk's buffers; `z` is this frame's input.
    fn run(&self, task: Task, chunk: &mut Chunk, z: &[f32]);
}

/// The frame's work: the pass over an operator file's stored matrix.
pub(crate) struct FileWork {
    pub file: Arc<OperatorFile>,
    pub kp: usize,
    pub simd: SimdLevel,
}

impl Work for FileWork {
    fn run(&self, task: Task, chunk: &mut Chunk, z: &[f32]) {
        let rows = chunk.rows.clone();
        match task {
            Task::Gather => {
                pass::gather_rows(&self.file, rows, z, self.kp, &mut chunk.w, self.simd)
            }
            Task::Read => chunk.sum = pass::read_rows(&self.file, rows, self.simd),
            Task::Partial => {}
        }
    }
}

/// A block of rows and its `W`.
#[derive(Debug)]
pub(crate) struct Chunk {
    pub index: usize,
    pub rows: Range<usize>,
    /// `3 * rows.len()`: `W` of the rows.
    pub w: Vec<f32>,
    pub sum: u64,
    /// [`Task::Partial`]'s output and scratch, as long as [`Pool::start`] was asked for (empty
    /// for an operator file's frames).
    pub partial: Vec<f64>,
    pub scratch: Vec<f32>,
    /// Set when the computation panicked (a bug): the frame fails instead of hanging.
    failed: bool,
}

impl Chunk {
    /// [`Work::run`], recording a panic instead of unwinding.
    fn run_caught(&mut self, task: Task, work: &dyn Work, z: &[f32]) {
        let run = AssertUnwindSafe(|| work.run(task, self, z));
        self.failed = catch_unwind(run).is_err();
    }
}

/// What wakes a worker for a frame: the task and its copy of `z` (`3 * kp`).
#[derive(Debug)]
struct Job {
    task: Task,
    z: Vec<f32>,
}

/// What comes back to the caller.
enum Done {
    Ready,
    Chunk(Chunk),
    Job(usize, Job),
}

/// One worker: its channel, its job while it is home, its thread.
struct Worker {
    to: Option<SyncSender<Job>>,
    job: Option<Job>,
    thread: Option<JoinHandle<()>>,
}

/// The chunks and the threads that share them.
pub(crate) struct Pool {
    /// Every chunk, home between frames (`None` while out).
    chunks: Vec<Option<Chunk>>,
    queue_tx: SyncSender<Chunk>,
    queue: Arc<Mutex<Receiver<Chunk>>>,
    workers: Vec<Worker>,
    done: Receiver<Done>,
    work: Arc<dyn Work>,
    /// Length of `z`.
    z_len: usize,
}

impl Pool {
    /// Cuts the rows at `bounds` into chunks and starts `workers` threads, waiting until each
    /// is ready. `z_len`: the length of a frame's `z`; `partial`: the lengths of each chunk's
    /// [`Task::Partial`] buffers (f64 output, f32 scratch), `(0, 0)` when unused.
    ///
    /// std's channels allocate a thread's wait state the first time it blocks. So every worker
    /// blocks once (1 ms, on its empty job channel) before it reports ready, and the caller
    /// blocks on the ready reports: after this, no frame allocates.
    pub(crate) fn start(
        work: Arc<dyn Work>,
        bounds: &[usize],
        workers: usize,
        z_len: usize,
        partial: (usize, usize),
    ) -> Result<Self, RuntimeError> {
        let chunks: Vec<Option<Chunk>> = bounds
            .windows(2)
            .enumerate()
            .map(|(index, b)| {
                Some(Chunk {
                    index,
                    rows: b[0]..b[1],
                    w: vec![0.0; 3 * (b[1] - b[0])],
                    sum: 0,
                    partial: vec![0.0; partial.0],
                    scratch: vec![0.0; partial.1],
                    failed: false,
                })
            })
            .collect();
        let (queue_tx, queue) = sync_channel(chunks.len());
        let queue = Arc::new(Mutex::new(queue));
        let (done_tx, done) = sync_channel(chunks.len() + 2 * workers + 1);
        let mut pool = Pool {
            chunks,
            queue_tx,
            queue,
            workers: Vec::with_capacity(workers),
            done,
            work,
            z_len,
        };
        for i in 0..workers {
            let worker = pool.spawn(i, done_tx.clone())?;
            pool.workers.push(worker);
        }
        for _ in 0..workers {
            pool.done.recv().map_err(|_| lost())?;
        }
        Ok(pool)
    }

    fn spawn(&self, i: usize, done: SyncSender<Done>) -> Result<Worker, RuntimeError> {
        let (to, from) = sync_channel::<Job>(1);
        let (work, queue) = (Arc::clone(&self.work), Arc::clone(&self.queue));
        let thread = std::thread::Builder::new()
            .name(format!("lrr-eval-{i}"))
            .spawn(move || {
                // Nothing is sent before every worker is ready: this times out.
                let _ = from.recv_timeout(Duration::from_millis(1));
                if done.send(Done::Ready).is_err() {
                    return;
                }
                while let Ok(job) = from.recv() {
                    while let Some(mut chunk) = take(&queue) {
                        chunk.run_caught(job.task, &*work, &job.z);
                        if done.send(Done::Chunk(chunk)).is_err() {
                            return;
                        }
                    }
                    if done.send(Done::Job(i, job)).is_err() {
                        return;
                    }
                }
            })
            .map_err(|e| {
                RuntimeError::Input(format!(
                    "cannot start evaluator thread {i}: {e} (ask for fewer threads)"
                ))
            })?;
        Ok(Worker {
            to: Some(to),
            job: Some(Job {
                task: Task::Gather,
                z: vec![0.0; self.z_len],
            }),
            thread: Some(thread),
        })
    }

    /// Threads in all, the caller's included.
    pub(crate) fn threads(&self) -> usize {
        self.workers.len() + 1
    }

    /// Bytes of the buffers.
    pub(crate) fn bytes(&self) -> usize {
        let chunk = |c: &Chunk| 4 * (c.w.len() + c.scratch.len()) + 8 * c.partial.len();
        let chunks: usize = self.chunks.iter().flatten().map(chunk).sum();
        chunks + 4 * self.workers.len() * self.z_len
    }

    /// [`Task::Read`] over every chunk: the wrapping sum of the words each chunk read (the
    /// read rooflines of the evaluator and of the dense baseline).
    pub(crate) fn read_sum(&mut self, z: &[f32]) -> Result<u64, RuntimeError> {
        let mut sum = 0u64;
        self.run(Task::Read, z, |chunk| sum = sum.wrapping_add(chunk.sum))?;
        Ok(sum)
    }

    /// Runs `task` over every chunk with every thread; `z` is the caller's copy. `finished`
    /// sees each chunk once, on the caller's thread, as soon as it is done (in any order).
    pub(crate) fn run(
        &mut self,
        task: Task,
        z: &[f32],
        mut finished: impl FnMut(&Chunk),
    ) -> Result<(), RuntimeError> {
        for chunk in self.chunks.iter_mut() {
            let chunk = chunk.take().ok_or_else(lost)?;
            self.queue_tx.send(chunk).map_err(|_| lost())?;
        }
        for worker in &mut self.workers {
            let mut job = worker.job.take().ok_or_else(lost)?;
            job.task = task;
            job.z.copy_from_slice(z);
            worker
                .to
                .as_ref()
                .ok_or_else(lost)?
                .send(job)
                .map_err(|_| lost())?;
        }
        let (mut chunks_out, mut jobs_out) = (self.chunks.len(), self.workers.len());
        let mut failed = false;
        while let Some(mut chunk) = take(&self.queue) {
            chunk.run_caught(task, &*self.work, z);
            failed |= self.home(chunk, &mut finished);
            chunks_out -= 1;
            // B of the chunks the workers finished meanwhile.
            while let Ok(done) = self.done.try_recv() {
                failed |= self.receive(done, &mut chunks_out, &mut jobs_out, &mut finished);
            }
        }
        while chunks_out + jobs_out > 0 {
            let done = self.done.recv().map_err(|_| lost())?;
            failed |= self.receive(done, &mut chunks_out, &mut jobs_out, &mut finished);
        }
        if failed {
            return Err(RuntimeError::Input(
                "an evaluator thread failed (a bug in lrr-runtime: please report it)".into(),
            ));
        }
        Ok(())
    }

    /// Files what came back; whether it reports a failure.
    fn receive(
        &mut self,
        done: Done,
        chunks_out: &mut usize,
        jobs_out: &mut usize,
        finished: &mut impl FnMut(&Chunk),
    ) -> bool {
        match done {
            Done::Ready => false,
            Done::Chunk(chunk) => {
                *chunks_out -= 1;
                self.home(chunk, finished)
            }
            Done::Job(i, job) => {
                *jobs_out -= 1;
                if let Some(worker) = self.workers.get_mut(i) {
                    worker.job = Some(job);
                }
                false
            }
        }
    }

    /// Hands a computed chunk to `finished` and puts it back; whether it failed.
    fn home(&mut self, mut chunk: Chunk, finished: &mut impl FnMut(&Chunk)) -> bool {
        let failed = std::mem::take(&mut chunk.failed);
        if !failed {
            finished(&chunk);
        }
        let index = chunk.index;
        if let Some(slot) = self.chunks.get_mut(index) {
            *slot = Some(chunk);
        }
        failed
    }
}

/// The next chunk of the shared queue, if any is left.
fn take(queue: &Mutex<Receiver<Chunk>>) -> Option<Chunk> {
    let queue = queue.lock().unwrap_or_else(PoisonError::into_inner);
    queue.try_recv().ok()
}

fn lost() -> RuntimeError {
    RuntimeError::Input(
        "the evaluator lost a worker thread or a chunk (a previous frame failed): create a new \
         evaluator"
            .into(),
    )
}

impl Drop for Pool {
    fn drop(&mut self) {
        // Closing the job channels ends each worker's loop; then wait for the threads.
        for w in &mut self.workers {
            w.to = None;
        }
        for w in &mut self.workers {
            if let Some(thread) = w.thread.take() {
                let _ = thread.join();
            }
        }
    }
}
