// fk_f32.wgsl: the stored matrix in f32, for gather.wgsl (binding 1 and `load_octet`). The
// other storages: fk_f16.wgsl (native f16), fk_f16_unpack.wgsl, fk_f16_bits.wgsl.

// A chunk of whole rows of KP entries, as vec4s (two per octet).
@group(0) @binding(1) var<storage, read> fk: array<vec4<f32>>;

// Entries 8 i .. 8 i + 7 of the bound chunk: 32 bytes in two 16-byte loads.
fn load_octet(i: u32) -> mat2x4<f32> {
    return mat2x4<f32>(fk[2u * i], fk[2u * i + 1u]);
}
