// lightmap.wgsl (entry point lightmap_fill): the lightmap fill on the GPU, the twin of
// lrr_runtime::Lightmap::fill (runtime/src/lightmap.rs): a frame's radiosity as the exitant
// radiance B/pi of every texel the faces cover and of every texel the dilation rings fill,
// written into an rgba16float storage texture an application binds (alpha 1 where written;
// texels never written stay zero). No readback.
//
// Self-contained (no common.wgsl). One dispatch a frame, one invocation per texel written:
// - invocations 0 .. samples: the samples. Sample i belongs to run r = samples[stride * i]
//   (consecutive texels of one row that one face covers), shows texel i + run_base[r] (wrapping
//   u32 arithmetic: run_base is the run's first texel minus its first sample) and reads the
//   run's sources run_index[r]:
//   - mode MODE_SMOOTH (stride 5): four smooth-vertex values (smooth.wgsl's output) weighted
//     by four weights (times 1/pi; unused corners weight 0), samples[5i + 1 .. 5i + 5];
//   - mode MODE_FLAT (stride 1): the element run_index[r].x's radiosity over pi.
// - invocations samples .. count: the dilated texels, ring after ring. Each is the mean of its
//   filled 8-neighbours, samples or texels of earlier rings, all linear in the sources, so the
//   host has expanded it into sources and weights once: texel j is rings[2j], its terms end at
//   rings[2j + 1] (start at rings[2j - 1], or 0), term k reads source ring_source[k] with
//   weight ring_weight[k]. No ring reads another, so the rings take
//   no dispatch of their own.
// `table` holds 3 f32 per source: the smooth-vertex values (smooth) or the radiosity per
// original id (flat). lrr_shaders::workgroups(ceil(count / LIGHTMAP_LANES)) groups, a 2D grid
// past 65535 groups, whose surplus invocations return at once.
//
// Weights are f32 (bits in u32 words). Binary16 weights (2^-11 relative) measured no faster on
// an H200 (22.0 against 22.3 us for the building's fill, docs/PERFORMANCE.md) and would add
// their rounding to the texture's.
//
// Indices (the host checks them once, from the Lightmap it was built from, in
// runtime/src/gpu/lightmap.rs; the module is compiled with bounds checks anyway): runs <
// run_base's length; sources < the smooth vertices (smooth) or n (flat); ring ends
// non-decreasing, the last = the length of ring_source.

const LIGHTMAP_LANES: u32 = 64u;
const MODE_SMOOTH: u32 = 0u;
const MODE_FLAT: u32 = 1u;
const FRAC_1_PI: f32 = 0.31830988618379067;

// The uniform. Mirrored by lrr_shaders::LightmapParams (shaders/src/lightmap.rs), 32 bytes; a
// naga test compares names and offsets.
struct LightmapParams {
    // Samples (the invocations before the dilated texels).
    samples: u32,
    // Invocations that compute: samples and dilated texels.
    count: u32,
    // Texels across the atlas.
    width: u32,
    // MODE_SMOOTH or MODE_FLAT.
    mode: u32,
    reserved0: u32,
    reserved1: u32,
    reserved2: u32,
    reserved3: u32,
}

@group(0) @binding(0) var<uniform> params: LightmapParams;
@group(0) @binding(1) var<storage, read> samples: array<u32>;
@group(0) @binding(2) var<storage, read> run_base: array<u32>;
@group(0) @binding(3) var<storage, read> run_index: array<vec4<u32>>;
@group(0) @binding(4) var<storage, read> rings: array<u32>;
@group(0) @binding(5) var<storage, read> ring_source: array<u32>;
@group(0) @binding(6) var<storage, read> ring_weight: array<u32>;
// Smooth: the smooth-vertex values (3 f32 each); flat: the radiosity (3 f32 per original id).
@group(0) @binding(7) var<storage, read> table: array<f32>;
@group(0) @binding(8) var atlas: texture_storage_2d<rgba16float, write>;

fn at(source: u32) -> vec3<f32> {
    let i = 3u * source;
    return vec3<f32>(table[i], table[i + 1u], table[i + 2u]);
}

@compute @workgroup_size(LIGHTMAP_LANES)
fn lightmap_fill(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = id.x + id.y * (groups.x * LIGHTMAP_LANES);
    if i >= params.count {
        return;
    }
    var v = vec3<f32>(0.0);
    var t = 0u;
    if i < params.samples {
        if params.mode == MODE_SMOOTH {
            let b = 5u * i;
            let run = samples[b];
            let c = run_index[run];
            let w = vec4<f32>(
                bitcast<f32>(samples[b + 1u]),
                bitcast<f32>(samples[b + 2u]),
                bitcast<f32>(samples[b + 3u]),
                bitcast<f32>(samples[b + 4u]),
            );
            v = w.x * at(c.x) + w.y * at(c.y) + w.z * at(c.z) + w.w * at(c.w);
            t = i + run_base[run];
        } else {
            let run = samples[i];
            v = at(run_index[run].x) * FRAC_1_PI;
            t = i + run_base[run];
        }
    } else {
        let j = i - params.samples;
        var start = 0u;
        if j > 0u {
            start = rings[2u * j - 1u];
        }
        t = rings[2u * j];
        let end = rings[2u * j + 1u];
        // Four terms a step, their loads in flight together; past the end a term reads the
        // last term's source, and its product is not added.
        let last = end - 1u;
        let zero = vec3<f32>(0.0);
        for (var k = start; k < end; k += 4u) {
            let q = vec4<u32>(k, min(k + 1u, last), min(k + 2u, last), min(k + 3u, last));
            let w = vec4<f32>(
                bitcast<f32>(ring_weight[q.x]),
                bitcast<f32>(ring_weight[q.y]),
                bitcast<f32>(ring_weight[q.z]),
                bitcast<f32>(ring_weight[q.w]),
            );
            let a0 = at(ring_source[q.x]);
            let a1 = at(ring_source[q.y]);
            let a2 = at(ring_source[q.z]);
            let a3 = at(ring_source[q.w]);
            v = v + w.x * a0;
            v = v + select(zero, w.y * a1, k + 1u < end);
            v = v + select(zero, w.z * a2, k + 2u < end);
            v = v + select(zero, w.w * a3, k + 3u < end);
        }
    }
    textureStore(atlas, vec2<u32>(t % params.width, t / params.width), vec4<f32>(v, 1.0));
}
