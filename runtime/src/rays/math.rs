//! The few vector operations rays need (the direct pass's and the tracer's), on plain
//! `[f32; 3]` (the layout a WGSL twin reads as `vec3<f32>`), so that nothing in the hot loop
//! hides behind a trait.

/// A point or direction.
pub(crate) type V3 = [f32; 3];

#[inline(always)]
pub(crate) fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[inline(always)]
pub(crate) fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline(always)]
pub(crate) fn scale(a: V3, s: f32) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// `a + s b`.
#[inline(always)]
pub(crate) fn mad(a: V3, b: V3, s: f32) -> V3 {
    [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]]
}

#[cfg(feature = "trace")]
#[inline(always)]
pub(crate) fn mul(a: V3, b: V3) -> V3 {
    [a[0] * b[0], a[1] * b[1], a[2] * b[2]]
}

#[inline(always)]
pub(crate) fn dot(a: V3, b: V3) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline(always)]
pub(crate) fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[inline(always)]
pub(crate) fn length(a: V3) -> f32 {
    dot(a, a).sqrt()
}

/// `a / |a|`; zero stays zero (callers check lengths where it matters).
#[inline(always)]
pub(crate) fn normalize(a: V3) -> V3 {
    let l = length(a);
    if l > 0.0 { scale(a, 1.0 / l) } else { a }
}

/// The largest component.
#[cfg(feature = "trace")]
#[inline(always)]
pub(crate) fn max_component(a: V3) -> f32 {
    a[0].max(a[1]).max(a[2])
}
