// core_product.wgsl: Z_c = M_c X_c for the three channels c, with M_c the k x k cores
// (I_k - Vᵀ diag(rho_c) F_k)^-1 in f32, row-major, core c at c * k * k. With
// params.channels == 1 the single core serves all three channels.
//     Z[p][c] = sum over q of M_c[p][q] * X[q][c]
// One workgroup per row p; lane l sums q = l, l + LANES, ..., then `reduce_lanes`.
// CPU mirror: `lrr_shaders::cpu::core_product`. Needs common.wgsl in front.

// channels x k x k cores, row-major.
@group(0) @binding(1) var<storage, read> cores: array<f32>;
// k x 3 input X (from segment_sums).
@group(0) @binding(2) var<storage, read> x: array<f32>;
// k x 3 output Z.
@group(0) @binding(3) var<storage, read_write> z: array<f32>;

@compute @workgroup_size(LANES)
fn core_product(
    @builtin(local_invocation_index) lane: u32,
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let p = group_index(group, groups);
    let k = params.k;
    if p >= k {
        return;
    }
    // Distance between the cores of consecutive channels: 0 when one core serves all three.
    let core_stride = select(0u, k * k, params.channels == 3u);
    var sum = vec3<f32>(0.0);
    for (var q = lane; q < k; q = q + LANES) {
        let i = p * k + q;
        let m = vec3<f32>(cores[i], cores[i + core_stride], cores[i + 2u * core_stride]);
        sum = sum + m * vec3<f32>(x[3u * q], x[3u * q + 1u], x[3u * q + 2u]);
    }
    let total = reduce_lanes(lane, sum);
    if lane == 0u {
        z[3u * p] = total.x;
        z[3u * p + 1u] = total.y;
        z[3u * p + 2u] = total.z;
    }
}
