// smooth.wgsl (entry point smooth_vertices): the smooth reconstruction's per-frame step on the
// GPU, the twin of lrr_runtime::Reconstruction::vertex_values (runtime/src/smooth.rs) and
// mirrored in f32 by lrr_shaders::cpu::smooth_vertices: each smooth vertex's value, the
// weighted sum of its elements' radiosity (section SMOOTH's weights; negative on a surface's
// boundary, where a vertex extrapolates), clamped at zero. It reads the radiosity the
// relighting passes left in their storage buffer and writes the values trace.wgsl interpolates
// (no readback between the passes).
//
// Self-contained (no common.wgsl). One invocation per smooth vertex, its row read four entries
// at a time: the four entries' loads are independent, so they are in flight together (one
// entry after another, each a chain of two loads, made the pass latency-bound: 10 us of an
// H200's time for the building's 36 261 vertices, docs/PERFORMANCE.md). The host dispatches
// lrr_shaders::workgroups(ceil(vertex_count / SMOOTH_LANES)) groups, a 2D grid past 65535
// groups, whose surplus invocations return at once.
//
// Indices (the argument for building this pass without bounds checks; the host checks all of
// it once, in Reconstruction::from_parts through TraceScene::new or, for the lightmap fill,
// Reconstruction::new, and in runtime/src/gpu/smooth.rs):
// - offsets: vertex_count + 1 entries, non-decreasing, the last = the length of elements and
//   weights, so offsets[v] .. offsets[v + 1] stays inside both for v < vertex_count (a step's
//   entries past the row's end read index offsets[v + 1] - 1, inside the row);
// - elements: original ids < n (SMOOTH's file positions mapped through the file's order at
//   upload, runtime/src/gpu/smooth.rs);
// - radiosity: at least 3 n f32 (checked per frame); vertex_values: 3 vertex_count f32.

const SMOOTH_LANES: u32 = 64u;

// The uniform. Mirrored by lrr_shaders::SmoothParams (shaders/src/smooth.rs), 16 bytes; a naga
// test compares names and offsets.
struct SmoothParams {
    vertex_count: u32,
    reserved0: u32,
    reserved1: u32,
    reserved2: u32,
}

@group(0) @binding(0) var<uniform> params: SmoothParams;
// Per smooth vertex v: its weights are offsets[v] .. offsets[v + 1].
@group(0) @binding(1) var<storage, read> offsets: array<u32>;
// Per weight: the original id of its element (the index into the radiosity).
@group(0) @binding(2) var<storage, read> elements: array<u32>;
@group(0) @binding(3) var<storage, read> weights: array<f32>;
// The relighting's B: 3 f32 per element, original ids (GpuEvaluator::radiosity_buffer).
@group(0) @binding(4) var<storage, read> radiosity: array<f32>;
// Out: 3 f32 per smooth vertex.
@group(0) @binding(5) var<storage, read_write> vertex_values: array<f32>;

fn element_value(e: u32) -> vec3<f32> {
    return vec3<f32>(radiosity[3u * e], radiosity[3u * e + 1u], radiosity[3u * e + 2u]);
}

@compute @workgroup_size(SMOOTH_LANES)
fn smooth_vertices(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let v = id.x + id.y * (groups.x * SMOOTH_LANES);
    if v >= params.vertex_count {
        return;
    }
    // Weights in their stored order, each channel a running f32 sum (the CPU mirror's order).
    // Four entries a step; past the row's end an entry reads the row's last element, and its
    // product is not added (so an infinite radiosity gives what the mirror gives).
    var sum = vec3<f32>(0.0);
    let end = offsets[v + 1u];
    for (var j = offsets[v]; j < end; j += 4u) {
        let last = end - 1u;
        let k = vec4<u32>(j, min(j + 1u, last), min(j + 2u, last), min(j + 3u, last));
        let w = vec4<f32>(weights[k.x], weights[k.y], weights[k.z], weights[k.w]);
        let b0 = element_value(elements[k.x]);
        let b1 = element_value(elements[k.y]);
        let b2 = element_value(elements[k.z]);
        let b3 = element_value(elements[k.w]);
        let zero = vec3<f32>(0.0);
        sum = sum + w.x * b0;
        sum = sum + select(zero, w.y * b1, j + 1u < end);
        sum = sum + select(zero, w.z * b2, j + 2u < end);
        sum = sum + select(zero, w.w * b3, j + 3u < end);
    }
    // Boundary vertices extrapolate (negative weights): never below zero.
    sum = max(sum, vec3<f32>(0.0));
    vertex_values[3u * v] = sum.x;
    vertex_values[3u * v + 1u] = sum.y;
    vertex_values[3u * v + 2u] = sum.z;
}
