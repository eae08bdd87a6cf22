//! The thread pool every parallel stage runs in.
//!
//! Rayon is given exactly `--threads` threads and faer runs sequentially inside it, so the
//! results never depend on how many threads there are (every parallel loop writes disjoint
//! outputs whose values depend only on their own index).

use crate::error::{Error, Result};

/// Runs `f` in a rayon pool of `threads` threads (all cores when `None`), with faer sequential.
pub fn with_threads<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> Result<T> {
    faer::set_global_parallelism(faer::Par::Seq);
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(t) = threads {
        if t == 0 {
            return Err(Error::Settings("--threads must be at least 1".into()));
        }
        builder = builder.num_threads(t);
    }
    let pool = builder
        .build()
        .map_err(|e| Error::Settings(format!("cannot start {threads:?} threads: {e}")))?;
    Ok(pool.install(f))
}
