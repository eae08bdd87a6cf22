// segment_sums.wgsl: X = Vᵀ E with a sparse V, the weighted emission of every patch:
//     X[c][p] = sum over s in I[p] .. I[p+1]-1 of w[s] * E[order[s]][c]
// Elements are in file order (sorted by patch), so patch p's elements are the segment
// I[p] .. I[p+1] of the index vector; the emission arrives in original id order and is read
// through `order` (file position -> id). One workgroup per patch; lane l sums s = I[p] + l,
// I[p] + l + LANES, ..., then `reduce_lanes` adds the lanes.
// CPU mirror: `lrr_shaders::cpu::segment_sums`. Needs common.wgsl.
//
// Indices, all proven by the operator file's validation (lrr_formats::OperatorFile::validate)
// and the host's buffer sizes, so the runtime may build this pass without bounds checks:
// p < k (checked below); index has k + 1 entries, non-decreasing, index[k] = n, so s < n;
// order is a permutation of 0 .. n - 1; emission has 3 n entries; x has 3 KP entries, KP >= k.

// k + 1 offsets into the elements, non-decreasing, index[k] = n.
@group(0) @binding(1) var<storage, read> index: array<u32>;
// n weights w[s] = A_s / A_P(s), file order.
@group(0) @binding(2) var<storage, read> weights: array<f32>;
// n file position -> original id.
@group(0) @binding(3) var<storage, read> order: array<u32>;
// n x 3 emission E, original id order.
@group(0) @binding(4) var<storage, read> emission: array<f32>;
// 3 planes of KP: output X.
@group(0) @binding(5) var<storage, read_write> x: array<f32>;

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
        let i = 3u * order[s];
        sum = sum + weights[s] * vec3<f32>(emission[i], emission[i + 1u], emission[i + 2u]);
    }
    let total = reduce_lanes(lane, sum);
    if lane == 0u {
        x[p] = total.x;
        x[KP + p] = total.y;
        x[2u * KP + p] = total.z;
    }
}
