// read.wgsl (entry point read_matrix): the read roofline of the gather, not a step of a frame: every 16 bytes of a
// bound chunk of the stored matrix loaded once, in the gather's grid-stride pattern, and
// XOR-folded so that no load can be dropped (the one store happens only when the fold equals a
// value the data practically never gives). The runtime's benchmark reports the gather's time
// as a fraction of this pass's over the same bytes. CPU mirror: `lrr_shaders::cpu::read_matrix`.
// Needs common.wgsl (for the shared declarations only).
//
// Indices: i + u * stride < arrayLength(&fk), checked in the loops.

// A chunk of the stored matrix, any precision, as 16-byte words.
@group(0) @binding(1) var<storage, read> fk: array<vec4<u32>>;
// Written only when the fold is 0x9E3779B9.
@group(0) @binding(2) var<storage, read_write> sink: array<u32>;

// Loads per thread and iteration: 1, or 4 independent loads (rows of the grid stride apart) in
// flight before the fold uses them. The runtime builds both and its benchmark takes the faster
// as the roofline.
override READ_UNROLL: u32 = 1u;

@compute @workgroup_size(LANES)
fn read_matrix(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    var acc = vec4<u32>(0u);
    let count = arrayLength(&fk);
    let stride = groups.x * LANES;
    var i = id.x;
    // count < 2^28 and stride < 2^22: no overflow.
    for (; i + (READ_UNROLL - 1u) * stride < count; i = i + READ_UNROLL * stride) {
        for (var u = 0u; u < READ_UNROLL; u = u + 1u) {
            acc = acc ^ fk[i + u * stride];
        }
    }
    for (; i < count; i = i + stride) {
        acc = acc ^ fk[i];
    }
    let folded = acc.x ^ acc.y ^ acc.z ^ acc.w;
    if folded == 0x9E3779B9u {
        sink[0] = folded;
    }
}
