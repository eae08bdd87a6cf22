//! IEEE 754 binary16 for the packed `F_k`: packing on the host, widening as the shader does.
//!
//! binary16: 1 sign bit, 5 exponent bits (bias 15), 10 mantissa bits. Every binary16 value is
//! exactly an f32, so widening never rounds.

/// Packs binary16 bits two per `u32` the way [`Pass::GatherF16`](crate::Pass::GatherF16) reads
/// them: entry `2j` in the low 16 bits of word `j`, entry `2j + 1` in the high 16 bits, a zero
/// half after an odd count. On a little-endian host these words have the bytes of the `u16`
/// array itself (plus the padding), so a file's binary16 `F_k` can also be uploaded as is.
///
/// ```
/// assert_eq!(lrr_shaders::pack_f16(&[0x3C00, 0x4000, 0xBC00]), [0x4000_3C00, 0x0000_BC00]);
/// ```
pub fn pack_f16(halves: &[u16]) -> Vec<u32> {
    halves
        .chunks(2)
        .map(|pair| u32::from(pair[0]) | u32::from(pair.get(1).copied().unwrap_or(0)) << 16)
        .collect()
}

/// Mirror of `f16_to_f32` in `wgsl/fk_f16.wgsl`: the f32 with the value of the binary16 `h`,
/// exactly (subnormals are normal f32s; NaN stays NaN, its payload moved to the top bits).
pub fn f16_to_f32(h: u16) -> f32 {
    let h = u32::from(h);
    let sign = (h & 0x8000) << 16;
    let exponent = (h >> 10) & 0x1F;
    let mantissa = h & 0x3FF;
    if exponent == 0 {
        // Zero or subnormal: mantissa · 2⁻²⁴.
        return f32::from_bits(sign | (mantissa as f32 * 2f32.powi(-24)).to_bits());
    }
    // Normal: rebias 15 → 127; infinity and NaN: all-ones exponent.
    let biased = if exponent == 31 { 255 } else { exponent + 112 };
    f32::from_bits(sign | biased << 23 | mantissa << 13)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_values_widen_exactly() {
        let cases: [(u16, f32); 11] = [
            (0x0000, 0.0),
            (0x3C00, 1.0),
            (0xC000, -2.0),
            (0x3555, 0.333_251_95),
            (0x7BFF, 65504.0),
            (0x0400, 2f32.powi(-14)),          // smallest normal
            (0x03FF, 1023.0 * 2f32.powi(-24)), // largest subnormal
            (0x0001, 2f32.powi(-24)),          // smallest subnormal
            (0x8001, -(2f32.powi(-24))),
            (0x7C00, f32::INFINITY),
            (0xFC00, f32::NEG_INFINITY),
        ];
        for (h, want) in cases {
            assert_eq!(f16_to_f32(h).to_bits(), want.to_bits(), "{h:#06x}");
        }
        assert_eq!(f16_to_f32(0x8000).to_bits(), (-0.0f32).to_bits());
        assert!(f16_to_f32(0x7E00).is_nan() && f16_to_f32(0xFC01).is_nan());
    }

    #[test]
    fn positive_finite_values_increase_and_negatives_mirror_them() {
        for h in 0..0x7BFFu16 {
            assert!(f16_to_f32(h) < f16_to_f32(h + 1), "{h:#06x}");
            assert_eq!(f16_to_f32(h | 0x8000), -f16_to_f32(h), "{h:#06x}");
        }
    }

    #[test]
    fn packing_puts_even_entries_low() {
        assert_eq!(pack_f16(&[]), Vec::<u32>::new());
        assert_eq!(pack_f16(&[0x1234]), [0x0000_1234]);
        assert_eq!(pack_f16(&[0x1234, 0xABCD]), [0xABCD_1234]);
        let halves: Vec<u16> = (0..7).map(|i| 0x3C00 + i).collect();
        let words = pack_f16(&halves);
        let bytes: Vec<u8> = halves.iter().flat_map(|h| h.to_le_bytes()).collect();
        let from_bytes: Vec<u32> = bytes
            .chunks(4)
            .map(|c| {
                let mut w = [0u8; 4];
                w[..c.len()].copy_from_slice(c);
                u32::from_le_bytes(w)
            })
            .collect();
        assert_eq!(
            words, from_bytes,
            "the file's LE u16 bytes are the packed words"
        );
    }
}
