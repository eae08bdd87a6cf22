// light_groups.wgsl: a frame given per-group intensities a_g instead of an emission
// (DESIGN.md §2, "Light groups"). Two entry points, dispatched in this order, replacing
// segment_sums:
//   group_sums:     X[c][p] = sum over g of a_g * x_g[c][p], from the groups' stored Vᵀ E_g;
//   group_emission: E[order[s]][c] = sum over the groups g lighting s of a_g * E_g(s)[c], for
//                   the distinct positions s some group lights. The other elements of this E
//                   buffer stay zero (written once at creation), so the gather reads it as any
//                   emission.
// CPU mirrors: `lrr_shaders::cpu::group_sums`, `lrr_shaders::cpu::group_emission`.
//
// Indices: t < 3 KP and u < positions are checked below; group_x has groups * 3 * KP entries;
// the host builds starts (positions + 1 offsets, non-decreasing, last = entries), members
// (< groups), position (< n, from the validated file) and member_emission (3 per entry).

// groups intensities a_g (finite, >= 0: checked by the host).
@group(0) @binding(1) var<storage, read> intensities: array<f32>;
// groups x 3 planes of KP: x_g = Vᵀ E_g.
@group(0) @binding(2) var<storage, read> group_x: array<f32>;
// Distinct lit file positions, increasing.
@group(0) @binding(3) var<storage, read> position: array<u32>;
// positions + 1 offsets into members: position u is lit by members[starts[u] .. starts[u+1]].
@group(0) @binding(4) var<storage, read> starts: array<u32>;
// The group of each (position, group) entry.
@group(0) @binding(5) var<storage, read> members: array<u32>;
// RGB exitance at intensity 1 of each entry.
@group(0) @binding(6) var<storage, read> member_emission: array<f32>;
// n file position -> original id.
@group(0) @binding(7) var<storage, read> order: array<u32>;
// 3 planes of KP: output X.
@group(0) @binding(8) var<storage, read_write> x: array<f32>;
// n x 3 emission, original id order: group_emission writes the lit elements.
@group(0) @binding(9) var<storage, read_write> emission: array<f32>;

@compute @workgroup_size(LANES)
fn group_sums(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let t = id.y * groups.x * LANES + id.x;
    if t >= 3u * KP {
        return;
    }
    var sum = 0.0;
    for (var g = 0u; g < params.groups; g = g + 1u) {
        sum = sum + intensities[g] * group_x[g * 3u * KP + t];
    }
    x[t] = sum;
}

@compute @workgroup_size(LANES)
fn group_emission(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let u = id.y * groups.x * LANES + id.x;
    if u >= params.positions {
        return;
    }
    var sum = vec3<f32>(0.0);
    for (var m = starts[u]; m < starts[u + 1u]; m = m + 1u) {
        let e = vec3<f32>(member_emission[3u * m], member_emission[3u * m + 1u], member_emission[3u * m + 2u]);
        sum = sum + intensities[members[m]] * e;
    }
    let i = 3u * order[position[u]];
    emission[i] = sum.x;
    emission[i + 1u] = sum.y;
    emission[i + 2u] = sum.z;
}
