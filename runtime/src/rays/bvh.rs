//! Rays and the watertight ray/triangle test (Woop, Benthin and Wald, "Watertight
//! Ray/Triangle Intersection", JCGT 2013), and the binary traversal of the file's flattened BVH
//! that `shaders/wgsl/bvh.wgsl` runs for the GPU's tracer and direct pass (the CPU traverses
//! the 4-wide collapse of the same tree, `bvh4.rs`, to the same answers; the binary loop stays
//! here as the tests' reference).
//!
//! Why watertight and not Möller–Trumbore: the display triangles are the fans of quads that
//! share edges and diagonals; Möller–Trumbore's barycentric tests round differently on the two
//! triangles of an edge and let a ray through the crack now and then (a speckle of background
//! in a closed box). The watertight test shears the triangle into the ray's space and
//! evaluates the three edge functions there, so the two triangles of an edge agree on the
//! edge function's sign (recomputed in f64 when it is exactly zero). Box tests use the
//! conservative slab test (the far distance enlarged by `1 + 2γ₃`, Ize 2013) so a box never
//! misses a ray the triangle test would hit.
//!
//! Binary traversal (the WGSL twin's): a fixed stack of node ids (no recursion); at an interior
//! node both children's boxes are tested, the nearer visited first and the farther pushed with
//! its entry distance, which is skipped when popped if it starts beyond the best hit. The
//! closest hit is the triangle of least distance, ties broken by the lower leaf-order index
//! (which makes the answer independent of the visiting order, so the 4-wide traversal gives
//! the same one).

#[cfg(test)]
use lrr_formats::BvhNode;

use super::math::V3;

/// Deepest BVH the fixed traversal stacks hold (a binary BVH over 2³² triangles built by a
/// balanced split is 32 deep; obvhs' trees stay far below 64 on every scene we bake).
pub(crate) const MAX_BVH_DEPTH: usize = 64;

/// `1 + 2γ₃` with γₙ = n ε / (1 - n ε), ε = 2⁻²⁴: the slab test's far distance is scaled by
/// this so rounding never shrinks a box (pbrt-v4, `Bounds3::IntersectP`).
pub(super) const FAR_SCALE: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// A ray with what its box and triangle tests precompute.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Ray {
    pub origin: V3,
    pub(super) inv: V3,
    /// The watertight test's dominant axis `kz` (`kx = kz + 1`, `ky = kz + 2`, mod 3) and
    /// shear.
    pub(super) kz: usize,
    pub(super) shear: V3,
}

impl Ray {
    /// A ray from `origin` along `dir` (any non-zero length; distances are in units of `|dir|`).
    #[inline]
    pub(crate) fn new(origin: V3, dir: V3) -> Self {
        let abs = [dir[0].abs(), dir[1].abs(), dir[2].abs()];
        let kz = if abs[0] > abs[1] {
            if abs[0] > abs[2] { 0 } else { 2 }
        } else if abs[1] > abs[2] {
            1
        } else {
            2
        };
        // Woop et al. swap kx and ky when dir[kz] < 0 to keep the winding for culling; a
        // two-sided test needs no swap (U, V, W and det all change sign together).
        let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
        // A zero component's reciprocal is made huge but finite, so that `0 * inv` is never
        // NaN in the slab test.
        let recip = |d: f32| {
            1.0 / if d.abs() < 1e-30 {
                1e-30f32.copysign(d)
            } else {
                d
            }
        };
        Ray {
            origin,
            inv: [recip(dir[0]), recip(dir[1]), recip(dir[2])],
            kz,
            shear: [dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]],
        }
    }
}

/// A closest hit: the distance and the triangle's leaf-order index.
#[cfg(feature = "trace")]
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Hit {
    pub t: f32,
    pub tri: u32,
}

/// Entry distance of `ray` into `node`'s box within `(0, t_max)`, or `None`.
#[cfg(test)]
#[inline(always)]
fn enter(node: &BvhNode, ray: &Ray, t_max: f32) -> Option<f32> {
    // Plain comparisons (one `minss`/`maxss` each) rather than `f32::min`, whose NaN rule
    // costs a compare and a blend more per use: nothing here is NaN (finite boxes, finite
    // reciprocals, finite origins).
    let lo = |a: f32, b: f32| if a < b { a } else { b };
    let hi = |a: f32, b: f32| if a > b { a } else { b };
    let mut near = 0.0f32;
    let mut far = t_max;
    for a in 0..3 {
        let t0 = (node.min[a] - ray.origin[a]) * ray.inv[a];
        let t1 = (node.max[a] - ray.origin[a]) * ray.inv[a];
        near = hi(near, lo(t0, t1));
        far = lo(far, hi(t0, t1) * FAR_SCALE);
    }
    (near <= far).then_some(near)
}

/// The watertight test of `ray` against the triangle `v`: its distance in `(t_min, t_max)`, or
/// `None`. Two-sided (no culling).
/// `KZ` is the ray's dominant axis, a constant so that the permutation costs nothing.
#[cfg(test)]
#[inline(always)]
pub(super) fn triangle<const KZ: usize>(
    ray: &Ray,
    v: &[f32; 9],
    t_min: f32,
    t_max: f32,
) -> Option<f32> {
    let (kx, ky, kz) = ((KZ + 1) % 3, (KZ + 2) % 3, KZ);
    let o = ray.origin;
    let rel = |i: usize| [v[i] - o[0], v[i + 1] - o[1], v[i + 2] - o[2]];
    let (a, b, c) = (rel(0), rel(3), rel(6));
    let [sx, sy, sz] = ray.shear;
    let (ax, ay) = (a[kx] - sx * a[kz], a[ky] - sy * a[kz]);
    let (bx, by) = (b[kx] - sx * b[kz], b[ky] - sy * b[kz]);
    let (cx, cy) = (c[kx] - sx * c[kz], c[ky] - sy * c[kz]);
    let mut u = cx * by - cy * bx;
    let mut v_ = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v_ == 0.0 || w == 0.0 {
        // On an edge in f32: the f64 products decide, the same on both triangles of the edge.
        let f = |p: f32, q: f32, r: f32, s: f32| (p as f64 * q as f64 - r as f64 * s as f64) as f32;
        u = f(cx, by, cy, bx);
        v_ = f(ax, cy, ay, cx);
        w = f(bx, ay, by, ax);
    }
    if (u < 0.0 || v_ < 0.0 || w < 0.0) && (u > 0.0 || v_ > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v_ + w;
    if det == 0.0 {
        return None;
    }
    let t_scaled = u * (sz * a[kz]) + v_ * (sz * b[kz]) + w * (sz * c[kz]);
    let t = t_scaled / det;
    (t > t_min && t < t_max).then_some(t)
}

/// A binary BVH and its triangles in leaf order (the file's, as `TraceScene` holds them).
#[cfg(test)]
#[derive(Clone, Copy)]
pub(super) struct Binary<'a> {
    pub nodes: &'a [BvhNode],
    pub tris: &'a [[f32; 9]],
}

/// The nearest triangle `ray` hits in `(t_min, t_max)`, by the binary traversal (ties: the
/// lower leaf-order index).
#[cfg(test)]
pub(super) fn closest_hit(scene: Binary, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
    match ray.kz {
        0 => closest_hit_kz::<0>(scene, ray, t_min, t_max),
        1 => closest_hit_kz::<1>(scene, ray, t_min, t_max),
        _ => closest_hit_kz::<2>(scene, ray, t_min, t_max),
    }
}

/// [`closest_hit`] for rays whose dominant axis is `KZ`.
#[cfg(test)]
fn closest_hit_kz<const KZ: usize>(
    scene: Binary,
    ray: &Ray,
    t_min: f32,
    t_max: f32,
) -> Option<Hit> {
    let nodes = &scene.nodes;
    if nodes.is_empty() {
        return None;
    }
    let mut best = Hit {
        t: t_max,
        tri: u32::MAX,
    };
    let mut stack = [(0u32, 0.0f32); MAX_BVH_DEPTH];
    let mut sp = 0usize;
    let mut node = 0usize;
    enter(&nodes[0], ray, best.t)?;
    loop {
        let n = &nodes[node];
        if n.count > 0 {
            let first = n.first as usize;
            for (i, tri) in scene.tris[first..first + n.count as usize]
                .iter()
                .enumerate()
            {
                let i = (first + i) as u32;
                let Some(t) = triangle::<KZ>(ray, tri, t_min, t_max) else {
                    continue;
                };
                if t < best.t || (t == best.t && i < best.tri) {
                    best = Hit { t, tri: i };
                }
            }
        } else {
            let c = n.first as usize;
            let near0 = enter(&nodes[c], ray, best.t);
            let near1 = enter(&nodes[c + 1], ray, best.t);
            match (near0, near1) {
                (Some(t0), Some(t1)) => {
                    let (first, second, t_second) = if t0 <= t1 {
                        (c, c + 1, t1)
                    } else {
                        (c + 1, c, t0)
                    };
                    stack[sp] = (second as u32, t_second);
                    sp += 1;
                    node = first;
                    continue;
                }
                (Some(_), None) => {
                    node = c;
                    continue;
                }
                (None, Some(_)) => {
                    node = c + 1;
                    continue;
                }
                (None, None) => {}
            }
        }
        // Pop the next node not beyond the best hit.
        loop {
            if sp == 0 {
                return (best.tri != u32::MAX).then_some(best);
            }
            sp -= 1;
            let (next, t_enter) = stack[sp];
            if t_enter <= best.t {
                node = next as usize;
                break;
            }
        }
    }
}

/// Whether any triangle blocks `ray` in `(t_min, t_max)` by the binary traversal (the first hit
/// ends it).
#[cfg(test)]
pub(super) fn occluded(scene: Binary, ray: &Ray, t_min: f32, t_max: f32) -> bool {
    match ray.kz {
        0 => occluded_kz::<0>(scene, ray, t_min, t_max),
        1 => occluded_kz::<1>(scene, ray, t_min, t_max),
        _ => occluded_kz::<2>(scene, ray, t_min, t_max),
    }
}

/// [`occluded`] for rays whose dominant axis is `KZ`.
#[cfg(test)]
fn occluded_kz<const KZ: usize>(scene: Binary, ray: &Ray, t_min: f32, t_max: f32) -> bool {
    let nodes = &scene.nodes;
    if nodes.is_empty() || enter(&nodes[0], ray, t_max).is_none() {
        return false;
    }
    let mut stack = [0u32; MAX_BVH_DEPTH];
    let mut sp = 0usize;
    let mut node = 0usize;
    loop {
        let n = &nodes[node];
        if n.count > 0 {
            let first = n.first as usize;
            let tris = &scene.tris[first..first + n.count as usize];
            if tris
                .iter()
                .any(|tri| triangle::<KZ>(ray, tri, t_min, t_max).is_some())
            {
                return true;
            }
        } else {
            let c = n.first as usize;
            let hit0 = enter(&nodes[c], ray, t_max).is_some();
            let hit1 = enter(&nodes[c + 1], ray, t_max).is_some();
            match (hit0, hit1) {
                (true, true) => {
                    stack[sp] = (c + 1) as u32;
                    sp += 1;
                    node = c;
                    continue;
                }
                (true, false) => {
                    node = c;
                    continue;
                }
                (false, true) => {
                    node = c + 1;
                    continue;
                }
                (false, false) => {}
            }
        }
        if sp == 0 {
            return false;
        }
        sp -= 1;
        node = stack[sp] as usize;
    }
}
