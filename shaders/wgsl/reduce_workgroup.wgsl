// reduce_workgroup.wgsl: `row_sum` for gather.wgsl through workgroup memory, for adapters
// without subgroup operations (and selectable for comparison). The other variant:
// reduce_subgroup.wgsl.

var<workgroup> row_partial: array<vec3<f32>, GATHER_SIZE>;

// The sum of `value` over the ROW_LANES lanes of this row (correct in lane 0 of the row): a
// binary tree over the row's slots, strides ROW_LANES / 2, ..., 1. Call in uniform control flow
// (it holds barriers).
fn row_sum(value: vec3<f32>, slot: u32) -> vec3<f32> {
    let lane = slot % ROW_LANES;
    row_partial[slot] = value;
    workgroupBarrier();
    for (var stride = ROW_LANES / 2u; stride > 0u; stride = stride / 2u) {
        if lane < stride {
            row_partial[slot] = row_partial[slot] + row_partial[slot + stride];
        }
        workgroupBarrier();
    }
    let total = row_partial[slot - lane];
    // Lets the next row overwrite `row_partial` only after every lane has read its total.
    workgroupBarrier();
    return total;
}
