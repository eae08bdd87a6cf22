// direct_pass.wgsl (entry point direct_pass): the per-frame direct pass of lights that are not
// surfaces on the GPU, the twin of lrr_runtime::trace::DirectLighting::irradiance followed by
// `reflected` (runtime/src/lights.rs): for every element, each light's irradiance per unit
// strength g (direct_light.wgsl's `towards`) averaged over the element's fixed sample points
// (the CPU pass's own points, uploaded once), each behind an any-hit shadow ray through the
// file's BVH (bvh.wgsl's `occluded`); then H = sum over lights of strength * mean, and
// E = base + rho * H written over the emission the GPU evaluator bounces next (no readback).
//
// A cache of still lights, the CPU pass's: each light's record carries a cache word (its slot in
// `terms` and whether to trace it this frame, lrr_shaders::direct_cache_word). A light to trace
// has its mean computed behind shadow rays and, when it has a slot, stored there (f32 bits at
// terms[n + slot * n + e]); any other light's mean is the one an earlier frame stored (no ray,
// the same f32). The host traces a light again when anything but its strength changed.
//
// Its source is bvh.wgsl + direct_light.wgsl + this file (lrr_shaders::DIRECT_PASS). One
// invocation per element (original id), a dispatch covering the elements first_element ..
// first_element + element_count (the host cuts a frame into dispatches of a bounded number of
// shadow rays, so that none runs long enough for a driver's watchdog).
//
// The CPU's order of operations: per light in the uploaded order, an f32 running sum of g over
// the element's samples in order (the lit and unoccluded ones), divided by the number of samples;
// H accumulated light by light as h + strength * mean; E = base + rho * H per channel. A shadow
// ray starts at p + epsilon n and ends just short of the light (d (1 - 1e-5)), or at FAR for a
// sun, as the CPU's `element_term`. The CPU traces the 4-wide BVH (packets of four rays where
// four samples face a light), which finds the same any hit as this binary traversal; a GPU
// compiler may fuse a multiply and an add and WGSL's division and sqrt need not round
// correctly, so H agrees to rounding, and a shadow ray that passes within rounding of an edge
// may be decided otherwise (runtime/tests/gpu_direct.rs measures both).
//
// Indices (the argument for building this pass without bounds checks; the host,
// runtime/src/gpu/direct.rs, checks all of it):
// - nodes and tris: bvh.wgsl's argument (the host runs no pass over a scene without triangles);
// - e = first_element + id < first_element + element_count <= n (checked below and on the host);
// - samples: n * samples_per_element entries, element e's at e * samples_per_element + j for
//   j < samples_per_element (n * samples_per_element * 32 bytes fits one binding, so the index
//   does not overflow);
// - direct_lights: at least light_count entries (the host writes them per frame);
// - reflectance, emission, irradiance: 3 n f32 each; terms: n u32 of ray counts (written only
//   with COUNT_RAYS) then n u32 per slot, (1 + slots) n words, every slot word of a record below
//   slots or DIRECT_NO_SLOT; a slot read without tracing was written by an earlier frame (the
//   host's cache; a slot never written holds zeros, which the host never reads).
// The loops end: j < samples_per_element <= 64, l < light_count, and bvh.wgsl's traversal.

// Count the shadow rays per element into the first n words of `terms` (the CPU's
// DirectReport::rays; off for timed frames).
override COUNT_RAYS: bool = false;

// Invocations per workgroup (lrr_shaders::DIRECT_LANES).
const DIRECT_LANES: u32 = 64u;
// A cache word's trace bit and the slot of a light whose term is not stored
// (lrr_shaders::DIRECT_TRACE, DIRECT_NO_SLOT).
const DIRECT_TRACE: u32 = 0x80000000u;
const DIRECT_NO_SLOT: u32 = 0x7fffffffu;

// The per-dispatch uniform. Mirrored by lrr_shaders::DirectParams (shaders/src/direct.rs), 32
// bytes; a naga test compares names and offsets.
struct DirectParams {
    // This dispatch's elements (original ids).
    first_element: u32,
    element_count: u32,
    // Sample points per element (1 to 64).
    samples_per_element: u32,
    // Lights in direct_lights (the frame's shining ones, in the caller's order).
    light_count: u32,
    // Offset of shadow ray origins off their surface (the scene's epsilon).
    epsilon: f32,
    // Elements in all (the stride of terms' slots).
    n: u32,
    reserved1: u32,
    reserved2: u32,
}

// One sample point of an element (lrr_shaders::direct_sample, 32 bytes; a naga test compares
// offsets): on its surface, with its front normal; valid 0 for the points of an element drawn by
// no triangle of area, which see no light (the CPU's NaN points).
struct Sample {
    point: vec3<f32>,
    valid: u32,
    normal: vec3<f32>,
    reserved: u32,
}

@group(0) @binding(0) var<uniform> params: DirectParams;
// Bindings 1 (nodes) and 2 (tris, leaf-order triangles): bvh.wgsl.
// samples_per_element per element, original ids (DirectLighting's points, uploaded once).
@group(0) @binding(3) var<storage, read> samples: array<Sample>;
// This frame's shining lights (dark ones left out by the host: they add nothing).
@group(0) @binding(4) var<storage, read> direct_lights: array<DirectLight>;
// Reflectance per element, 3 f32 each, original ids.
@group(0) @binding(5) var<storage, read> reflectance: array<f32>;
// In: the frame's base emission; out: base + rho * H. 3 f32 per element, original ids (the GPU
// evaluator's upload slot, which its segment sums and gather read next).
@group(0) @binding(6) var<storage, read_write> emission: array<f32>;
// Out: H, 3 f32 per element, original ids.
@group(0) @binding(7) var<storage, read_write> irradiance: array<f32>;
// Out (COUNT_RAYS): the shadow rays cast per element, its first n words; then the stored
// terms, n f32 (as bits) per slot.
@group(0) @binding(8) var<storage, read_write> terms: array<u32>;

@compute @workgroup_size(DIRECT_LANES)
fn direct_pass(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = id.x + id.y * (groups.x * DIRECT_LANES);
    if i >= params.element_count {
        return;
    }
    let e = params.first_element + i;
    let first = e * params.samples_per_element;
    var h = vec3<f32>(0.0);
    var shadow_rays = 0u;
    for (var l = 0u; l < params.light_count; l++) {
        let light = direct_lights[l];
        let slot = light.cache & DIRECT_NO_SLOT;
        if (light.cache & DIRECT_TRACE) == 0u {
            // Still since the frame that stored its term: no ray.
            h = h + light.strength * bitcast<f32>(terms[params.n + slot * params.n + e]);
            continue;
        }
        // lights.rs `element_term`: the mean of g over the samples the light reaches unblocked.
        var sum = 0.0;
        for (var j = 0u; j < params.samples_per_element; j++) {
            let s = samples[first + j];
            if s.valid == 0u {
                continue;
            }
            let to = towards(light, s.point, s.normal);
            if !to.lit {
                continue;
            }
            shadow_rays += 1u;
            var reach = FAR;
            if light.kind != DIRECT_SUN {
                reach = to.dist * (1.0 - 1e-5);
            }
            let origin = mad3(s.point, s.normal, params.epsilon);
            if !occluded(make_ray(origin, to.w), 0.0, reach) {
                sum += to.g;
            }
        }
        let mean = sum / f32(params.samples_per_element);
        if slot != DIRECT_NO_SLOT {
            terms[params.n + slot * params.n + e] = bitcast<u32>(mean);
        }
        h = h + light.strength * mean;
    }
    let at = 3u * e;
    let rho = vec3<f32>(reflectance[at], reflectance[at + 1u], reflectance[at + 2u]);
    let base = vec3<f32>(emission[at], emission[at + 1u], emission[at + 2u]);
    let out = base + rho * h;
    emission[at] = out.x;
    emission[at + 1u] = out.y;
    emission[at + 2u] = out.z;
    irradiance[at] = h.x;
    irradiance[at + 1u] = h.y;
    irradiance[at + 2u] = h.z;
    if COUNT_RAYS {
        terms[e] = shadow_rays;
    }
}
