// bvh.wgsl: the file's binary BVH on the GPU, shared by the passes that trace rays through it
// (lrr_shaders::TRACE = bvh.wgsl + direct_light.wgsl + trace.wgsl; lrr_shaders::DIRECT_PASS =
// bvh.wgsl + direct_light.wgsl + direct_pass.wgsl; naga validates whole modules, so the parts are
// joined into each pass's source): the CPU's ray (runtime/src/rays/bvh.rs), its
// watertight triangle test and its binary traversal, closest hit and any hit, with the same
// operations in the same order (the CPU's 4-wide traversal, bvh4.rs, finds the same hits). It
// declares the two bindings every such pass shares, nodes (1) and tris (2), and reads nothing
// else: a pass's own bindings and uniform are in its own file.
//
// Indices (the argument for building a pass that includes this file without bounds checks; the
// host checks all of it once, in RayScene::new): node 0 exists (a host runs no such pass over a
// scene without triangles); an interior node's children first, first + 1 are after it and in the
// list; a leaf's first + count <= the triangle count, and tris holds 9 f32 per triangle; depth <
// MAX_BVH_DEPTH, so the traversal stacks (at most one entry per level) never overflow. The loops
// end: the traversal visits each node at most once (children after parents).

// runtime/src/rays/bvh.rs MAX_BVH_DEPTH.
const MAX_BVH_DEPTH: u32 = 64u;
// The largest finite f32: the CPU's f32::INFINITY as the far end of unbounded rays (every hit
// distance the tests accept is finite, so the comparisons agree).
const FAR: f32 = 3.40282347e+38;
// 1 + 2 gamma_3 rounded to f32 (runtime/src/rays/bvh.rs FAR_SCALE): 1 + 3 ulp.
const FAR_SCALE_BITS: u32 = 0x3F800003u;
const NO_HIT: u32 = 0xFFFFFFFFu;

// A BVH node as the file stores it, reordered for 16-byte alignment.
struct Node {
    min: vec3<f32>,
    // Leaf: number of triangles; 0 for an interior node.
    count: u32,
    max: vec3<f32>,
    // Interior: the first child (the second is first + 1). Leaf: first leaf-order triangle.
    first: u32,
}

// The BVH, as the host uploads it once (TraceScene: nodes in the file's order, children after
// parents; triangles in leaf order).
@group(0) @binding(1) var<storage, read> nodes: array<Node>;
// Leaf-order triangles, 9 f32 each: v0, v1, v2.
@group(0) @binding(2) var<storage, read> tris: array<f32>;

// math.rs: written out so no builtin reorders them (dot, normalize, length).
fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

fn mad3(a: vec3<f32>, b: vec3<f32>, s: f32) -> vec3<f32> {
    return a + s * b;
}

fn length3(a: vec3<f32>) -> f32 {
    return sqrt(dot3(a, a));
}

fn normalize3(a: vec3<f32>) -> vec3<f32> {
    let l = length3(a);
    if l > 0.0 {
        return a * (1.0 / l);
    }
    return a;
}

fn cross3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

// bvh.rs Ray: the ray with its reciprocal direction and the watertight test's permutation and
// shear.
struct Ray {
    origin: vec3<f32>,
    inv: vec3<f32>,
    kx: u32,
    ky: u32,
    kz: u32,
    shear: vec3<f32>,
}

// A zero component's reciprocal made huge but finite (bvh.rs `recip`).
fn recip(d: f32) -> f32 {
    var x = d;
    if abs(d) < 1e-30 {
        x = select(1e-30, -1e-30, (bitcast<u32>(d) & 0x80000000u) != 0u);
    }
    return 1.0 / x;
}

fn make_ray(origin: vec3<f32>, dir: vec3<f32>) -> Ray {
    let a = abs(dir);
    var kz = 2u;
    if a.x > a.y {
        if a.x > a.z {
            kz = 0u;
        }
    } else if a.y > a.z {
        kz = 1u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kz + 2u) % 3u;
    if dir[kz] < 0.0 {
        let t = kx;
        kx = ky;
        ky = t;
    }
    var ray: Ray;
    ray.origin = origin;
    ray.inv = vec3<f32>(recip(dir.x), recip(dir.y), recip(dir.z));
    ray.kx = kx;
    ray.ky = ky;
    ray.kz = kz;
    ray.shear = vec3<f32>(dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]);
    return ray;
}

// bvh.rs `enter`: the entry distance into node i's box within (0, t_max), or -1.
fn enter(i: u32, ray: Ray, t_max: f32) -> f32 {
    let node = nodes[i];
    let far_scale = bitcast<f32>(FAR_SCALE_BITS);
    var near = 0.0;
    var far = t_max;
    for (var a = 0u; a < 3u; a++) {
        let t0 = (node.min[a] - ray.origin[a]) * ray.inv[a];
        let t1 = (node.max[a] - ray.origin[a]) * ray.inv[a];
        near = max(near, min(t0, t1));
        far = min(far, max(t0, t1) * far_scale);
    }
    if near <= far {
        return near;
    }
    return -1.0;
}

// p q - r s as the CPU's f64 fallback rounds it: exact products (an f32 product fits an f64)
// replaced by Kahan's fused difference of products (within 1.5 ulp, exact sign, exact zero).
fn diff_of_products(p: f32, q: f32, r: f32, s: f32) -> f32 {
    let w = r * s;
    let e = fma(-r, s, w);
    let f = fma(p, q, -w);
    return f + e;
}

// bvh.rs `triangle`: the watertight test of `ray` against leaf-order triangle `t`, its distance
// in (t_min, t_max), or -1. Two-sided.
fn triangle(ray: Ray, t: u32, t_min: f32, t_max: f32) -> f32 {
    let base = 9u * t;
    let o = ray.origin;
    let a = vec3<f32>(tris[base], tris[base + 1u], tris[base + 2u]) - o;
    let b = vec3<f32>(tris[base + 3u], tris[base + 4u], tris[base + 5u]) - o;
    let c = vec3<f32>(tris[base + 6u], tris[base + 7u], tris[base + 8u]) - o;
    let sx = ray.shear.x;
    let sy = ray.shear.y;
    let sz = ray.shear.z;
    let ax = a[ray.kx] - sx * a[ray.kz];
    let ay = a[ray.ky] - sy * a[ray.kz];
    let bx = b[ray.kx] - sx * b[ray.kz];
    let by = b[ray.ky] - sy * b[ray.kz];
    let cx = c[ray.kx] - sx * c[ray.kz];
    let cy = c[ray.ky] - sy * c[ray.kz];
    var u = cx * by - cy * bx;
    var v = ax * cy - ay * cx;
    var w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        u = diff_of_products(cx, by, cy, bx);
        v = diff_of_products(ax, cy, ay, cx);
        w = diff_of_products(bx, ay, by, ax);
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return -1.0;
    }
    let det = u + v + w;
    if det == 0.0 {
        return -1.0;
    }
    let t_scaled = u * (sz * a[ray.kz]) + v * (sz * b[ray.kz]) + w * (sz * c[ray.kz]);
    let dist = t_scaled / det;
    if dist > t_min && dist < t_max {
        return dist;
    }
    return -1.0;
}

struct Hit {
    t: f32,
    // Leaf-order triangle, NO_HIT for a miss.
    tri: u32,
}

// bvh.rs `closest_hit`: the nearest triangle in (t_min, t_max), between equal distances the
// lower leaf-order index (an answer independent of the visiting order, the CPU's 4-wide
// traversal's); a fixed stack of (node, entry distance), the nearer child first, a popped node
// skipped when it starts beyond the best hit.
fn closest_hit(ray: Ray, t_min: f32, t_max: f32) -> Hit {
    var best = Hit(t_max, NO_HIT);
    if enter(0u, ray, best.t) < 0.0 {
        return best;
    }
    var stack_node: array<u32, MAX_BVH_DEPTH>;
    var stack_t: array<f32, MAX_BVH_DEPTH>;
    var sp = 0u;
    var node = 0u;
    loop {
        let n = nodes[node];
        var descend = false;
        if n.count > 0u {
            for (var i = n.first; i < n.first + n.count; i++) {
                let t = triangle(ray, i, t_min, t_max);
                if t >= 0.0 && (t < best.t || (t == best.t && i < best.tri)) {
                    best = Hit(t, i);
                }
            }
        } else {
            let c = n.first;
            let near0 = enter(c, ray, best.t);
            let near1 = enter(c + 1u, ray, best.t);
            if near0 >= 0.0 && near1 >= 0.0 {
                if near0 <= near1 {
                    stack_node[sp] = c + 1u;
                    stack_t[sp] = near1;
                    node = c;
                } else {
                    stack_node[sp] = c;
                    stack_t[sp] = near0;
                    node = c + 1u;
                }
                sp += 1u;
                descend = true;
            } else if near0 >= 0.0 {
                node = c;
                descend = true;
            } else if near1 >= 0.0 {
                node = c + 1u;
                descend = true;
            }
        }
        if descend {
            continue;
        }
        // Pop the next node not beyond the best hit.
        var found = false;
        while sp > 0u {
            sp -= 1u;
            if stack_t[sp] <= best.t {
                node = stack_node[sp];
                found = true;
                break;
            }
        }
        if !found {
            return best;
        }
    }
    return best;
}

// bvh.rs `occluded`: whether any triangle blocks the ray in (t_min, t_max); the first hit ends
// it.
fn occluded(ray: Ray, t_min: f32, t_max: f32) -> bool {
    if enter(0u, ray, t_max) < 0.0 {
        return false;
    }
    var stack: array<u32, MAX_BVH_DEPTH>;
    var sp = 0u;
    var node = 0u;
    loop {
        let n = nodes[node];
        var descend = false;
        if n.count > 0u {
            for (var i = n.first; i < n.first + n.count; i++) {
                if triangle(ray, i, t_min, t_max) >= 0.0 {
                    return true;
                }
            }
        } else {
            let c = n.first;
            let hit0 = enter(c, ray, t_max) >= 0.0;
            let hit1 = enter(c + 1u, ray, t_max) >= 0.0;
            if hit0 && hit1 {
                stack[sp] = c + 1u;
                sp += 1u;
                node = c;
                descend = true;
            } else if hit0 {
                node = c;
                descend = true;
            } else if hit1 {
                node = c + 1u;
                descend = true;
            }
        }
        if descend {
            continue;
        }
        if sp == 0u {
            return false;
        }
        sp -= 1u;
        node = stack[sp];
    }
    return false;
}
