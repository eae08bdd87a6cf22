//! CPU mirrors of the passes, one function per WGSL entry point, with the same name; and
//! [`mean_value_weights`], the piece of `trace.wgsl` (whose mirror is the runtime's CPU tracer)
//! that computes in f32 what the CPU tracer computes in f64, so its error is measured here.
//!
//! Plain f32 arithmetic in the shaders' order: every sum is split over the same lanes (lane `l`
//! adds terms `l, l + lanes, …` in turn), then the lanes are added by the same binary tree as
//! `reduce_lanes` (`wgsl/common.wgsl`) and `row_sum` (`wgsl/reduce_*.wgsl`). A GPU result can
//! still differ in the last bits: a GPU compiler may fuse a multiply and an add (one rounding
//! instead of two) and `dot` adds its four products in an order of its choosing; the
//! rounding-error bound of the tests covers all of these.
//!
//! Buffers are the shaders' (see the crate docs): per-element RGB as `[f32; 3]`, per-patch
//! quantities as three planes of `kp` floats. A buffer too short for [`Params`] is a
//! programming mistake and panics.

use lrr_formats::f16_to_f32;

use crate::{GatherConstants, LANES, Params, SmoothParams};

/// Mirror of `segment_sums` (`wgsl/segment_sums.wgsl`): `x[c·kp + p] = Σ_{s=I[p]}^{I[p+1]-1}
/// w[s] e[order[s]][c]` for the `params.k` patches.
pub fn segment_sums(
    params: &Params,
    kp: usize,
    index: &[u32],
    weights: &[f32],
    order: &[u32],
    emission: &[[f32; 3]],
    x: &mut [f32],
) {
    for p in 0..params.k as usize {
        let (begin, end) = (index[p] as usize, index[p + 1] as usize);
        let total = reduce_lanes(LANES as usize, end.saturating_sub(begin), |i| {
            let s = begin + i;
            emission[order[s] as usize].map(|e| weights[s] * e)
        });
        for c in 0..3 {
            x[c * kp + p] = total[c];
        }
    }
}

/// Mirror of `group_sums` (`wgsl/light_groups.wgsl`): `x[t] = Σ_g a_g group_x[g·3·kp + t]` for
/// `t < 3·kp`, groups in order.
pub fn group_sums(params: &Params, kp: usize, intensities: &[f32], group_x: &[f32], x: &mut [f32]) {
    for (t, xt) in x[..3 * kp].iter_mut().enumerate() {
        let mut sum = 0.0f32;
        for g in 0..params.groups as usize {
            sum += intensities[g] * group_x[g * 3 * kp + t];
        }
        *xt = sum;
    }
}

/// Mirror of `group_emission` (`wgsl/light_groups.wgsl`): for each lit position `u`,
/// `emission[order[position[u]]] = Σ_{m ∈ starts[u]..starts[u+1]} a_{members[m]}
/// member_emission[m]`. Other elements are left as they are (zero on the GPU).
#[allow(clippy::too_many_arguments)] // the pass's bindings, one argument each
pub fn group_emission(
    params: &Params,
    intensities: &[f32],
    position: &[u32],
    starts: &[u32],
    members: &[u32],
    member_emission: &[[f32; 3]],
    order: &[u32],
    emission: &mut [[f32; 3]],
) {
    for u in 0..params.positions as usize {
        let mut sum = [0.0f32; 3];
        for m in starts[u] as usize..starts[u + 1] as usize {
            let a = intensities[members[m] as usize];
            for c in 0..3 {
                sum[c] += a * member_emission[m][c];
            }
        }
        emission[order[position[u] as usize] as usize] = sum;
    }
}

/// Mirror of `core_product` (`wgsl/core_product.wgsl`): `z[c·kp + p] = Σ_q M_c[p][q]
/// x[c·kp + q]`, each core `k` rows of `kp` entries (zero past `k`).
pub fn core_product(params: &Params, kp: usize, cores: [&[f32]; 3], x: &[f32], z: &mut [f32]) {
    for p in 0..params.k as usize {
        // Lane l takes the vec4 groups j = l, l + LANES, …: 4 consecutive entries each.
        let total = reduce_lanes(LANES as usize, kp / 4, |j| {
            std::array::from_fn(|c| {
                let row = &cores[c][p * kp + 4 * j..p * kp + 4 * j + 4];
                dot4(row, &x[c * kp + 4 * j..c * kp + 4 * j + 4])
            })
        });
        for c in 0..3 {
            z[c * kp + p] = total[c];
        }
    }
}

/// A chunk of whole stored rows (`row_count · kp` entries), as the gather's loader reads it.
#[derive(Clone, Copy, Debug)]
pub enum Rows<'a> {
    /// `f32` entries (`wgsl/fk_f32.wgsl`).
    F32(&'a [f32]),
    /// binary16 bits (`wgsl/fk_f16*.wgsl`), widened exactly by [`lrr_formats::f16_to_f32`].
    F16(&'a [u16]),
}

impl Rows<'_> {
    fn get(&self, i: usize) -> f32 {
        match self {
            Rows::F32(v) => v[i],
            Rows::F16(v) => f16_to_f32(v[i]),
        }
    }
}

/// Mirror of `gather` (`wgsl/gather.wgsl` with any loader and reduction): for the chunk's rows
/// `r < row_count`, stored row `first_row + r` (block `c`, element `s` in file order):
///
/// ```text
/// W[s][c] = Σ_q rows[r·kp + q] z[c·kp + q]
/// factored: B[order[s]][c] = E[order[s]][c] + ρ[s][c] W[s][c]     plain: B = E - W
/// ```
///
/// With `per_block` (plain RGB) a row of block `c` gives channel `c` alone. Rows outside the
/// chunk are left as they are.
#[allow(clippy::too_many_arguments)] // the pass's bindings, one argument each
pub fn gather(
    params: &Params,
    constants: &GatherConstants,
    rows: &Rows<'_>,
    z: &[f32],
    emission: &[[f32; 3]],
    reflectance: &[[f32; 3]],
    order: &[u32],
    radiosity: &mut [[f32; 3]],
) {
    let kp = constants.kp as usize;
    let n = params.n as usize;
    for r in 0..params.row_count as usize {
        let stored = params.first_row as usize + r;
        let block = if constants.per_block { stored / n } else { 0 };
        let s = stored - block * n;
        // Lane l takes octets j = l, l + ROW_LANES, …: 8 entries, as two 4-entry dots.
        let octet = |j: usize, c: usize| {
            let f: [f32; 8] = std::array::from_fn(|i| rows.get(r * kp + 8 * j + i));
            let zc = &z[c * kp + 8 * j..c * kp + 8 * j + 8];
            dot4(&f[..4], &zc[..4]) + dot4(&f[4..], &zc[4..])
        };
        let w = reduce_lanes(constants.row_lanes as usize, kp / 8, |j| {
            if constants.per_block {
                [octet(j, block), 0.0, 0.0]
            } else {
                std::array::from_fn(|c| octet(j, c))
            }
        });
        let id = order[s] as usize;
        let (e, b) = (emission[id], &mut radiosity[id]);
        if constants.per_block {
            b[block] = e[block] - w[0];
        } else if constants.factored {
            *b = std::array::from_fn(|c| e[c] + reflectance[s][c] * w[c]);
        } else {
            *b = std::array::from_fn(|c| e[c] - w[c]);
        }
    }
}

/// Mirror of `read_matrix` (`wgsl/read.wgsl`): the XOR of every 32-bit word of `words`, the value the
/// pass compares before its one store. Lanes and order do not matter to XOR.
pub fn read_matrix(words: &[u32]) -> u32 {
    words.iter().fold(0, |acc, w| acc ^ w)
}

/// Mirror of `smooth_vertices` (`wgsl/smooth.wgsl`): for each smooth vertex `v <
/// params.vertex_count`, `out[v] = max(0, Σ_{j ∈ offsets[v]..offsets[v+1]} weights[j]
/// radiosity[elements[j]])`, one running f32 sum per channel in stored order (`radiosity` by
/// original id, `elements` SMOOTH's positions mapped through the file's order). The pass reads
/// four entries a step and adds only the products of the row's own entries.
pub fn smooth_vertices(
    params: &SmoothParams,
    offsets: &[u32],
    elements: &[u32],
    weights: &[f32],
    radiosity: &[[f32; 3]],
    out: &mut [[f32; 3]],
) {
    for v in 0..params.vertex_count as usize {
        let mut sum = [0.0f32; 3];
        for j in offsets[v] as usize..offsets[v + 1] as usize {
            let b = radiosity[elements[j] as usize];
            for c in 0..3 {
                sum[c] += weights[j] * b[c];
            }
        }
        out[v] = sum.map(|x| x.max(0.0));
    }
}

/// Mirror of `mean_value_weights` (`wgsl/trace.wgsl`; not an entry point: what its `SMOOTH`
/// variant weights an element's corners with at a hit): the mean value coordinates of `x`
/// projected onto the plane of the convex polygon `v` (3 or 4 corners, unit normal `n`), in f32
/// with the f64 original's cases and thresholds (`lrr_runtime`'s `smooth.rs`): on a vertex (`r_i
/// <= 1e-12` of the longest edge) that vertex; on or beyond an edge's line linear interpolation
/// at the nearest boundary point; else `w_i ∝ (t_{i-1} + t_i) / r_i`, `t_i = (r_i r_{i+1} −
/// d_i·d_{i+1}) / ((d_i × d_{i+1})·n)`.
pub fn mean_value_weights(v: &[[f32; 3]], n: [f32; 3], x: [f32; 3]) -> [f32; 4] {
    let m = v.len();
    let mut d = [[0.0f32; 3]; 4];
    let mut r = [0.0f32; 4];
    let mut scale = 0.0f32;
    for i in 0..m {
        let e = sub3(v[i], x);
        let h = dot3(e, n);
        d[i] = [e[0] - h * n[0], e[1] - h * n[1], e[2] - h * n[2]];
        r[i] = dot3(d[i], d[i]).sqrt();
        let edge = sub3(v[(i + 1) % m], v[i]);
        scale = scale.max(dot3(edge, edge).sqrt());
    }
    let mut w = [0.0f32; 4];
    let eps = 1e-12 * scale;
    if let Some(i) = (0..m).find(|&i| r[i] <= eps) {
        w[i] = 1.0;
        return w;
    }
    let mut t = [0.0f32; 4];
    for i in 0..m {
        let j = (i + 1) % m;
        let area = dot3(cross3(d[i], d[j]), n);
        if area <= 1e-12 * r[i] * r[j] {
            return nearest_edge_weights(&d, m);
        }
        t[i] = (r[i] * r[j] - dot3(d[i], d[j])) / area;
    }
    let mut total = 0.0f32;
    for i in 0..m {
        w[i] = (t[(i + m - 1) % m] + t[i]) / r[i];
        total += w[i];
    }
    for wi in w.iter_mut().take(m) {
        *wi /= total;
    }
    w
}

/// Mirror of `nearest_edge_weights` (`wgsl/trace.wgsl`): linear interpolation along the edge
/// nearest the point, at its nearest point on it, from `d`, the `m` corners relative to the
/// point and projected onto the polygon's plane (as the f64 original's, which measures in 3D:
/// the same edge and parameter for a planar polygon, and in f32 exact to a few ulp of the small
/// relative vectors where the original's `x − v_i` would round at the coordinates' magnitude).
fn nearest_edge_weights(d: &[[f32; 3]], m: usize) -> [f32; 4] {
    let (mut best, mut best_s, mut best_dist) = (0, 0.0f32, 0.0f32);
    for i in 0..m {
        let ab = sub3(d[(i + 1) % m], d[i]);
        let len2 = dot3(ab, ab);
        let s = if len2 > 0.0 {
            (-dot3(d[i], ab) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        // The nearest point of edge i, relative to the point.
        let q = [0, 1, 2].map(|c| d[i][c] + s * ab[c]);
        let dist = dot3(q, q);
        if i == 0 || dist < best_dist {
            (best, best_s, best_dist) = (i, s, dist);
        }
    }
    let mut w = [0.0f32; 4];
    w[best] = 1.0 - best_s;
    w[(best + 1) % m] += best_s;
    w
}

/// `a.x b.x + a.y b.y + a.z b.z` in that order (`dot3` of `trace.wgsl`).
fn dot3(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub3(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross3(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `((a0 b0 + a1 b1) + a2 b2) + a3 b3`: one order a GPU's `dot` may use.
fn dot4(a: &[f32], b: &[f32]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
}

/// Mirror of the lane split plus the tree of `reduce_lanes` / `row_sum`: the sum of `term(i)`
/// for `i < len`, lane `l < lanes` adding `i = l, l + lanes, …` in turn, then a binary tree
/// over the lanes (strides `lanes/2, …, 1`). `lanes` is a power of two.
pub fn reduce_lanes(lanes: usize, len: usize, term: impl Fn(usize) -> [f32; 3]) -> [f32; 3] {
    let mut partial = vec![[0.0f32; 3]; lanes];
    for (lane, sum) in partial.iter_mut().enumerate() {
        for i in (lane..len).step_by(lanes) {
            *sum = add(*sum, term(i));
        }
    }
    let mut stride = lanes / 2;
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
