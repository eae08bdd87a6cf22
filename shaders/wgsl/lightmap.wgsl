// lightmap.wgsl (entry point lightmap_fill): the lightmap fill on the GPU, the twin of
// lrr_runtime::Lightmap::fill (runtime/src/lightmap.rs): a frame's radiosity as the exitant
// radiance B/pi of every texel the faces cover, then the dilation rings, written into an
// rgba16float storage texture an application binds (alpha 1 where written; texels never
// written stay zero). No readback.
//
// Self-contained (no common.wgsl). The host dispatches it once per step of a frame, with its
// own uniform:
// - mode MODE_SMOOTH: one invocation per sample, its value the weighted sum of at most four
//   smooth-vertex values (smooth.wgsl's output; weights times 1/pi, unused ones 0);
// - mode MODE_FLAT: one invocation per sample, its element's radiosity over pi;
// - mode MODE_RING: one invocation per texel of one dilation ring, the mean of its filled
//   8-neighbours (samples or texels of earlier rings), read from `values`.
// Compact ids: samples 0 .. samples, then the dilated texels in ring order; `values` holds 3
// f32 per compact id, `texel` the atlas texel (y * width + x) of each. lrr_shaders::workgroups
// (ceil(count / LIGHTMAP_LANES)) groups, a 2D grid past 65535 groups, whose surplus invocations
// return at once. Dispatches follow one another, so a ring reads what the steps before it
// wrote.
//
// Indices (the host checks them once, from the Lightmap it was built from, in
// runtime/src/gpu/lightmap.rs; the module is compiled with bounds checks anyway):
// - first + count <= the compact ids of the step; index: 4 per sample (smooth: smooth vertices
//   < the vertex count) or 1 (flat: original ids < n); table: 3 f32 per smooth vertex or per
//   element; neighbour_ends: one per dilated texel, non-decreasing, the last = the length of
//   neighbours; neighbours: compact ids of earlier steps.

const LIGHTMAP_LANES: u32 = 64u;
const MODE_SMOOTH: u32 = 0u;
const MODE_FLAT: u32 = 1u;
const MODE_RING: u32 = 2u;
const FRAC_1_PI: f32 = 0.31830988618379067;

// The uniform. Mirrored by lrr_shaders::LightmapParams (shaders/src/lightmap.rs), 32 bytes; a
// naga test compares names and offsets.
struct LightmapParams {
    // Invocations that compute.
    count: u32,
    // The compact id of the first.
    first: u32,
    // Texels across the atlas.
    width: u32,
    mode: u32,
    // Samples (the compact id of the first dilated texel).
    samples: u32,
    reserved0: u32,
    reserved1: u32,
    reserved2: u32,
}

@group(0) @binding(0) var<uniform> params: LightmapParams;
@group(0) @binding(1) var<storage, read> texel: array<u32>;
@group(0) @binding(2) var<storage, read> index: array<u32>;
@group(0) @binding(3) var<storage, read> weight: array<f32>;
// Smooth: the smooth-vertex values (3 f32 each); flat: the radiosity (3 f32 per original id).
@group(0) @binding(4) var<storage, read> table: array<f32>;
@group(0) @binding(5) var<storage, read_write> values: array<f32>;
@group(0) @binding(6) var<storage, read> neighbour_ends: array<u32>;
@group(0) @binding(7) var<storage, read> neighbours: array<u32>;
@group(0) @binding(8) var atlas: texture_storage_2d<rgba16float, write>;

fn at(buffer_index: u32) -> vec3<f32> {
    return vec3<f32>(table[buffer_index], table[buffer_index + 1u], table[buffer_index + 2u]);
}

@compute @workgroup_size(LIGHTMAP_LANES)
fn lightmap_fill(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let local = id.x + id.y * (groups.x * LIGHTMAP_LANES);
    if local >= params.count {
        return;
    }
    let i = params.first + local;
    var v = vec3<f32>(0.0);
    if params.mode == MODE_SMOOTH {
        for (var k = 0u; k < 4u; k++) {
            v = v + weight[4u * i + k] * at(3u * index[4u * i + k]);
        }
    } else if params.mode == MODE_FLAT {
        v = at(3u * index[i]) * FRAC_1_PI;
    } else {
        let j = i - params.samples;
        var start = 0u;
        if j > 0u {
            start = neighbour_ends[j - 1u];
        }
        let end = neighbour_ends[j];
        for (var k = start; k < end; k++) {
            let c = neighbours[k];
            v = v + vec3<f32>(values[3u * c], values[3u * c + 1u], values[3u * c + 2u]);
        }
        v = v * (1.0 / f32(end - start));
    }
    values[3u * i] = v.x;
    values[3u * i + 1u] = v.y;
    values[3u * i + 2u] = v.z;
    let t = texel[i];
    textureStore(atlas, vec2<u32>(t % params.width, t / params.width), vec4<f32>(v, 1.0));
}
