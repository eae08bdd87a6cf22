// segment_sums.wgsl: X = Vᵀ E with a sparse V, the weighted emission of every patch:
//     X[p][c] = sum over s in I[p] .. I[p+1]-1 of w[s] * E[s][c]
// Elements are in file order (sorted by patch), so patch p's elements are the segment
// I[p] .. I[p+1] of the index vector. One workgroup per patch; lane l sums s = I[p] + l,
// I[p] + l + LANES, ..., then `reduce_lanes` adds the lanes.
// CPU mirror: `lrr_shaders::cpu::segment_sums`. Needs common.wgsl in front.

// k + 1 offsets into the elements, non-decreasing, index[k] = n.
@group(0) @binding(1) var<storage, read> index: array<u32>;
// n weights w[s] = A_s / A_P(s), file order.
@group(0) @binding(2) var<storage, read> weights: array<f32>;
// n x 3 emission E, file order.
@group(0) @binding(3) var<storage, read> emission: array<f32>;
// k x 3 output X.
@group(0) @binding(4) var<storage, read_write> x: array<f32>;

@compute @workgroup_size(LANES)
fn segment_sums(
    @builtin(local_invocation_index) lane: u32,
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let p = group_index(group, groups);
    if p >= params.k {
        return;
    }
    let end = index[p + 1u];
    var sum = vec3<f32>(0.0);
    for (var s = index[p] + lane; s < end; s = s + LANES) {
        let e = vec3<f32>(emission[3u * s], emission[3u * s + 1u], emission[3u * s + 2u]);
        sum = sum + weights[s] * e;
    }
    let total = reduce_lanes(lane, sum);
    if lane == 0u {
        x[3u * p] = total.x;
        x[3u * p + 1u] = total.y;
        x[3u * p + 2u] = total.z;
    }
}
