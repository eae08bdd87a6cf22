/*
 * lrr.h: the C interface of the lrr runtime (low-rank radiosity).
 *
 * Load an operator file baked by `lrr bake`, then relight the scene for any emission, every
 * frame, in O(nk):  B = E + rho * F_k M (V^T E).  Link liblrr_capi.a (with -lpthread -ldl -lm)
 * or liblrr_capi.so. Written by hand: runtime/capi/tests/header.rs checks that it declares
 * exactly the functions and codes of runtime/capi/src, with the same parameter types.
 *
 * Conventions
 * - Functions return LRR_OK (0) or a negative LRR_ERROR_* code, except lrr_element_count
 *   (0 on error), lrr_free and lrr_last_error. After a failure, lrr_last_error() says what
 *   went wrong. Invalid arguments (null pointers, wrong lengths, misaligned or overlapping
 *   buffers, paths that are not UTF-8) are reported as errors; a bug inside lrr is caught and
 *   reported as LRR_ERROR_PANIC, never unwound into C.
 * - Emission and radiosity buffers are interleaved RGB floats, 3 * n of them for an operator of
 *   n elements, indexed by element id: element i is floats 3i, 3i+1, 3i+2. The caller owns them.
 * - Emission is emitted exitance (lrr reports E = pi * Ke for an MTL Ke); radiosity comes out in
 *   the same units.
 * - An operator handle is owned by the caller from a successful lrr_load* until lrr_free. It is
 *   immutable: several threads may call lrr_evaluate on one handle at once, each with its own
 *   output buffer. Freeing it while another thread uses it is undefined behaviour.
 * - What no function can check is the caller's promise: that a non-null pointer points at as
 *   many readable (or writable) values as its length says, and that a handle is live.
 */
#ifndef LRR_H
#define LRR_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Status codes. */
#define LRR_OK 0
/* A required pointer argument is null. */
#define LRR_ERROR_NULL (-1)
/* The path is not valid UTF-8. */
#define LRR_ERROR_UTF8 (-2)
/* A buffer length does not match the operator (it must be 3 * lrr_element_count). */
#define LRR_ERROR_LENGTH (-3)
/* A buffer is misaligned for float, or the input and output buffers overlap. */
#define LRR_ERROR_BUFFER (-4)
/* The file could not be read (missing, permissions). */
#define LRR_ERROR_IO (-5)
/* The bytes are not a valid operator file (wrong magic or version, truncated, corrupt). */
#define LRR_ERROR_FORMAT (-6)
/* An input value is refused: negative or non-finite emission, a non-finite point or normal. */
#define LRR_ERROR_INPUT (-7)
/* A bug in lrr: a panic was caught at the boundary. Output buffers hold unspecified values. */
#define LRR_ERROR_PANIC (-8)

/* A loaded operator (opaque). */
typedef struct lrr_operator lrr_operator;

/*
 * Loads and validates the operator file at `path` (NUL-terminated UTF-8; the library does not
 * keep it). On success stores a new handle in *out_op, which the caller frees with lrr_free.
 * On failure sets *out_op to NULL (when out_op is not NULL) and returns LRR_ERROR_NULL,
 * LRR_ERROR_UTF8, LRR_ERROR_IO or LRR_ERROR_FORMAT.
 */
int32_t lrr_load(const char *path, lrr_operator **out_op);

/*
 * Like lrr_load, from `len` bytes in memory. The bytes are copied: the caller may free them as
 * soon as this returns. `bytes` may be NULL only when len is 0 (which gives LRR_ERROR_FORMAT).
 */
int32_t lrr_load_bytes(const uint8_t *bytes, size_t len, lrr_operator **out_op);

/* The number of elements n (at least 1) of a loaded operator; 0 if `op` is NULL. */
size_t lrr_element_count(const lrr_operator *op);

/*
 * Radiosity for an emission. `emission` holds emission_len = 3 * n readable floats, finite and
 * non-negative; `radiosity` receives radiosity_len = 3 * n floats and must not overlap
 * `emission`. Both stay owned by the caller and are not kept. `radiosity` is written only on
 * success. Errors: LRR_ERROR_NULL, LRR_ERROR_LENGTH, LRR_ERROR_BUFFER, LRR_ERROR_INPUT.
 */
int32_t lrr_evaluate(const lrr_operator *op, const float *emission, size_t emission_len,
                     float *radiosity, size_t radiosity_len);

/*
 * Copies the emission the scene was baked with (3 * n floats, interleaved RGB by element id)
 * into `out`, which holds out_len = 3 * n writable floats. Scale it, edit it, pass it to
 * lrr_evaluate. Errors: LRR_ERROR_NULL, LRR_ERROR_LENGTH, LRR_ERROR_BUFFER.
 */
int32_t lrr_baked_emission(const lrr_operator *op, float *out, size_t out_len);

/*
 * The id of the element whose surface holds the point `position` (x, y, z): the nearest element
 * whose normal agrees with `normal` (dot product > 0), or the nearest of all when none agrees;
 * the normal tells coincident surfaces apart. Stores the id (below n) in *out_element. Linear in
 * n: for probes, not per frame. Errors: LRR_ERROR_NULL, LRR_ERROR_BUFFER, LRR_ERROR_INPUT (a
 * non-finite coordinate).
 */
int32_t lrr_locate(const lrr_operator *op, const float position[3], const float normal[3],
                   uint32_t *out_element);

/* Frees an operator from lrr_load*. NULL does nothing. The handle must not be used afterwards. */
void lrr_free(lrr_operator *op);

/*
 * Lights that are not surfaces (point, spot, directional), moving every frame: the operator is
 * linear in the emission, so a frame lights each element with their direct irradiance H (at
 * fixed sample points, each behind a shadow ray through the file's BVH) and evaluates
 * E = base + rho * H. A light is LRR_LIGHT_FLOATS floats:
 *   [0]      kind: 0 point, 1 spot, 2 directional
 *   [1..4]   position (point, spot)
 *   [4..7]   direction: where a spot points, where a directional light's light travels
 *   [7..10]  intensity per channel: W/sr (point; spot on its axis), W/m^2 facing it (directional)
 *   [10, 11] a spot's inner and outer cone half-angles in radians (glTF's falloff between)
 */
#define LRR_LIGHT_FLOATS 12

/* The direct pass of one operator (opaque). One thread at a time. */
typedef struct lrr_direct lrr_direct;

/*
 * Makes the direct pass of `op` with `samples` points per element (1 to 64; 4 is the default
 * elsewhere) into *out_direct, freed with lrr_direct_free; NULL there on failure. Needs a file
 * baked with a BVH (this lrr). Errors: LRR_ERROR_NULL, LRR_ERROR_BUFFER, LRR_ERROR_INPUT.
 */
int32_t lrr_direct_new(const lrr_operator *op, uint32_t samples, lrr_direct **out_direct);

/*
 * The emission of a frame with lights: emission = base + rho * H (3 * n floats each, not
 * overlapping). `lights` holds lights_len = LRR_LIGHT_FLOATS * count floats (NULL with 0: no
 * light, no ray). A light that did not move since the last call is not traced again. Pass
 * `emission` to lrr_evaluate. Errors: LRR_ERROR_NULL, LRR_ERROR_LENGTH, LRR_ERROR_BUFFER,
 * LRR_ERROR_INPUT (a bad light, named by its index).
 */
int32_t lrr_direct_emission(lrr_direct *direct, const float *lights, size_t lights_len,
                            const float *base, size_t base_len, float *emission,
                            size_t emission_len);

/*
 * The direct light reflected at a surface point: rho * H(x) of element `element` at
 * `position` on a surface of front normal `normal` (unit), each light behind its own shadow
 * ray, into out_rgb[3]. Added to the bounced light there (the radiosity less rho * H of the
 * element), shadow edges are as sharp as the light's. Errors: LRR_ERROR_NULL,
 * LRR_ERROR_LENGTH, LRR_ERROR_BUFFER, LRR_ERROR_INPUT.
 */
int32_t lrr_direct_at(const lrr_direct *direct, const float *lights, size_t lights_len,
                      uint32_t element, const float position[3], const float normal[3],
                      float out_rgb[3]);

/* Frees a direct pass from lrr_direct_new. NULL does nothing. */
void lrr_direct_free(lrr_direct *direct);

/*
 * Lightmaps filled every frame: the texels of the lightmap atlas the bake laid out (the scene's
 * TEXCOORD_1, or charts the bake packed; every file of this lrr has one), each the exitant
 * radiance B/pi of the surface under it, RGB, rows top to bottom (v = 0 the first row),
 * smooth when the file has smooth weights, dilated the atlas's padding around the charts.
 */
typedef struct lrr_lightmap lrr_lightmap;

/*
 * Makes the lightmap of `op` into *out_lightmap, freed with lrr_lightmap_free; NULL there on
 * failure. Built once (it rasterises the display faces); the operator may be freed afterwards.
 * Errors: LRR_ERROR_NULL, LRR_ERROR_BUFFER, LRR_ERROR_INPUT (a file without an atlas).
 */
int32_t lrr_lightmap_new(const lrr_operator *op, lrr_lightmap **out_lightmap);

/* The atlas's width and height in texels. Errors: LRR_ERROR_NULL, LRR_ERROR_BUFFER. */
int32_t lrr_lightmap_size(const lrr_lightmap *lightmap, uint32_t *out_width,
                          uint32_t *out_height);

/*
 * Fills `texels` (3 * width * height floats) from `radiosity` (3 * n floats, interleaved RGB
 * by element id, what lrr_evaluate writes); the buffers must not overlap. One pass over a
 * sparse table, no allocation, on every core. One thread at a time per lightmap. Errors:
 * LRR_ERROR_NULL, LRR_ERROR_LENGTH, LRR_ERROR_BUFFER.
 */
int32_t lrr_lightmap_fill(lrr_lightmap *lightmap, const float *radiosity, size_t radiosity_len,
                          float *texels, size_t texels_len);

/* Frees a lightmap from lrr_lightmap_new. NULL does nothing. */
void lrr_lightmap_free(lrr_lightmap *lightmap);

/*
 * The message of the last call that failed on the calling thread (NUL-terminated UTF-8), or ""
 * if none has. The string belongs to the library: do not free it. It stays valid until the next
 * failing lrr_ call on the same thread; successful calls leave it unchanged.
 */
const char *lrr_last_error(void);

#ifdef __cplusplus
}
#endif

#endif /* LRR_H */
