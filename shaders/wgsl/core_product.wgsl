// core_product.wgsl: Z_c = M_c X_c for the three channels c, with M_c the k x k cores
// (I_k - Vᵀ diag(rho_c) F_k)^-1 in f32, each in its own buffer as k rows of KP entries (zero
// padding). A grey operator has one core: the host binds it three times.
//     Z[c][p] = sum over q of M_c[p][q] * X[c][q]
// One workgroup per row p; lane l sums the vec4 groups j = l, l + LANES, ... of the row (four
// entries each), then `reduce_lanes`.
// CPU mirror: `lrr_shaders::cpu::core_product`. Needs common.wgsl.
//
// Indices: p < k (checked below), j < KP / 4: every load is inside the k * KP / 4 vec4s of a
// core and the 3 KP / 4 of X, as the host sizes them.

// k x KP core of each channel, row-major.
@group(0) @binding(1) var<storage, read> core_r: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> core_g: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> core_b: array<vec4<f32>>;
// 3 planes of KP: input X (from segment_sums or group_sums).
@group(0) @binding(4) var<storage, read> x: array<vec4<f32>>;
// 3 planes of KP: output Z.
@group(0) @binding(5) var<storage, read_write> z: array<f32>;

@compute @workgroup_size(LANES)
fn core_product(
    @builtin(local_invocation_index) lane: u32,
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let p = group_index(group, groups);
    if p >= params.k {
        return;
    }
    let quads = KP / 4u;
    let row = p * quads;
    var sum = vec3<f32>(0.0);
    for (var j = lane; j < quads; j = j + LANES) {
        sum = sum + vec3<f32>(
            dot(core_r[row + j], x[j]),
            dot(core_g[row + j], x[quads + j]),
            dot(core_b[row + j], x[2u * quads + j]),
        );
    }
    let total = reduce_lanes(lane, sum);
    if lane == 0u {
        z[p] = total.x;
        z[KP + p] = total.y;
        z[2u * KP + p] = total.z;
    }
}
