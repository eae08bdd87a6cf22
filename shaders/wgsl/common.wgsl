// common.wgsl: what every pass shares. `lrr_shaders::source` (shaders/src/lib.rs) concatenates
// this file in front of each pass, so the passes use these items without declaring them.
//
// Buffers hold per-element and per-patch RGB as 3 consecutive f32 (element s at 3s, 3s+1, 3s+2),
// never `array<vec3<f32>>` (16-byte stride): the file's reflectance and the caller's `[[f32; 3]]`
// upload as they are.

// The per-dispatch uniform, binding 0 of every pass.
// Mirrored by the Rust struct `lrr_shaders::Params` (shaders/src/params.rs): same fields in the
// same order, 32 bytes. A test (shaders/src/naga_tests.rs) parses this struct with naga and
// compares names, offsets and size.
struct Params {
    // Elements (rows of F_k, entries of E, rho and B).
    n: u32,
    // Patches (columns of F_k, rows of the k x k cores, entries of X and Z).
    k: u32,
    // Number of k x k cores: 1 (one core serves all three channels) or 3 (one per channel);
    // core_product reads any other value as 1.
    channels: u32,
    // gather: first element (row of F_k) this dispatch computes.
    row_offset: u32,
    // gather: number of rows this dispatch computes, from row_offset on.
    row_count: u32,
    // gather: index, in the bound F_k view, of the first entry of row row_offset. F_k may be
    // bound in row chunks (lavapipe binds at most 128 MiB per storage buffer) at any offset the
    // device allows; this says where the chunk's first row starts inside that binding.
    fk_offset: u32,
    // Zero; keeps the struct a multiple of 16 bytes for every backend's uniform rules.
    reserved0: u32,
    reserved1: u32,
}

// Invocations per workgroup: the lanes that share one patch or one row. Mirrored by
// `lrr_shaders::LANES`; the CPU mirrors (shaders/src/cpu.rs) reduce in this same lane order.
const LANES: u32 = 64u;

@group(0) @binding(0) var<uniform> params: Params;

var<workgroup> partial: array<vec3<f32>, LANES>;

// Linear workgroup index over a 2D grid: at most 65535 workgroups per dimension, so a dispatch
// of more groups spreads over y (`lrr_shaders::workgroups`); groups past the end return at once.
fn group_index(group: vec3<u32>, groups: vec3<u32>) -> u32 {
    return group.y * groups.x + group.x;
}

// Sum of `value` over the workgroup's lanes, returned to every lane. Lane l's value goes to
// slot l, then a binary tree halves the live slots: strides 32, 16, ..., 1. Must be called in
// uniform control flow (it holds barriers).
fn reduce_lanes(lane: u32, value: vec3<f32>) -> vec3<f32> {
    partial[lane] = value;
    workgroupBarrier();
    for (var stride = LANES / 2u; stride > 0u; stride = stride / 2u) {
        if lane < stride {
            partial[lane] = partial[lane] + partial[lane + stride];
        }
        workgroupBarrier();
    }
    let total = partial[0];
    // Lets a later call overwrite `partial` only after every lane has read the total.
    workgroupBarrier();
    return total;
}

