// gather.wgsl: the one pass over F_k, all three channels at once, then the radiosity:
//     W[s][c] = sum over q of F_k[s][q] * Z[q][c]
//     B[s][c] = E[s][c] + rho[s][c] * W[s][c]
// for the rows s = row_offset .. row_offset + row_count. Needs common.wgsl, then fk_f32.wgsl
// or fk_f16.wgsl (binding 1 and `load_fk`), in front.
// One workgroup per row; lane l sums q = l, l + LANES, ..., so a workgroup reads its row of
// F_k in consecutive runs of LANES entries; then `reduce_lanes`.
// CPU mirrors: `lrr_shaders::cpu::gather` and `lrr_shaders::cpu::gather_f16`.

// k x 3 input Z (from core_product).
@group(0) @binding(2) var<storage, read> z: array<f32>;
// n x 3 emission E, file order.
@group(0) @binding(3) var<storage, read> emission: array<f32>;
// n x 3 reflectance rho, file order.
@group(0) @binding(4) var<storage, read> reflectance: array<f32>;
// n x 3 output radiosity B, file order; this dispatch writes rows row_offset .. + row_count.
@group(0) @binding(5) var<storage, read_write> radiosity: array<f32>;

@compute @workgroup_size(LANES)
fn gather(
    @builtin(local_invocation_index) lane: u32,
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let r = group_index(group, groups);
    if r >= params.row_count {
        return;
    }
    let k = params.k;
    let row = params.fk_offset + r * k;
    var sum = vec3<f32>(0.0);
    for (var q = lane; q < k; q = q + LANES) {
        sum = sum + load_fk(row + q) * vec3<f32>(z[3u * q], z[3u * q + 1u], z[3u * q + 2u]);
    }
    let w = reduce_lanes(lane, sum);
    if lane == 0u {
        let s = params.row_offset + r;
        for (var c = 0u; c < 3u; c = c + 1u) {
            radiosity[3u * s + c] = emission[3u * s + c] + reflectance[3u * s + c] * w[c];
        }
    }
}
