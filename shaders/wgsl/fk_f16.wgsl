enable f16;
// fk_f16.wgsl: the stored matrix in binary16 with WGSL's native f16 (adapters with
// wgpu::Features::SHADER_F16), for gather.wgsl. Placed first in the pass's source: the
// `enable` directive must precede every declaration. Entry 2 m is the low half of word m: the
// file's little-endian u16 array read as words.

// A chunk of whole rows of KP entries, 8 halves (16 bytes) per element.
@group(0) @binding(1) var<storage, read> fk: array<mat2x4<f16>>;

// Entries 8 i .. 8 i + 7 of the bound chunk, widened exactly to f32: one 16-byte load.
fn load_octet(i: u32) -> mat2x4<f32> {
    return mat2x4<f32>(fk[i]);
}
