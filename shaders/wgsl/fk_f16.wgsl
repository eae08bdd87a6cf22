// fk_f16.wgsl: F_k stored as IEEE binary16, for gather.wgsl (concatenated between common.wgsl
// and it). The other storage, with the same binding and `load_fk`: fk_f32.wgsl.
//
// Storage buffers hold 32-bit words, and WGSL's f16 type needs `enable f16;` (shader-f16, not
// on every adapter), so the halves travel packed two per u32: entry 2j in the low 16 bits of
// word j, entry 2j + 1 in the high 16 bits. That is the file's little-endian u16 array read as
// u32 words (padded with a zero half when the count is odd).
//
// Widened with integer operations, not `unpack2x16float`: naga accepts that builtin only with
// the SHADER_FLOAT16_IN_FLOAT32 capability, which wgpu grants from
// DownlevelFlags::SHADER_F16_IN_F32, documented as missing on Mesa's Vulkan drivers (lavapipe
// included) without shader-f16. The gather is bound by memory traffic; a few integer operations
// per entry cost nothing there.

// A view of n x k row-major F_k as packed halves: all of it, or a chunk of rows starting at a
// whole word (see Params.fk_offset, which counts halves, not words).
@group(0) @binding(1) var<storage, read> fk: array<u32>;

// The f32 with the value of the binary16 bits `h` (low 16 bits), exactly. A binary16
// subnormal (mantissa * 2^-24) is a normal f32, so no flush-to-zero mode can touch it.
// CPU mirror: `lrr_shaders::cpu::f16_to_f32`.
fn f16_to_f32(h: u32) -> f32 {
    let sign = (h & 0x8000u) << 16u;
    let exponent = (h >> 10u) & 0x1Fu;
    let mantissa = h & 0x3FFu;
    if exponent == 0u {
        // Zero or subnormal.
        return bitcast<f32>(sign | bitcast<u32>(f32(mantissa) * 0x1p-24f));
    }
    // Normal: rebias 15 -> 127; infinity and NaN: all-ones exponent.
    let biased = select(exponent + 112u, 255u, exponent == 31u);
    return bitcast<f32>(sign | (biased << 23u) | (mantissa << 13u));
}

// Entry `i` (in halves) of the bound view.
fn load_fk(i: u32) -> f32 {
    let word = fk[i >> 1u];
    return f16_to_f32((word >> (16u * (i & 1u))) & 0xFFFFu);
}
