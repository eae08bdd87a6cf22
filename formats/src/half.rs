//! IEEE 754 binary16 ("half") <-> f32, hand-written.
//!
//! binary16: 1 sign bit, 5 exponent bits (bias 15), 10 mantissa bits. Largest finite 65504,
//! smallest normal 2⁻¹⁴ ≈ 6.10e-5, smallest subnormal 2⁻²⁴ ≈ 5.96e-8. Every f16 is exactly an
//! f32, so [`f16_to_f32`] is exact and `f32_to_f16(f16_to_f32(h)) == h` for all 65536 values,
//! NaN payloads included. [`f32_to_f16`] rounds to nearest, ties to even, like a hardware
//! `vcvtps2ph` with the default rounding mode: overflow goes to ±inf, underflow to ±0 through the
//! subnormals.

/// Rounds `x` to the nearest binary16 (ties to even) and returns its bits.
///
/// ```
/// use lrr_formats::{f16_to_f32, f32_to_f16};
/// assert_eq!(f32_to_f16(1.0), 0x3C00);
/// assert_eq!(f32_to_f16(65504.0), 0x7BFF); // largest finite
/// assert_eq!(f32_to_f16(65520.0), 0x7C00); // rounds up to +inf
/// assert_eq!(f16_to_f32(f32_to_f16(0.1)), 0.099975586);
/// ```
pub fn f32_to_f16(x: f32) -> u16 {
    let bits = x.to_bits();
    let sign = ((bits >> 16) & 0x8000) as u16;
    let exp = ((bits >> 23) & 0xFF) as i32;
    let man = bits & 0x007F_FFFF;

    if exp == 0xFF {
        // Inf stays inf; NaN keeps the top 10 payload bits and stays a NaN (never becomes inf).
        let payload = (man >> 13) as u16;
        let nan_bit = if man != 0 && payload == 0 { 0x0200 } else { 0 };
        return sign | 0x7C00 | payload | nan_bit;
    }
    let e = exp - 127; // unbiased; f32 zeros and subnormals land far below -25
    if e > 15 {
        return sign | 0x7C00;
    }
    if e >= -14 {
        // Normal: drop 13 mantissa bits. A carry out of the mantissa bumps the exponent, which
        // is exactly right, up to 0x7C00 (inf) for values >= 65520.
        let h = (((e + 15) as u32) << 10) | (man >> 13);
        return sign | round_shifted(h, man, 13) as u16;
    }
    if e < -25 {
        return sign; // below half the smallest subnormal: ±0
    }
    // Subnormal: value = full * 2^(e-23) = h * 2^-24, so h = full >> (-e - 1), shift in 14..=24.
    let full = man | 0x0080_0000;
    let shift = (-e - 1) as u32;
    sign | round_shifted(full >> shift, full, shift) as u16
}

/// Rounds `kept = value >> shift` to nearest, ties to even, looking at the `shift` dropped bits.
fn round_shifted(kept: u32, value: u32, shift: u32) -> u32 {
    let dropped = value & ((1 << shift) - 1);
    let half = 1 << (shift - 1);
    if dropped > half || (dropped == half && kept & 1 == 1) {
        kept + 1
    } else {
        kept
    }
}

/// The f32 with the same value as the binary16 `h` (exact).
pub fn f16_to_f32(h: u16) -> f32 {
    let sign = u32::from(h & 0x8000) << 16;
    let exp = u32::from((h >> 10) & 0x1F);
    let man = u32::from(h & 0x03FF);
    let bits = match (exp, man) {
        (0, 0) => sign,
        (0, _) => {
            // Subnormal man * 2^-24: normalise so the leading one becomes the implicit bit.
            let lead = 31 - man.leading_zeros(); // 0..=9
            let frac = (man << (10 - lead)) & 0x03FF;
            sign | ((lead + 103) << 23) | (frac << 13)
        }
        (0x1F, _) => sign | 0x7F80_0000 | (man << 13),
        _ => sign | ((exp + 112) << 23) | (man << 13),
    };
    f32::from_bits(bits)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_f16_round_trips() {
        for h in 0..=u16::MAX {
            let x = f16_to_f32(h);
            let back = f32_to_f16(x);
            if x.is_nan() {
                assert!(f16_to_f32(back).is_nan(), "{h:#06x} lost its NaN");
            }
            assert_eq!(back, h, "{h:#06x} -> {x:e} -> {back:#06x}");
        }
    }

    #[test]
    fn decodes_against_the_formula() {
        for h in 0..=u16::MAX {
            let exp = i32::from((h >> 10) & 0x1F);
            let man = f64::from(h & 0x3FF);
            let magnitude = match exp {
                0 => man * 2f64.powi(-24),
                31 => continue,
                _ => (1.0 + man / 1024.0) * 2f64.powi(exp - 15),
            };
            let expected = if h & 0x8000 != 0 {
                -magnitude
            } else {
                magnitude
            };
            assert_eq!(f64::from(f16_to_f32(h)), expected, "{h:#06x}");
        }
    }

    #[test]
    fn known_values() {
        let cases: &[(f32, u16)] = &[
            (0.0, 0x0000),
            (-0.0, 0x8000),
            (1.0, 0x3C00),
            (-2.0, 0xC000),
            (0.5, 0x3800),
            (65504.0, 0x7BFF),
            (65519.996, 0x7BFF),
            (65520.0, 0x7C00),
            (1e9, 0x7C00),
            (-1e9, 0xFC00),
            (f32::INFINITY, 0x7C00),
            (f32::NEG_INFINITY, 0xFC00),
            (f32::MAX, 0x7C00),
            (6.103_515_6e-5, 0x0400),     // smallest normal 2^-14
            (5.960_464_5e-8, 0x0001),     // smallest subnormal 2^-24
            (1.0 / 33_554_432.0, 0x0000), // exactly 2^-25: tie, to even (0)
            (2.980_233e-8, 0x0001),       // just above the tie
            (1.5 / 16_777_216.0, 0x0002), // 1.5 * 2^-24: tie, to even (2)
            (2.5 / 16_777_216.0, 0x0002), // 2.5 * 2^-24: tie, to even (2)
            (f32::MIN_POSITIVE, 0x0000),
            (1e-45, 0x0000), // f32 subnormal
            (-1e-45, 0x8000),
            (1.0 + 1.0 / 2048.0, 0x3C00), // 1 + 2^-11: tie, to even (1.0)
            (1.0 + 3.0 / 2048.0, 0x3C02), // 1 + 3 * 2^-11: tie, to even (1 + 2^-9)
            (1.000_488_4, 0x3C01),        // just above the tie
            (2048.0, 0x6800),
            (2049.0, 0x6800), // tie between 2048 and 2050: to even
            (2051.0, 0x6802), // tie between 2050 and 2052: to even
            (0.1, 0x2E66),
            (-0.333_333_34, 0xB555),
            (6.097_555e-5, 0x03FF), // largest subnormal
        ];
        for &(x, h) in cases {
            assert_eq!(f32_to_f16(x), h, "{x:e} should give {h:#06x}");
        }
    }

    #[test]
    fn nan_stays_nan() {
        for bits in [
            0x7FC0_0000u32,
            0x7F80_0001,
            0xFF80_1000,
            0x7FFF_FFFF,
            0x7FA0_0000,
        ] {
            let h = f32_to_f16(f32::from_bits(bits));
            assert_eq!(h & 0x7C00, 0x7C00);
            assert_ne!(h & 0x03FF, 0, "{bits:#010x} became inf");
            assert_eq!(h & 0x8000 != 0, bits >> 31 == 1);
        }
    }

    #[test]
    fn rounding_matches_f64_reference() {
        // Round-to-nearest-even checked against exact arithmetic on a spread of f32 values.
        let mut x = 1u32;
        for _ in 0..200_000 {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let v = f32::from_bits(x);
            if !v.is_finite() {
                continue;
            }
            let h = f32_to_f16(v);
            let got = f64::from(f16_to_f32(h));
            let exact = f64::from(v);
            if got.is_infinite() {
                assert!(exact.abs() >= 65520.0, "{v:e}");
                continue;
            }
            // No other f16 may be strictly closer.
            for neighbour in [h.wrapping_sub(1), h.wrapping_add(1), h ^ 0x8000] {
                let n = f64::from(f16_to_f32(neighbour));
                if n.is_finite() {
                    assert!((n - exact).abs() >= (got - exact).abs(), "{v:e}: {h:#06x}");
                }
            }
        }
    }
}
