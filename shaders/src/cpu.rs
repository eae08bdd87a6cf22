//! CPU mirrors of the passes, one function per WGSL entry point, with the same name.
//!
//! Plain f32 arithmetic in the shaders' order: every sum is split over [`LANES`] lanes (lane `l`
//! adds terms `l, l + LANES, …` in turn), then the lanes are added by the same binary tree as
//! `reduce_lanes` in `wgsl/common.wgsl`. A GPU result can still differ in the last bits, as a
//! GPU compiler may fuse a multiply and an add into one FMA (one rounding instead of two); the
//! rounding-error bound in the tests below covers both.
//!
//! Buffers are the shaders' (see the crate docs), RGB entries as `[f32; 3]`, all in file order.
//! A buffer too short for [`Params`] is a programming mistake and panics.

use crate::{LANES, Params};

pub use crate::half::f16_to_f32;

/// Mirror of `segment_sums` (`wgsl/segment_sums.wgsl`): `x[p][c] = Σ_{s=I[p]}^{I[p+1]-1} w[s]
/// e[s][c]` for the `params.k` patches.
pub fn segment_sums(
    params: &Params,
    index: &[u32],
    weights: &[f32],
    emission: &[[f32; 3]],
    x: &mut [[f32; 3]],
) {
    let k = params.k as usize;
    for (p, xp) in x[..k].iter_mut().enumerate() {
        let (begin, end) = (index[p] as usize, index[p + 1] as usize);
        *xp = reduce_lanes(end.saturating_sub(begin), |i| {
            let s = begin + i;
            emission[s].map(|e| weights[s] * e)
        });
    }
}

/// Mirror of `core_product` (`wgsl/core_product.wgsl`): `z[p][c] = Σ_q M_c[p][q] x[q][c]`,
/// with `cores` holding `params.channels` (1 or 3) `k × k` row-major matrices; a single core
/// serves all three channels.
pub fn core_product(params: &Params, cores: &[f32], x: &[[f32; 3]], z: &mut [[f32; 3]]) {
    assert!(
        matches!(params.channels, 1 | 3),
        "channels must be 1 or 3, not {}",
        params.channels
    );
    let k = params.k as usize;
    let core_stride = if params.channels == 3 { k * k } else { 0 };
    for (p, zp) in z[..k].iter_mut().enumerate() {
        *zp = reduce_lanes(k, |q| {
            let i = p * k + q;
            let m = [cores[i], cores[i + core_stride], cores[i + 2 * core_stride]];
            [m[0] * x[q][0], m[1] * x[q][1], m[2] * x[q][2]]
        });
    }
}

/// Mirror of `gather` with f32 `F_k` (`wgsl/fk_f32.wgsl` + `wgsl/gather.wgsl`): for the rows
/// `s = row_offset + r`, `r < row_count`, with `fk` the bound view (row `row_offset` at entry
/// `fk_offset`):
///
/// ```text
/// W[s][c] = Σ_q F_k[s][q] z[q][c]        radiosity[s][c] = emission[s][c] + reflectance[s][c] W[s][c]
/// ```
///
/// Rows outside the range are left as they are.
pub fn gather(
    params: &Params,
    fk: &[f32],
    z: &[[f32; 3]],
    emission: &[[f32; 3]],
    reflectance: &[[f32; 3]],
    radiosity: &mut [[f32; 3]],
) {
    gather_with(params, |i| fk[i], z, emission, reflectance, radiosity);
}

/// Mirror of `gather` with binary16 `F_k` (`wgsl/fk_f16.wgsl` + `wgsl/gather.wgsl`): as
/// [`gather`], with entry `i` of the view the binary16 in half `i & 1` of word `fk[i >> 1]`
/// (see [`pack_f16`](crate::pack_f16)), widened by [`f16_to_f32`]. Gives exactly what
/// [`gather`] gives on the widened values.
pub fn gather_f16(
    params: &Params,
    fk: &[u32],
    z: &[[f32; 3]],
    emission: &[[f32; 3]],
    reflectance: &[[f32; 3]],
    radiosity: &mut [[f32; 3]],
) {
    // Mirror of `load_fk` in wgsl/fk_f16.wgsl.
    let load = |i: usize| f16_to_f32((fk[i >> 1] >> (16 * (i & 1))) as u16);
    gather_with(params, load, z, emission, reflectance, radiosity);
}

/// The body of `gather`, with `load_fk` as the storage-specific loader (`wgsl/fk_*.wgsl`).
fn gather_with(
    params: &Params,
    load_fk: impl Fn(usize) -> f32,
    z: &[[f32; 3]],
    emission: &[[f32; 3]],
    reflectance: &[[f32; 3]],
    radiosity: &mut [[f32; 3]],
) {
    let k = params.k as usize;
    for r in 0..params.row_count as usize {
        let row = params.fk_offset as usize + r * k;
        let w = reduce_lanes(k, |q| {
            let f = load_fk(row + q);
            z[q].map(|zq| f * zq)
        });
        let s = params.row_offset as usize + r;
        for c in 0..3 {
            radiosity[s][c] = emission[s][c] + reflectance[s][c] * w[c];
        }
    }
}

/// Mirror of the lane split plus `reduce_lanes` (`wgsl/common.wgsl`): the sum of `term(i)` for
/// `i < len`, lane `l` adding `i = l, l + LANES, …` in turn, then a binary tree over the lanes
/// (strides 32, 16, …, 1).
fn reduce_lanes(len: usize, term: impl Fn(usize) -> [f32; 3]) -> [f32; 3] {
    const L: usize = LANES as usize;
    let mut partial = [[0.0f32; 3]; L];
    for (lane, sum) in partial.iter_mut().enumerate() {
        for i in (lane..len).step_by(L) {
            *sum = add(*sum, term(i));
        }
    }
    let mut stride = L / 2;
    while stride > 0 {
        for lane in 0..stride {
            partial[lane] = add(partial[lane], partial[lane + stride]);
        }
        stride /= 2;
    }
    partial[0]
}

fn add(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[cfg(test)]
mod tests;
