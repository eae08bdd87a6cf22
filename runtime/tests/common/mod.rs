//! Shared by the runtime's integration tests.

#![allow(dead_code)] // each test binary uses a different part

use lrr_formats::{OperatorData, OperatorFile, Precision, StoredMatrix};

/// The largest `|got - want| / want` over every element and channel (`want >= 0`: the operators
/// here are physical, every term non-negative).
pub fn worst_relative(got: &[[f32; 3]], want: &[[f64; 3]]) -> f64 {
    assert_eq!(got.len(), want.len());
    let mut worst = 0.0f64;
    for (g, w) in got.iter().zip(want) {
        for c in 0..3 {
            assert!(w[c] >= 0.0, "reference value {} < 0", w[c]);
            let err = (f64::from(g[c]) - w[c]).abs();
            if err > 0.0 {
                worst = worst.max(err / w[c].max(1e-300));
            }
        }
    }
    worst
}

/// `file` with its stored matrix rounded to binary16 (cores unchanged).
pub fn to_f16(file: &OperatorFile) -> OperatorFile {
    let mut out = file.clone();
    out.precision = Precision::F16;
    match &mut out.operator {
        OperatorData::Factored { fk: m, .. } | OperatorData::PlainYk { yk: m } => {
            *m = StoredMatrix::from_f32(&m.to_f32(), Precision::F16);
        }
    }
    out
}

/// A deterministic emission: most elements dark, some lit, values spread over two decades.
pub fn emission(n: usize, seed: u64) -> Vec<[f32; 3]> {
    let mut s = seed | 1;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            if s.is_multiple_of(5) {
                [
                    (s % 97) as f32 / 9.7,
                    (s % 89) as f32 / 0.89,
                    (s % 83) as f32 / 83.0,
                ]
            } else {
                [0.0; 3]
            }
        })
        .collect()
}
