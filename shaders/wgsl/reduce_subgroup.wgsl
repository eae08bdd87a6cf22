// reduce_subgroup.wgsl: `row_sum` for gather.wgsl with subgroup shuffles (adapters with
// wgpu::Features::SUBGROUP; naga 30 takes the builtins without an `enable subgroups;`, which it
// does not parse). The other variant: reduce_workgroup.wgsl.
//
// The ROW_LANES lanes of a row are consecutive invocations (slot / ROW_LANES), and ROW_LANES is
// at most the adapter's smallest subgroup: this assumes a 1D workgroup fills its subgroups in
// invocation order (subgroup_invocation_id = local_invocation_index % subgroup_size), as NVIDIA,
// AMD, Intel and llvmpipe do. The butterfly adds in the order of the workgroup variant's tree
// for lane 0, the lane whose total is used.

// The sum of `value` over the ROW_LANES lanes of this row (correct in lane 0 of the row). Call
// in uniform control flow.
fn row_sum(value: vec3<f32>, slot: u32) -> vec3<f32> {
    var v = value;
    for (var mask = ROW_LANES / 2u; mask > 0u; mask = mask / 2u) {
        v = v + subgroupShuffleXor(v, mask);
    }
    return v;
}
