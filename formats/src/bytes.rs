//! Little-endian scalars and arrays, and checked size arithmetic.
//!
//! Decoders take a slice whose length the caller has already checked against the dimensions, so
//! the vectors they allocate are never larger than bytes that really exist in the input.

use crate::error::FormatError;

/// Rounds `x` up to a multiple of `align` (a power of two), `None` on overflow.
pub(crate) fn align_up(x: u64, align: u64) -> Option<u64> {
    Some(x.checked_add(align - 1)? & !(align - 1))
}

/// The product of `factors` as a `usize`, or a `Limits` error naming `what`.
pub(crate) fn checked_product(what: &str, factors: &[u64]) -> Result<usize, FormatError> {
    factors
        .iter()
        .try_fold(1u64, |acc, &f| acc.checked_mul(f))
        .and_then(|p| usize::try_from(p).ok())
        .ok_or_else(|| {
            let terms: Vec<String> = factors.iter().map(u64::to_string).collect();
            FormatError::limits(format!(
                "{what}: size {} overflows this machine's address space",
                terms.join(" x ")
            ))
        })
}

/// The `N` bytes at `at`, or `None` when they are not all inside `bytes`.
pub(crate) fn array_at<const N: usize>(bytes: &[u8], at: usize) -> Option<[u8; N]> {
    let end = at.checked_add(N)?;
    bytes.get(at..end)?.try_into().ok()
}

pub(crate) fn u16_at(bytes: &[u8], at: usize) -> Option<u16> {
    array_at(bytes, at).map(u16::from_le_bytes)
}

pub(crate) fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    array_at(bytes, at).map(u32::from_le_bytes)
}

pub(crate) fn u64_at(bytes: &[u8], at: usize) -> Option<u64> {
    array_at(bytes, at).map(u64::from_le_bytes)
}

pub(crate) fn f32_at(bytes: &[u8], at: usize) -> Option<f32> {
    array_at(bytes, at).map(f32::from_le_bytes)
}

/// Three consecutive `f32` at `at` (zeros past the end: callers check lengths first).
pub(crate) fn vec3_at(bytes: &[u8], at: usize) -> [f32; 3] {
    [0, 4, 8].map(|d| f32_at(bytes, at.saturating_add(d)).unwrap_or_default())
}

/// Decodes `bytes.len() / 4` little-endian `u32` (a trailing partial value is ignored).
pub(crate) fn u32s(bytes: &[u8]) -> Vec<u32> {
    bytes
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

pub(crate) fn u16s(bytes: &[u8]) -> Vec<u16> {
    bytes
        .chunks_exact(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]))
        .collect()
}

pub(crate) fn f32s(bytes: &[u8]) -> Vec<f32> {
    bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

pub(crate) fn f64s(bytes: &[u8]) -> Vec<f64> {
    bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]))
        .collect()
}

pub(crate) fn put_u32s(out: &mut Vec<u8>, values: &[u32]) {
    out.reserve(values.len() * 4);
    values
        .iter()
        .for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
}

pub(crate) fn put_u16s(out: &mut Vec<u8>, values: &[u16]) {
    out.reserve(values.len() * 2);
    values
        .iter()
        .for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
}

pub(crate) fn put_f32s(out: &mut Vec<u8>, values: &[f32]) {
    out.reserve(values.len() * 4);
    values
        .iter()
        .for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
}

pub(crate) fn put_f64s(out: &mut Vec<u8>, values: &[f64]) {
    out.reserve(values.len() * 8);
    values
        .iter()
        .for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scalars_and_arrays_round_trip() {
        let mut out = Vec::new();
        put_u32s(&mut out, &[1, u32::MAX]);
        put_f32s(&mut out, &[-1.5]);
        put_f64s(&mut out, &[0.25]);
        put_u16s(&mut out, &[0xBEEF]);
        assert_eq!(u32s(&out[..8]), [1, u32::MAX]);
        assert_eq!(f32s(&out[8..12]), [-1.5]);
        assert_eq!(f64s(&out[12..20]), [0.25]);
        assert_eq!(u16s(&out[20..]), [0xBEEF]);
        assert_eq!(u16_at(&out, 20), Some(0xBEEF));
        assert_eq!(u32_at(&out, 19), None);
        assert_eq!(u64_at(&out, usize::MAX), None);
    }

    #[test]
    fn sizes_are_checked() {
        assert_eq!(align_up(65, 64), Some(128));
        assert_eq!(align_up(128, 64), Some(128));
        assert_eq!(align_up(u64::MAX, 64), None);
        assert_eq!(checked_product("x", &[3, 4, 5]), Ok(60));
        let err = checked_product("section FK", &[u64::from(u32::MAX), u64::from(u32::MAX), 4]);
        assert_eq!(err.unwrap_err().kind, crate::ErrorKind::Limits);
    }
}
