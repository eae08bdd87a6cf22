//! Refusing jobs that would not fit in memory, before allocating.

use crate::error::{Error, Result};

/// Bytes of memory available to this process: `MemAvailable` from /proc/meminfo, or 16 GiB
/// where that cannot be read. `LRR_MEMORY_LIMIT` (bytes) overrides it (for tests and for
/// sharing a machine).
pub(crate) fn available() -> u128 {
    if let Some(v) = std::env::var("LRR_MEMORY_LIMIT")
        .ok()
        .and_then(|v| v.parse::<u128>().ok())
    {
        return v;
    }
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("MemAvailable:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<u128>().ok())
                .map(|kb| kb * 1024)
        })
        .unwrap_or(16 << 30)
}

/// Refuses `bytes` of working memory for `what` when they exceed `limit` bytes
/// (`--max-memory`) or, without one, 80% of what is available.
pub(crate) fn check_with(bytes: u128, limit: Option<u64>, what: &str, fix: &str) -> Result<()> {
    check_then(bytes, limit, || what.to_string(), |_| fix.to_string())
}

/// [`check_with`] for a refusal whose words cost work to build: `what` and `fix` run only
/// when the job is refused, `fix` with the bytes that can be used.
pub(crate) fn check_then(
    bytes: u128,
    limit: Option<u64>,
    what: impl FnOnce() -> String,
    fix: impl FnOnce(u128) -> String,
) -> Result<()> {
    let whence = whence(limit);
    let limit = usable(limit);
    if bytes > limit {
        return Err(Error::Limits(format!(
            "{} needs about {} but only {} can be used{whence}; {}",
            what(),
            size(bytes),
            size(limit),
            fix(limit)
        )));
    }
    Ok(())
}

/// What to change when the elements or the patches are too many for the memory (`n · k`, the
/// probes): a larger element size lowers n on every surface (small faces are grouped into
/// elements of about the element size, `mesh::dense`); a larger patch size or threshold
/// lowers k and the probes.
pub(crate) fn size_advice() -> String {
    "use a larger --element-size or --patch-size".to_string()
}

/// Where the limit of a refusal comes from, after its figure: nothing when `--max-memory` gave
/// it; without it the bound is the machine's, and some commands (`lrr scene`, `accuracy`, the
/// benches) have no flag, so say where it comes from and what moves it.
pub(crate) fn whence(limit: Option<u64>) -> &'static str {
    match limit {
        Some(_) => "",
        None => {
            " (80% of the memory available; the environment variable LRR_MEMORY_LIMIT, in \
             bytes, sets what is available)"
        }
    }
}

/// The bytes a job may use: `limit` (`--max-memory`), or 80% of what is available.
pub(crate) fn usable(limit: Option<u64>) -> u128 {
    limit.map_or_else(|| available() * 8 / 10, u128::from)
}

/// Bytes in GiB, or MiB below 1 GiB (so small limits do not all read "0.01 GiB").
pub(crate) fn size(bytes: u128) -> String {
    if bytes >= 1 << 30 {
        format!("{:.2} GiB", bytes as f64 / (1u64 << 30) as f64)
    } else {
        format!("{:.1} MiB", bytes as f64 / (1u64 << 20) as f64)
    }
}
