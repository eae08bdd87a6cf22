//! Step 3 of a frame for one block of rows: the gather `W = M z` over the stored matrix (`F_k`,
//! or the channel blocks of `Y_k`), and the memory-read roofline that reads the same bytes. The
//! pool's threads (`pool.rs`) run these per chunk; the other steps are in `frame.rs`.

use std::ops::Range;

use lrr_formats::{OperatorData, OperatorFile, StoredMatrix};

use crate::kernel::{self, Gather, Rows, SimdLevel};

/// The rows `rows` of the stored matrix of channel block `c` (plain RGB) or of the only block.
fn block<'a>(m: &'a StoredMatrix, n: usize, k: usize, c: usize, rows: &Range<usize>) -> Rows<'a> {
    let (start, end) = ((c * n + rows.start) * k, (c * n + rows.end) * k);
    match m {
        StoredMatrix::F32(v) => Rows::F32(&v[start..end]),
        StoredMatrix::F16(v) => Rows::F16(&v[start..end]),
    }
}

/// Step 3 for the rows `rows`: `w[3 (s - rows.start) + c] = W_c(s)`. One pass over the rows
/// for all channels (factored, or plain grey); three passes over three matrices for plain RGB.
pub(crate) fn gather_rows(
    file: &OperatorFile,
    rows: Range<usize>,
    z: &[f32],
    kp: usize,
    w: &mut [f32],
    simd: SimdLevel,
) {
    let (n, k) = (file.n as usize, file.k as usize);
    let matrix = file.operator.matrix();
    let three_blocks = matches!(file.operator, OperatorData::PlainYk { .. }) && file.channels == 3;
    if three_blocks {
        for c in 0..3 {
            let g = Gather {
                m: block(matrix, n, k, c, &rows),
                k,
                z: &z[c * kp..],
                kp,
                offset: c,
            };
            kernel::gather::<1>(simd, &g, w);
        }
    } else {
        let g = Gather {
            m: block(matrix, n, k, 0, &rows),
            k,
            z,
            kp,
            offset: 0,
        };
        kernel::gather::<3>(simd, &g, w);
    }
}

/// The memory-read roofline of [`gather_rows`]: reads the same bytes, returns a sum of them.
pub(crate) fn read_rows(file: &OperatorFile, rows: Range<usize>, simd: SimdLevel) -> u64 {
    let (n, k) = (file.n as usize, file.k as usize);
    let blocks = match file.operator {
        OperatorData::PlainYk { .. } => file.channels as usize,
        OperatorData::Factored { .. } => 1,
    };
    (0..blocks)
        .map(|c| kernel::read_sum(simd, block(file.operator.matrix(), n, k, c, &rows)))
        .fold(0, u64::wrapping_add)
}
