//! End-to-end tests across the crates: scene files in, `lrr` commands (run in-process through
//! `lrr_precompute::cli::run`), operator files, the runtime.

mod analytic;
mod cornell;
mod files;
mod furnace;
mod import;
mod resilience;
mod util;
