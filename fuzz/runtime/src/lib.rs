//! Support for the runtime's fuzz targets in `fuzz_targets/`: the shared bodies ([`operators`],
//! [`kernels`], [`trace`], [`capi`], also replayed by the end-to-end tests) and an allocation meter for the loader's
//! size limits.

pub mod alloc;
pub mod capi;
pub mod kernels;
pub mod operators;
#[path = "../../reader.rs"]
pub mod reader;
pub mod trace;
