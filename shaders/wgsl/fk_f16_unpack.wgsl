// fk_f16_unpack.wgsl: the stored matrix in binary16 widened by `unpack2x16float`, for adapters
// with wgpu::DownlevelFlags::SHADER_F16_IN_F32 (naga's SHADER_FLOAT16_IN_FLOAT32 capability),
// native f16 or not: the runtime's default binary16 loader (on an H100 slightly faster than
// native f16, docs/PERFORMANCE.md), for gather.wgsl. Entry 2 m is the low half of word m.

// A chunk of whole rows of KP entries, 8 halves (16 bytes) per element.
@group(0) @binding(1) var<storage, read> fk: array<vec4<u32>>;

// Entries 8 i .. 8 i + 7 of the bound chunk, widened exactly to f32: one 16-byte load.
fn load_octet(i: u32) -> mat2x4<f32> {
    let w = fk[i];
    return mat2x4<f32>(
        vec4<f32>(unpack2x16float(w.x), unpack2x16float(w.y)),
        vec4<f32>(unpack2x16float(w.z), unpack2x16float(w.w)),
    );
}
