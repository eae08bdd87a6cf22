// fk_f16_bits.wgsl: the stored matrix in binary16 widened with integer operations, for
// adapters with neither native f16 nor SHADER_F16_IN_F32 (Mesa's llvmpipe grants the latter
// only with the former), for gather.wgsl. Entry 2 m is the low half of word m.

// A chunk of whole rows of KP entries, 8 halves (16 bytes) per element.
@group(0) @binding(1) var<storage, read> fk: array<vec4<u32>>;

// The f32 with the value of the binary16 bits `h` (low 16 bits), exactly. A binary16
// subnormal (mantissa * 2^-24) is a normal f32, so no flush-to-zero mode can touch it.
// CPU twin: `lrr_formats::f16_to_f32` (the same values, computed differently).
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

fn halves(w: u32) -> vec2<f32> {
    return vec2<f32>(f16_to_f32(w & 0xFFFFu), f16_to_f32(w >> 16u));
}

// Entries 8 i .. 8 i + 7 of the bound chunk: one 16-byte load.
fn load_octet(i: u32) -> mat2x4<f32> {
    let w = fk[i];
    return mat2x4<f32>(vec4<f32>(halves(w.x), halves(w.y)), vec4<f32>(halves(w.z), halves(w.w)));
}
