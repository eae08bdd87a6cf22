//! Lightmaps for C: the runtime's [`Lightmap`] behind the opaque `lrr_lightmap *`, built once
//! from an operator's lightmap coordinates and atlas, filled every frame from the radiosity
//! `lrr_evaluate` wrote.

use lrr_runtime::Lightmap;

use crate::LrrOperator;
use crate::args;
use crate::status::guard;
use crate::status::{Error, LRR_ERROR_LENGTH, status};

/// The opaque handle behind C's `lrr_lightmap *`.
#[derive(Debug)]
pub struct LrrLightmap {
    map: Lightmap,
    /// The operator's element count: the radiosity a fill takes.
    n: usize,
}

/// Makes the lightmap of `op` over the atlas its file names (sections LIGHTMAP and ATLAS:
/// every file baked by this lrr), smooth when the file has SMOOTH weights, filled on every
/// core, into `*out_lightmap`. The operator may be freed afterwards.
///
/// # Safety
/// `op` is null or a live operator handle; `out_lightmap` is null or points to a writable
/// `lrr_lightmap *`, set to null on failure.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lrr_lightmap_new(
    op: *const LrrOperator,
    out_lightmap: *mut *mut LrrLightmap,
) -> i32 {
    status(|| {
        // SAFETY: forwarded from this function's contract.
        let slot = unsafe { args::out(out_lightmap, "out_lightmap")? };
        *slot = std::ptr::null_mut();
        // SAFETY: forwarded from this function's contract.
        let op = &unsafe { args::operator(op)? }.op;
        let mut map = Lightmap::new(op.file(), None)?;
        map.set_threads(0);
        *slot = Box::into_raw(Box::new(LrrLightmap { map, n: op.n() }));
        Ok(())
    })
}

/// The atlas's width and height in texels into `*out_width` and `*out_height`.
///
/// # Safety
/// `lightmap` is null or a live handle from [`lrr_lightmap_new`]; `out_width` and
/// `out_height` are null or point to a writable `uint32_t` each.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lrr_lightmap_size(
    lightmap: *const LrrLightmap,
    out_width: *mut u32,
    out_height: *mut u32,
) -> i32 {
    status(|| {
        if lightmap.is_null() {
            return Err(Error::null("the lightmap handle"));
        }
        // SAFETY: non-null; the caller promises a live handle from lrr_lightmap_new.
        let l = unsafe { &*lightmap };
        // SAFETY: forwarded from this function's contract.
        let w = unsafe { args::out(out_width, "out_width")? };
        // SAFETY: forwarded from this function's contract.
        let h = unsafe { args::out(out_height, "out_height")? };
        // Sides are at most 16384 (the file's check).
        *w = l.map.width() as u32;
        *h = l.map.height() as u32;
        Ok(())
    })
}

/// Fills `texels` (`3 * width * height` floats, RGB, rows top to bottom) with the exitant
/// radiance `B/π` of `radiosity` (`3 * n` floats, interleaved RGB by element id: what
/// `lrr_evaluate` writes); texels no face covers and dilation does not reach are zero.
///
/// # Safety
/// `lightmap` is null or a live handle from [`lrr_lightmap_new`] that no other thread uses
/// during the call; `radiosity` and `texels` are null or point to that many readable and
/// writable floats, and do not overlap.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lrr_lightmap_fill(
    lightmap: *mut LrrLightmap,
    radiosity: *const f32,
    radiosity_len: usize,
    texels: *mut f32,
    texels_len: usize,
) -> i32 {
    status(|| {
        // SAFETY: forwarded from this function's contract.
        let l = unsafe { args::out(lightmap, "lightmap handle")? };
        // SAFETY: forwarded from this function's contract.
        let b = unsafe { args::rgb(radiosity, radiosity_len, l.n, "radiosity")? };
        let count = l.map.width() * l.map.height();
        if !texels.is_null() && texels_len != 3 * count {
            return Err(Error::new(
                LRR_ERROR_LENGTH,
                format!(
                    "the texels buffer holds {texels_len} floats, but the {}×{} atlas needs \
                     3 × {count} = {} (RGB)",
                    l.map.width(),
                    l.map.height(),
                    3 * count
                ),
            ));
        }
        args::check_rgb(texels, texels_len, count, "texels")?;
        let (r, t) = (radiosity as usize, texels as usize);
        if r < t.saturating_add(12 * count) && t < r.saturating_add(12 * l.n) {
            return Err(Error::new(
                crate::status::LRR_ERROR_BUFFER,
                "the radiosity and texels buffers overlap; pass two separate buffers",
            ));
        }
        // SAFETY: forwarded from this function's contract; checked above that it does not
        // overlap the radiosity.
        let out = unsafe { args::rgb_mut(texels, texels_len, count, "texels")? };
        l.map.fill(b, out)?;
        Ok(())
    })
}

/// Frees a lightmap. Null is allowed (nothing happens).
///
/// # Safety
/// `lightmap` is null or a handle from [`lrr_lightmap_new`] not freed before; it must not be
/// used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lrr_lightmap_free(lightmap: *mut LrrLightmap) {
    if lightmap.is_null() {
        return;
    }
    guard((), || {
        // SAFETY: the caller promises `lightmap` came from Box::into_raw in lrr_lightmap_new
        // and that this is its only release.
        drop(unsafe { Box::from_raw(lightmap) });
        Ok(())
    })
}
