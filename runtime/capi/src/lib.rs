//! # lrr-capi: the lrr runtime for C
//!
//! `liblrr_capi.a` and `liblrr_capi.so` with the hand-written header `include/lrr.h`: load an
//! operator file, relight it for any emission, find the element under a surface point.
//!
//! ```c
//! #include "lrr.h"
//!
//! lrr_operator *op = NULL;
//! if (lrr_load("cornell.lrr", &op) != LRR_OK) {
//!     fprintf(stderr, "%s\n", lrr_last_error());
//!     return 1;
//! }
//! size_t n = lrr_element_count(op);
//! float *emission = malloc(3 * n * sizeof(float)), *radiosity = malloc(3 * n * sizeof(float));
//! lrr_baked_emission(op, emission, 3 * n);
//! lrr_evaluate(op, emission, 3 * n, radiosity, 3 * n);   /* every frame */
//! lrr_free(op);
//! ```
//!
//! The libraries hold the runtime's default build: load, evaluate and the direct pass of lights
//! that are not surfaces (`lrr_direct_*`), no ray tracer (the runtime's feature `trace` stays
//! off; `tests/tests/e2e/capi.rs` checks the static library for it).
//!
//! `examples/relight.c` is a complete program; `tests/tests/e2e/capi.rs` compiles and runs it
//! against both libraries. Link the static library with `-lpthread -ldl -lm` (what the Rust
//! standard library needs; `cargo rustc -p lrr-capi --crate-type staticlib -- --print
//! native-static-libs` lists it for other targets).
//!
//! ## Rules at the boundary
//! - Every function returns `LRR_OK` (0) or a negative `LRR_ERROR_*` code, except
//!   [`lrr_element_count`] (0 on error), [`lrr_free`] and [`lrr_last_error`]. A failed call
//!   leaves its message in a thread-local slot that [`lrr_last_error`] returns.
//! - Null pointers, wrong lengths, misaligned or overlapping buffers and non-UTF-8 paths are
//!   errors. A panic (a bug) is caught and becomes `LRR_ERROR_PANIC`; nothing unwinds into C.
//! - The caller owns every buffer; the library owns the operator (freed by [`lrr_free`]) and the
//!   error string.
//! - A loaded operator is immutable: several threads may evaluate it at once, each with its own
//!   output buffer.
//!
//! The header is written by hand; `tests/header.rs` checks that it declares exactly the
//! functions and codes defined here, with the same parameter types.

#![warn(missing_docs)]
// Every unsafe block states why it is sound.
#![deny(clippy::undocumented_unsafe_blocks)]

mod args;
mod lightmap;
mod lights;
mod status;

use std::ffi::c_char;
use std::path::Path;

use lrr_runtime::Operator;

pub use lightmap::{
    LrrLightmap, lrr_lightmap_fill, lrr_lightmap_free, lrr_lightmap_new, lrr_lightmap_size,
};
pub use lights::{
    LRR_LIGHT_FLOATS, LrrDirect, lrr_direct_at, lrr_direct_emission, lrr_direct_free,
    lrr_direct_new,
};
use status::{Error, guard, status};
pub use status::{
    LRR_ERROR_BUFFER, LRR_ERROR_FORMAT, LRR_ERROR_INPUT, LRR_ERROR_IO, LRR_ERROR_LENGTH,
    LRR_ERROR_NULL, LRR_ERROR_PANIC, LRR_ERROR_UTF8, LRR_OK,
};

/// The opaque handle behind C's `lrr_operator *`: a loaded operator.
#[derive(Debug)]
pub struct LrrOperator {
    op: Operator,
}

/// Loads and validates the operator file at `path` (NUL-terminated UTF-8) into `*out_op`.
///
/// # Safety
/// `path` is null or a NUL-terminated string; `out_op` is null or points to a writable
/// `lrr_operator *`. On success `*out_op` owns a handle to free with [`lrr_free`]; on failure
/// it is set to null (when `out_op` is not null).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lrr_load(path: *const c_char, out_op: *mut *mut LrrOperator) -> i32 {
    status(|| {
        // SAFETY: forwarded from this function's contract.
        let slot = unsafe { args::handle_slot(out_op)? };
        // SAFETY: forwarded from this function's contract.
        let path = unsafe { args::path(path)? };
        let op = Operator::load(Path::new(path))?;
        *slot = Box::into_raw(Box::new(LrrOperator { op }));
        Ok(())
    })
}

/// Parses an operator file held in memory (`len` bytes at `bytes`) into `*out_op`. The bytes are
/// copied: the caller may free them as soon as this returns.
///
/// # Safety
/// `bytes` is null (only with `len == 0`) or points to `len` readable bytes; `out_op` as in
/// [`lrr_load`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lrr_load_bytes(
    bytes: *const u8,
    len: usize,
    out_op: *mut *mut LrrOperator,
) -> i32 {
    status(|| {
        // SAFETY: forwarded from this function's contract.
        let slot = unsafe { args::handle_slot(out_op)? };
        // SAFETY: forwarded from this function's contract.
        let bytes = unsafe { args::bytes(bytes, len)? };
        let op = Operator::from_bytes(bytes)?;
        *slot = Box::into_raw(Box::new(LrrOperator { op }));
        Ok(())
    })
}

/// The number of elements `n` (at least 1); buffers hold `3 * n` floats. 0 when `op` is null.
///
/// # Safety
/// `op` is null or a live handle from [`lrr_load`] / [`lrr_load_bytes`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lrr_element_count(op: *const LrrOperator) -> usize {
    // SAFETY: forwarded from this function's contract.
    guard(0, || Ok(unsafe { args::operator(op)? }.op.n()))
}

/// Radiosity for an emission: `emission` and `radiosity` are interleaved RGB, `3 * n` floats
/// each, by element id. `radiosity` is written only on success.
///
/// # Safety
/// `op` as in [`lrr_element_count`]; `emission` is null or points to `emission_len` readable
/// floats; `radiosity` is null or points to `radiosity_len` writable floats that nothing else
/// accesses during the call.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lrr_evaluate(
    op: *const LrrOperator,
    emission: *const f32,
    emission_len: usize,
    radiosity: *mut f32,
    radiosity_len: usize,
) -> i32 {
    status(|| {
        // SAFETY: forwarded from this function's contract.
        let op = &unsafe { args::operator(op)? }.op;
        let n = op.n();
        // SAFETY: forwarded from this function's contract.
        let e = unsafe { args::rgb(emission, emission_len, n, "emission")? };
        args::check_rgb(radiosity, radiosity_len, n, "radiosity")?;
        if args::overlap(emission, radiosity, 3 * n) {
            return Err(Error::new(
                LRR_ERROR_BUFFER,
                "the emission and radiosity buffers overlap; pass two separate buffers",
            ));
        }
        // SAFETY: forwarded from this function's contract; checked above that it does not
        // overlap the emission slice.
        let b = unsafe { args::rgb_mut(radiosity, radiosity_len, n, "radiosity")? };
        op.evaluate(e, b)?;
        Ok(())
    })
}

/// Copies the emission the scene was baked with (interleaved RGB, `3 * n` floats, by element
/// id) into `out`.
///
/// # Safety
/// `op` as in [`lrr_element_count`]; `out` is null or points to `out_len` writable floats.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lrr_baked_emission(
    op: *const LrrOperator,
    out: *mut f32,
    out_len: usize,
) -> i32 {
    status(|| {
        // SAFETY: forwarded from this function's contract.
        let op = &unsafe { args::operator(op)? }.op;
        // SAFETY: forwarded from this function's contract.
        let out = unsafe { args::rgb_mut(out, out_len, op.n(), "emission")? };
        out.copy_from_slice(&op.baked_emission());
        Ok(())
    })
}

/// The id of the element whose surface holds `position` (3 floats): the nearest element whose
/// normal agrees with `normal` (3 floats; dot > 0), or the nearest of all when none agrees.
/// Linear in n: for probes, not per frame.
///
/// # Safety
/// `op` as in [`lrr_element_count`]; `position` and `normal` are null or point to 3 readable
/// floats; `out_element` is null or points to a writable `uint32_t`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lrr_locate(
    op: *const LrrOperator,
    position: *const f32,
    normal: *const f32,
    out_element: *mut u32,
) -> i32 {
    status(|| {
        // SAFETY: forwarded from this function's contract.
        let op = &unsafe { args::operator(op)? }.op;
        // SAFETY: forwarded from this function's contract.
        let position = unsafe { args::vec3(position, "position")? };
        // SAFETY: forwarded from this function's contract.
        let normal = unsafe { args::vec3(normal, "normal")? };
        // SAFETY: forwarded from this function's contract.
        let out = unsafe { args::out(out_element, "out_element")? };
        // An operator has at least one element, so `locate` always finds one.
        *out = op.locate(position, normal).ok_or_else(|| {
            Error::new(LRR_ERROR_INPUT, "no element found (the operator is empty)")
        })?;
        Ok(())
    })
}

/// Frees an operator. Null is allowed (nothing happens).
///
/// # Safety
/// `op` is null or a handle from [`lrr_load`] / [`lrr_load_bytes`] not freed before; it must
/// not be used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lrr_free(op: *mut LrrOperator) {
    if op.is_null() {
        return;
    }
    guard((), || {
        // SAFETY: the caller promises `op` came from Box::into_raw in lrr_load* and that this is
        // its only release.
        drop(unsafe { Box::from_raw(op) });
        Ok(())
    })
}

/// The message of the last call that failed on the calling thread, as NUL-terminated UTF-8;
/// `""` when none has. Owned by the library: do not free it. It stays valid until the next
/// failing `lrr_` call on the same thread (copy it to keep it longer).
#[unsafe(no_mangle)]
pub extern "C" fn lrr_last_error() -> *const c_char {
    status::last_error()
}
