//! Turning C arguments (raw pointers and lengths) into Rust references, with every check that can
//! be made: null, alignment, length, overlap, UTF-8. What cannot be checked (that a non-null
//! pointer really points at `len` readable values, that a handle came from `lrr_load`) is the
//! caller's promise, stated in `include/lrr.h`.

use std::ffi::{CStr, c_char};

use crate::LrrOperator;
use crate::status::{Error, LRR_ERROR_BUFFER, LRR_ERROR_INPUT, LRR_ERROR_LENGTH, LRR_ERROR_UTF8};

/// The operator behind a handle.
///
/// # Safety
/// `op` is null or a handle from `lrr_load*` not yet freed; it stays valid for `'a`.
pub(crate) unsafe fn operator<'a>(op: *const LrrOperator) -> Result<&'a LrrOperator, Error> {
    if op.is_null() {
        return Err(Error::null("the operator handle"));
    }
    if !op.is_aligned() {
        return Err(Error::new(
            LRR_ERROR_BUFFER,
            "the operator handle is misaligned: it did not come from lrr_load",
        ));
    }
    // SAFETY: non-null and aligned; the caller promises it is a live handle from lrr_load*,
    // i.e. a pointer from Box::into_raw that lrr_free has not consumed.
    Ok(unsafe { &*op })
}

/// The out-parameter of a load, reset to null so that C never sees a stale handle on failure.
///
/// # Safety
/// `out` is null or points to writable memory for one pointer, valid for `'a`.
pub(crate) unsafe fn handle_slot<'a>(
    out: *mut *mut LrrOperator,
) -> Result<&'a mut *mut LrrOperator, Error> {
    if out.is_null() {
        return Err(Error::null("the out_op argument"));
    }
    if !out.is_aligned() {
        return Err(Error::new(
            LRR_ERROR_BUFFER,
            "the out_op argument is misaligned",
        ));
    }
    // SAFETY: non-null and aligned; the caller promises it points to a writable pointer.
    let slot = unsafe { &mut *out };
    *slot = std::ptr::null_mut();
    Ok(slot)
}

/// A NUL-terminated UTF-8 path.
///
/// # Safety
/// `path` is null or points to a NUL-terminated string that stays valid for `'a`.
pub(crate) unsafe fn path<'a>(path: *const c_char) -> Result<&'a str, Error> {
    if path.is_null() {
        return Err(Error::null("the path"));
    }
    // SAFETY: non-null; the caller promises a NUL-terminated string valid for 'a.
    let text = unsafe { CStr::from_ptr(path) };
    text.to_str().map_err(|e| {
        Error::new(
            LRR_ERROR_UTF8,
            format!(
                "the path {} is not valid UTF-8 ({e})",
                text.to_string_lossy()
            ),
        )
    })
}

/// `len` bytes at `bytes`; a null pointer is accepted for `len == 0`.
///
/// # Safety
/// `bytes` is null or points to `len` readable bytes that stay valid and unmodified for `'a`.
pub(crate) unsafe fn bytes<'a>(bytes: *const u8, len: usize) -> Result<&'a [u8], Error> {
    if len == 0 {
        return Ok(&[]);
    }
    if bytes.is_null() {
        return Err(Error::null("the bytes argument"));
    }
    if len > isize::MAX as usize {
        return Err(Error::new(
            LRR_ERROR_LENGTH,
            format!("a length of {len} bytes cannot be addressed"),
        ));
    }
    // SAFETY: non-null, u8 needs no alignment, len <= isize::MAX; the caller promises `len`
    // readable bytes that nobody writes to during the call.
    Ok(unsafe { std::slice::from_raw_parts(bytes, len) })
}

/// Checks an RGB buffer of `len` floats meant to hold `n` triples.
pub(crate) fn check_rgb(ptr: *const f32, len: usize, n: usize, name: &str) -> Result<(), Error> {
    if ptr.is_null() {
        return Err(Error::null(&format!("the {name} buffer")));
    }
    if Some(len) != n.checked_mul(3) {
        return Err(Error::new(
            LRR_ERROR_LENGTH,
            format!(
                "the {name} buffer holds {len} floats, but the operator needs 3 × {n} elements = \
                 {} (interleaved RGB)",
                n.saturating_mul(3)
            ),
        ));
    }
    if !ptr.is_aligned() {
        return Err(Error::new(
            LRR_ERROR_BUFFER,
            format!("the {name} buffer is not aligned for float"),
        ));
    }
    Ok(())
}

/// `len` floats at `ptr` read as `n` RGB triples.
///
/// # Safety
/// `ptr` is null or points to `len` readable floats that nobody writes to for `'a`.
pub(crate) unsafe fn rgb<'a>(
    ptr: *const f32,
    len: usize,
    n: usize,
    name: &str,
) -> Result<&'a [[f32; 3]], Error> {
    check_rgb(ptr, len, n, name)?;
    // SAFETY: non-null and aligned for f32, which is the alignment of [f32; 3]; len = 3n floats
    // are n triples, and n triples already exist in the operator, so 12n <= isize::MAX. The
    // caller promises they are readable and unaliased by writers.
    Ok(unsafe { std::slice::from_raw_parts(ptr.cast::<[f32; 3]>(), n) })
}

/// `len` floats at `ptr` written as `n` RGB triples.
///
/// # Safety
/// `ptr` is null or points to `len` writable floats that nothing else accesses for `'a`.
pub(crate) unsafe fn rgb_mut<'a>(
    ptr: *mut f32,
    len: usize,
    n: usize,
    name: &str,
) -> Result<&'a mut [[f32; 3]], Error> {
    check_rgb(ptr, len, n, name)?;
    // SAFETY: as in `rgb`; the caller promises the floats are writable and not accessed
    // through any other pointer during the call (the caller of this function checks overlap
    // with the other buffer it holds).
    Ok(unsafe { std::slice::from_raw_parts_mut(ptr.cast::<[f32; 3]>(), n) })
}

/// `len` floats at `ptr`; a null pointer is accepted for `len == 0`.
///
/// # Safety
/// `ptr` is null or points to `len` readable floats that nobody writes to for `'a`.
pub(crate) unsafe fn floats<'a>(
    ptr: *const f32,
    len: usize,
    name: &str,
) -> Result<&'a [f32], Error> {
    if len == 0 {
        return Ok(&[]);
    }
    if ptr.is_null() {
        return Err(Error::null(&format!("the {name} buffer")));
    }
    if !ptr.is_aligned() {
        return Err(Error::new(
            LRR_ERROR_BUFFER,
            format!("the {name} buffer is not aligned for float"),
        ));
    }
    if len > isize::MAX as usize / size_of::<f32>() {
        return Err(Error::new(
            LRR_ERROR_LENGTH,
            format!("a length of {len} floats cannot be addressed"),
        ));
    }
    // SAFETY: non-null, aligned, the byte length addressable; the caller promises `len`
    // readable floats that nobody writes to during the call.
    Ok(unsafe { std::slice::from_raw_parts(ptr, len) })
}

/// Whether two buffers of `len` floats share any byte (address arithmetic only).
pub(crate) fn overlap(a: *const f32, b: *const f32, len: usize) -> bool {
    let bytes = len.saturating_mul(size_of::<f32>());
    let (a, b) = (a as usize, b as usize);
    a < b.saturating_add(bytes) && b < a.saturating_add(bytes)
}

/// Three finite floats at `ptr` (a position or a normal).
///
/// # Safety
/// `ptr` is null or points to 3 readable floats.
pub(crate) unsafe fn vec3(ptr: *const f32, name: &str) -> Result<[f32; 3], Error> {
    if ptr.is_null() {
        return Err(Error::null(&format!("the {name}")));
    }
    if !ptr.is_aligned() {
        return Err(Error::new(
            LRR_ERROR_BUFFER,
            format!("the {name} is not aligned for float"),
        ));
    }
    // SAFETY: non-null and aligned; the caller promises 3 readable floats.
    let v = unsafe { ptr.cast::<[f32; 3]>().read() };
    if v.iter().any(|c| !c.is_finite()) {
        return Err(Error::new(
            LRR_ERROR_INPUT,
            format!("the {name} {v:?} has a non-finite coordinate"),
        ));
    }
    Ok(v)
}

/// A writable out-parameter.
///
/// # Safety
/// `ptr` is null or points to a writable `T` valid for `'a`.
pub(crate) unsafe fn out<'a, T>(ptr: *mut T, name: &str) -> Result<&'a mut T, Error> {
    if ptr.is_null() {
        return Err(Error::null(&format!("the {name} argument")));
    }
    if !ptr.is_aligned() {
        return Err(Error::new(
            LRR_ERROR_BUFFER,
            format!("the {name} argument is misaligned"),
        ));
    }
    // SAFETY: non-null and aligned; the caller promises a writable T.
    Ok(unsafe { &mut *ptr })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overlap_is_symmetric_and_exact() {
        let buf = [0.0f32; 8];
        let p = buf.as_ptr();
        // SAFETY: offsets stay inside `buf`.
        let (q, r) = unsafe { (p.add(2), p.add(4)) };
        assert!(overlap(p, q, 3) && overlap(q, p, 3));
        assert!(!overlap(p, r, 4) && !overlap(r, p, 4));
        assert!(!overlap(p, q, 0));
    }
}
