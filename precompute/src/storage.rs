//! How the operator file is stored (`--precision`, `--layout`) and what writing it costs in
//! memory: planned with the bake's other stages, before the form factors, so that a file too
//! large to write is refused before hours of baking ([`check_memory`]); with `--refine`, its
//! lower bound before the first pass too ([`check_memory_unrefined`]).

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

/// The working memory of [`write`](crate::write::write), for `n` elements, `k` patches and
/// `channels` cores stored as `storage`, with `groups` light groups (the emitting surfaces) and
/// `display`:
/// - the matrices: the bake's f64 `F_k` while it is converted (with the first sixteenth of the
///   f32 `F_k`, made before any f64 is released: `write::into_f32`), or what the write makes
///   when that is more: `F_k` in f32, in f16 when stored so, and the plain layout's `Y_k`
///   (`channels` blocks of n·k f32, and their f16 copy), none of it counted as released;
/// - per element, [`WRITE_BYTES_PER_ELEMENT`]; the file's copy of the cores (`channels` k×k
///   f64); the light groups (each 3k f64 and its name);
/// - the largest section but the matrix, encoded as it is written
///   ([`OperatorFile::write`](lrr_formats::OperatorFile::write)).
pub fn write_bytes(
    dims: (usize, usize, usize),
    storage: Storage,
    groups: usize,
    display: &Display,
) -> u128 {
    write_bytes_with(
        dims,
        storage,
        groups,
        display.largest_payload_bytes() as u128,
    )
}

/// [`write_bytes`] with the largest display section's length given.
fn write_bytes_with(
    (n, k, channels): (usize, usize, usize),
    storage: Storage,
    groups: usize,
    largest_display: u128,
) -> u128 {
    let (n, k, c, g) = (n as u128, k as u128, channels as u128, groups as u128);
    let nk = n * k;
    let per_value = match (storage.layout, storage.precision) {
        (Layout::Factored, Precision::F32) => 4,
        (Layout::Factored, Precision::F16) => 4 + 2,
        (Layout::PlainYk, Precision::F32) => 4 + 4 * c,
        (Layout::PlainYk, Precision::F16) => 4 + 2 + 6 * c,
    };
    let converting = 8 * nk + 4 * (nk / 16).max(1 << 16);
    let matrices = converting.max(per_value * nk);
    let cores = 8 * c * k * k;
    // A light group: 3k f64 (its value on the patches per channel) and its name (256 bytes
    // allowed); its members' positions and emission are in the per-element figure.
    let group = 24 * k + 256;
    // The largest section: a display section, the geometry (4 corners and a normal in f32 and
    // a count byte, padded), the cores, or the light groups (each also 16 bytes of header,
    // each emitter's position and emission).
    let sections = [
        largest_display,
        n.next_multiple_of(4) + 60 * n,
        cores,
        8 + g * (16 + group) + 16 * n,
    ]
    .into_iter()
    .max()
    .unwrap_or(0);
    matrices + WRITE_BYTES_PER_ELEMENT * n + cores + g * group + sections
}

/// Refuses a bake whose [`write`](crate::write::write) ([`write_bytes`]) would exceed `max_memory`,
/// before its form factors are computed, and reports the estimate to `progress` (stage "write").
pub(crate) fn check_memory(
    dims: (usize, usize, usize),
    storage: Storage,
    groups: usize,
    display: &Display,
    (progress, max_memory): (&crate::progress::Progress, Option<u64>),
) -> Result<()> {
    let bytes = write_bytes(dims, storage, groups, display);
    refuse(bytes, dims, storage, "", max_memory)?;
    progress.estimate("write", bytes);
    Ok(())
}

/// Refuses, before `--refine`'s first pass, a bake whose write cannot fit whatever the
/// refinement does: it keeps the patches and only adds elements (`refine`), so the write of the
/// unrefined mesh's `n0` elements, without light groups and display sections, is at most the
/// final plan [`check_memory`] makes once the mesh is refined. `dims`: `(n0, k, channels)`.
pub(crate) fn check_memory_unrefined(
    dims: (usize, usize, usize),
    storage: Storage,
    max_memory: Option<u64>,
) -> Result<()> {
    let bytes = write_bytes_with(dims, storage, 0, 0);
    refuse(bytes, dims, storage, " before refinement", max_memory)
}

/// The refusal of a write planned at `bytes`; `more` follows the element count.
fn refuse(
    bytes: u128,
    (n, k, _): (usize, usize, usize),
    storage: Storage,
    more: &str,
    max_memory: Option<u64>,
) -> Result<()> {
    let (what, advice) = match storage.layout {
        Layout::Factored => (
            format!("writing the operator file (n = {n} elements{more}, k = {k} patches)"),
            "use a larger --element-size or --patch-size, or raise --max-memory",
        ),
        Layout::PlainYk => (
            format!(
                "writing the operator file in the plain layout (n = {n} elements{more}, \
                 k = {k} patches)"
            ),
            "use the factored layout (the default, without --layout plain), a larger \
             --element-size or --patch-size, or raise --max-memory",
        ),
    };
    crate::memory::check_with(bytes, max_memory, &what, advice)
}
