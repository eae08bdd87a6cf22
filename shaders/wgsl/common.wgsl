// common.wgsl: what every pass shares. `lrr_shaders::source` (shaders/src/lib.rs) concatenates
// this file with each pass's own files, so the passes use these items without declaring them.
//
// Layouts (all in little-endian 32-bit words):
// - per element RGB (emission E, radiosity B): 3 consecutive f32 per element, ORIGINAL id order
//   (what the caller's `[[f32; 3]]` holds), element i at 3i, 3i+1, 3i+2;
// - reflectance rho: 3 f32 per element, FILE order (sorted by patch, as the operator file);
// - per patch (X, Z, light-group sums): three planes of KP f32, channel c at c * KP, entries
//   k..KP zero, so a vec4 load of a plane never needs a tail;
// - stored matrices (F_k, plain Y_k blocks, cores): rows of KP entries (k values, zero padding),
//   f32 or binary16, split into chunks of whole rows that each fit one binding.

// The per-dispatch uniform, binding 0 of every pass. Mirrored by the Rust struct
// `lrr_shaders::Params` (shaders/src/params.rs): same fields in the same order, 32 bytes. A test
// (shaders/src/naga_tests.rs) lays this struct out with naga and compares names, offsets and
// size with the Rust struct's `offset_of!`.
struct Params {
    // Elements: rows of F_k, entries of E, rho and B.
    n: u32,
    // Patches: columns of F_k, rows of the cores, entries of X and Z.
    k: u32,
    // gather, core_product: first stored row of the chunk bound to this dispatch (rows of the
    // plain RGB Y_k run over the three blocks, block c holding rows c n .. c n + n - 1).
    first_row: u32,
    // gather, core_product: rows in that chunk.
    row_count: u32,
    // group_sums, group_emission: light groups.
    groups: u32,
    // group_emission: distinct file positions lit by some group.
    positions: u32,
    // Zero; keep the struct a multiple of 16 bytes for every backend's uniform rules.
    reserved0: u32,
    reserved1: u32,
}

// Padded row length of every stored matrix and plane stride of X and Z (a multiple of 8, at
// least k): a pipeline constant. `lrr_shaders::padded_k` computes it.
override KP: u32 = 8u;

// Invocations per workgroup in segment_sums, core_product and the light-group passes: the lanes
// that share one patch or one row. Mirrored by `lrr_shaders::LANES`.
const LANES: u32 = 64u;

@group(0) @binding(0) var<uniform> params: Params;

var<workgroup> partial: array<vec3<f32>, LANES>;

// Linear workgroup index over a 2D grid: at most 65535 workgroups per dimension, so a dispatch
// of more groups spreads over y (`lrr_shaders::workgroups`); groups past the end return at once.
fn group_index(group: vec3<u32>, groups: vec3<u32>) -> u32 {
    return group.y * groups.x + group.x;
}

// Sum of `value` over the LANES lanes of the workgroup, returned to every lane. Lane l's value
// goes to slot l, then a binary tree halves the live slots: strides 32, 16, ..., 1. Must be
// called in uniform control flow (it holds barriers). CPU mirror: `cpu::reduce_lanes`.
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
