//! How the operator file is stored (`--precision`, `--layout`) and what writing it costs in
//! memory: planned with the bake's other stages, before the form factors, so that a file too
//! large to write is refused before hours of baking ([`check_memory`]).

use lrr_formats::{Display, Layout, Precision};

use crate::error::Result;

/// How the operator is stored in the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Storage {
    /// Number format of the stored matrix (f32 or f16).
    pub precision: Precision,
    /// Factored (`F_k` + cores) or the plain per-channel `Y_k`.
    pub layout: Layout,
}

impl Default for Storage {
    fn default() -> Self {
        Self {
            precision: Precision::F32,
            layout: Layout::Factored,
        }
    }
}

/// Bytes [`write`](crate::write::write) holds per element beyond the bake's own: the skeleton's
/// copies (order, weights, materials, surfaces and geometry, about 133), the file's f32 weights and
/// materials (28), the light groups' members (16) and the metadata's surface ranges (up to about
/// 24).
pub const WRITE_BYTES_PER_ELEMENT: u128 = 256;

/// Below this size a block freed by the allocator may stay resident (glibc's largest dynamic mmap
/// threshold on 64-bit systems, 32 MiB): the f64 `F_k` released by [`write`](crate::write::write)
/// lowers the resident memory only when it is at least this large.
const RELEASED_FROM: u128 = 32 << 20;

/// The working memory of [`write`](crate::write::write) over what the bake holds when it starts
/// (its f64 `F_k` included), for `n` elements, `k` patches and `channels` cores stored as
/// `storage`, with `surfaces` named surfaces and `display`:
/// - per element, [`WRITE_BYTES_PER_ELEMENT`];
/// - the matrices it makes: `F_k` in f32, in f16 when stored so, and the plain layout's `Y_k`
///   (`channels` blocks of n·k f32, and their f16 copy). When the f64 `F_k` it releases is large
///   enough to leave the process ([`RELEASED_FROM`]), less that, but at least the first sixteenth
///   of the f32 `F_k`, made before any f64 is released (`write::into_f32`);
/// - the largest section but the matrix, encoded as it is written
///   ([`OperatorFile::write`](lrr_formats::OperatorFile::write)).
pub fn write_bytes(
    (n, k, channels): (usize, usize, usize),
    storage: Storage,
    surfaces: usize,
    display: &Display,
) -> u128 {
    let (n, k, c) = (n as u128, k as u128, channels as u128);
    let nk = n * k;
    let per_value = match (storage.layout, storage.precision) {
        (Layout::Factored, Precision::F32) => 4,
        (Layout::Factored, Precision::F16) => 4 + 2,
        (Layout::PlainYk, Precision::F32) => 4 + 4 * c,
        (Layout::PlainYk, Precision::F16) => 4 + 2 + 6 * c,
    };
    let matrices = match 8 * nk >= RELEASED_FROM {
        true => (per_value * nk)
            .saturating_sub(8 * nk)
            .max(4 * (nk / 16).max(1 << 16)),
        false => per_value * nk,
    };
    // The largest section: a display section, the geometry (4 corners and a normal in f32 and
    // a count byte, padded), the cores (f64), or the light groups (each its k values in f64
    // and name, each emitter's position and emission).
    let sections = [
        display.largest_payload_bytes() as u128,
        n.next_multiple_of(4) + 60 * n,
        8 * c * k * k,
        8 + surfaces as u128 * (24 + 8 * k + 256) + 16 * n,
    ]
    .into_iter()
    .max()
    .unwrap_or(0);
    WRITE_BYTES_PER_ELEMENT * n + matrices + sections
}

/// Refuses a bake whose [`write`](crate::write::write) ([`write_bytes`]) would exceed `max_memory`,
/// before its form factors are computed, and reports the estimate to `progress` (stage "write").
pub(crate) fn check_memory(
    dims: (usize, usize, usize),
    storage: Storage,
    surfaces: usize,
    display: &Display,
    (progress, max_memory): (&crate::progress::Progress, Option<u64>),
) -> Result<()> {
    let bytes = write_bytes(dims, storage, surfaces, display);
    let (n, k, _) = dims;
    let (what, advice) = match storage.layout {
        Layout::Factored => (
            format!("writing the operator file (n = {n} elements, k = {k} patches)"),
            "use a larger --element-size or --patch-size, or raise --max-memory",
        ),
        Layout::PlainYk => (
            format!(
                "writing the operator file in the plain layout (n = {n} elements, k = {k} patches)"
            ),
            "use the factored layout (the default, without --layout plain), a larger \
             --element-size or --patch-size, or raise --max-memory",
        ),
    };
    crate::memory::check_with(bytes, max_memory, &what, advice)?;
    progress.estimate("write", bytes);
    Ok(())
}
