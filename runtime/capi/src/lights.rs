//! Lights that are not surfaces for C: a direct pass (`lrr_runtime::lights::DirectLighting`)
//! behind the opaque `lrr_direct *`, taking a frame's lights as [`LRR_LIGHT_FLOATS`] floats each
//! and giving the emission to evaluate (`base + ρ ⊙ H`) and the direct light at a surface point.

use lrr_runtime::lights::{DirectLighting, Light, reflected};

use crate::LrrOperator;
use crate::args;
use crate::status::guard;
use crate::status::{Error, LRR_ERROR_BUFFER, LRR_ERROR_INPUT, LRR_ERROR_LENGTH, status};

/// Floats per light: kind (0 point, 1 spot, 2 directional), position (3), direction (3),
/// intensity (3; W/sr, or W/m² for a directional light), inner and outer cone half-angles in
/// radians (spot; else ignored).
pub const LRR_LIGHT_FLOATS: i32 = 12;

/// The opaque handle behind C's `lrr_direct *`: the direct pass of one operator and the
/// reflectance its lights are reflected with.
#[derive(Debug)]
pub struct LrrDirect {
    pass: DirectLighting,
    reflectance: Vec<[f32; 3]>,
}

/// Makes the direct pass of `op` with `samples` points per element (1 to 64; 4 is the
/// runtime's default) into `*out_direct` (threads: what the machine has). The operator may be
/// freed afterwards: the pass keeps what it needs.
///
/// # Safety
/// `op` is null or a live operator handle; `out_direct` is null or points to a writable
/// `lrr_direct *`, set to null on failure.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lrr_direct_new(
    op: *const LrrOperator,
    samples: u32,
    out_direct: *mut *mut LrrDirect,
) -> i32 {
    status(|| {
        // SAFETY: forwarded from this function's contract.
        let slot = unsafe { args::out(out_direct, "out_direct")? };
        *slot = std::ptr::null_mut();
        // SAFETY: forwarded from this function's contract.
        let op = &unsafe { args::operator(op)? }.op;
        let pass = DirectLighting::new(op.file(), samples, 0)?;
        *slot = Box::into_raw(Box::new(LrrDirect {
            pass,
            reflectance: op.reflectance(),
        }));
        Ok(())
    })
}

/// The lights of `count` records of [`LRR_LIGHT_FLOATS`] floats.
fn parse_lights(floats: &[f32]) -> Result<Vec<Light>, Error> {
    let per = LRR_LIGHT_FLOATS as usize;
    if !floats.len().is_multiple_of(per) {
        return Err(Error::new(
            LRR_ERROR_LENGTH,
            format!(
                "the lights buffer holds {} floats, not a multiple of LRR_LIGHT_FLOATS = {per}",
                floats.len()
            ),
        ));
    }
    floats
        .chunks_exact(per)
        .enumerate()
        .map(|(i, f)| {
            let v = |at: usize| [f[at], f[at + 1], f[at + 2]];
            let light = match f[0] {
                0.0 => Light::Point {
                    position: v(1),
                    intensity: v(7),
                },
                1.0 => Light::Spot {
                    position: v(1),
                    direction: v(4),
                    intensity: v(7),
                    inner: f[10],
                    outer: f[11],
                },
                2.0 => Light::Directional {
                    direction: v(4),
                    irradiance: v(7),
                },
                kind => {
                    return Err(Error::new(
                        LRR_ERROR_INPUT,
                        format!(
                            "light {i}: kind {kind} is none of 0 (point), 1 (spot), 2 (directional)"
                        ),
                    ));
                }
            };
            light
                .check()
                .map_err(|p| Error::new(LRR_ERROR_INPUT, format!("light {i}: {p}")))?;
            Ok(light)
        })
        .collect()
}

/// The emission of a frame with lights: `emission = base + ρ ⊙ H`, `H` the lights' direct
/// irradiance per element (shadow rays through the file's BVH; a light that did not move since
/// the last call is not traced again). `lights` holds `lights_len` floats, [`LRR_LIGHT_FLOATS`]
/// per light (0 lights: `emission` is `base`); `base` and `emission` are `3 * n` floats each,
/// interleaved RGB by element id, and must not overlap. Pass `emission` to `lrr_evaluate`.
///
/// # Safety
/// `direct` is null or a live handle from [`lrr_direct_new`] that no other thread uses during
/// the call; `lights` is null (only with `lights_len == 0`) or points to `lights_len` readable
/// floats; `base` and `emission` as `lrr_evaluate`'s buffers.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lrr_direct_emission(
    direct: *mut LrrDirect,
    lights: *const f32,
    lights_len: usize,
    base: *const f32,
    base_len: usize,
    emission: *mut f32,
    emission_len: usize,
) -> i32 {
    status(|| {
        // SAFETY: forwarded from this function's contract.
        let d = unsafe { args::out(direct, "direct handle")? };
        // SAFETY: forwarded from this function's contract.
        let list = parse_lights(unsafe { args::floats(lights, lights_len, "lights")? })?;
        let n = d.reflectance.len();
        // SAFETY: forwarded from this function's contract.
        let base_rgb = unsafe { args::rgb(base, base_len, n, "base emission")? };
        args::check_rgb(emission, emission_len, n, "emission")?;
        if args::overlap(base, emission, 3 * n) {
            return Err(Error::new(
                LRR_ERROR_BUFFER,
                "the base and emission buffers overlap; pass two separate buffers",
            ));
        }
        let mut h = vec![[0.0f32; 3]; n];
        d.pass.irradiance(&list, &mut h)?;
        // SAFETY: forwarded from this function's contract; checked above that it does not
        // overlap the base slice.
        let out = unsafe { args::rgb_mut(emission, emission_len, n, "emission")? };
        reflected(&d.reflectance, &h, base_rgb, out)?;
        Ok(())
    })
}

/// The direct light of `lights` reflected at a surface point: `ρ ⊙ H(x)` of element `element`
/// (its reflectance) at `position` on a surface of front normal `normal` (unit), each light
/// behind its own shadow ray; into `out_rgb` (3 floats). Add it to the bounced light at the
/// point (the radiosity less the element's `ρ ⊙ H`) for shadow edges as sharp as the light's.
///
/// # Safety
/// `direct` is null or a live handle from [`lrr_direct_new`]; `lights` as in
/// [`lrr_direct_emission`]; `position` and `normal` null or 3 readable floats; `out_rgb` null
/// or 3 writable floats.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lrr_direct_at(
    direct: *const LrrDirect,
    lights: *const f32,
    lights_len: usize,
    element: u32,
    position: *const f32,
    normal: *const f32,
    out_rgb: *mut f32,
) -> i32 {
    status(|| {
        if direct.is_null() {
            return Err(Error::null("the direct handle"));
        }
        // SAFETY: non-null; the caller promises a live handle from lrr_direct_new.
        let d = unsafe { &*direct };
        // SAFETY: forwarded from this function's contract.
        let list = parse_lights(unsafe { args::floats(lights, lights_len, "lights")? })?;
        // SAFETY: forwarded from this function's contract.
        let position = unsafe { args::vec3(position, "position")? };
        // SAFETY: forwarded from this function's contract.
        let normal = unsafe { args::vec3(normal, "normal")? };
        let rho = *d.reflectance.get(element as usize).ok_or_else(|| {
            Error::new(
                LRR_ERROR_INPUT,
                format!(
                    "element {element} is not below the operator's n = {}",
                    d.reflectance.len()
                ),
            )
        })?;
        // SAFETY: forwarded from this function's contract.
        let out = unsafe { args::out(out_rgb.cast::<[f32; 3]>(), "out_rgb")? };
        let h = d.pass.at(&list, position, normal);
        *out = [rho[0] * h[0], rho[1] * h[1], rho[2] * h[2]];
        Ok(())
    })
}

/// Frees a direct pass. Null is allowed (nothing happens).
///
/// # Safety
/// `direct` is null or a handle from [`lrr_direct_new`] not freed before; it must not be used
/// afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lrr_direct_free(direct: *mut LrrDirect) {
    if direct.is_null() {
        return;
    }
    guard((), || {
        // SAFETY: the caller promises `direct` came from Box::into_raw in lrr_direct_new and
        // that this is its only release.
        drop(unsafe { Box::from_raw(direct) });
        Ok(())
    })
}
