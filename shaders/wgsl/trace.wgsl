// trace.wgsl (entry point trace): the GPU twin of the CPU ray tracer (lrr_runtime::trace,
// runtime/src/trace/): a Whitted ray tree per pixel over the operator file's flattened binary
// BVH, shaded with the radiosity the relighting passes left in their storage buffer. Every
// function here mirrors one of the CPU twin's, with the same operations in the same order
// (named in each comment), so the two images agree to rounding: see runtime/tests/gpu_trace.rs
// for the tolerance and why.
//
// Self-contained (no common.wgsl). One invocation per pixel; a dispatch covers the tile of
// pixels first_pixel .. first_pixel + pixel_count in row-major order (the host cuts an image
// into tiles so that no dispatch runs long enough for a driver's watchdog).
//
// Indices (the argument for building this pass without bounds checks; the host checks all of
// it once, in TraceScene::new and runtime/src/gpu/trace.rs):
// - nodes: node 0 exists (the host renders a scene without triangles black, without this pass); an interior node's children first, first + 1 are
//   after it and in the list; a leaf's first + count <= the triangle count; depth < 64, so the
//   traversal stacks (at most one entry per level) never overflow;
// - tris, tri_face: one entry per leaf-order triangle; tri_face < F, the number of display
//   faces (the file's section FACES, else its elements: F = n);
// - face_id, normals, face_material: F entries; face_id < n (the original id of the face's
//   element); face_material < the material count;
// - radiosity: at least 3 n f32; lights: light_count entries (at least one bound);
// - image: pixel_count <= its length; counts: 3 per tile, tile < their count / 3;
// - the ray stack: a popped ray pushes at most two, with depth + 1 <= max_depth <= 16, so at
//   most max_depth + 2 <= RAY_STACK entries are live;
// - smooth_faces: F entries; a face's used corners (3, or 4 when c3 != NO_CORNER) name
//   smooth vertices < the vertex count (Reconstruction::from_parts), and vertex_values holds 3
//   f32 per smooth vertex (written by smooth.wgsl before the tiles). Without SMOOTH both are
//   bound but unread;
// - direct_lights: at least direct_count entries; reflectance: at least 3 n f32 (the host
//   checks both per frame). Without DIRECT both are bound but unread.

// Effects, set per frame by the host exactly as the CPU's `Effects` decide
// (runtime/src/trace/effects.rs): a switched-off effect's code is removed at pipeline creation.
// Phong highlights, one shadow ray per point light at every specular hit.
override HIGHLIGHTS: bool = false;
// Mirror reflection and refraction rays (the ray tree up to max_depth).
override SECONDARY: bool = false;
// Smooth reconstruction of the radiosity at hit points (the CPU twin's Reconstruction::at): the
// display face's smooth-vertex values (smooth.wgsl, once per frame) by mean value coordinates.
override SMOOTH: bool = false;
// Count rays by kind into `counts` (benchmarks and reports; atomics, off for timed frames).
override COUNT_RAYS: bool = false;
// Lights that are not surfaces (the CPU's Lighting::direct): at every hit, rho H(p) / pi added
// to the radiosity's radiance, each light of direct_lights behind its own shadow ray. Off, a
// frame without such lights runs none of it.
override DIRECT: bool = false;

// Invocations per workgroup (lrr_shaders::TRACE_LANES).
const TRACE_LANES: u32 = 64u;
// runtime/src/trace/scene.rs MAX_BVH_DEPTH.
const MAX_BVH_DEPTH: u32 = 64u;
// runtime/src/trace/shade.rs STACK: MAX_DEPTH_LIMIT + 2.
const RAY_STACK: u32 = 18u;
// The largest finite f32: the CPU's f32::INFINITY as the far end of unbounded rays (every hit
// distance the tests accept is finite, so the comparisons agree).
const FAR: f32 = 3.40282347e+38;
// 1 + 2 gamma_3 rounded to f32 (runtime/src/trace/bvh.rs FAR_SCALE): 1 + 3 ulp.
const FAR_SCALE_BITS: u32 = 0x3F800003u;
// f32 FRAC_1_PI.
const FRAC_1_PI: f32 = 0.318309886183790671537767526745028724;
const NO_HIT: u32 = 0xFFFFFFFFu;
// A triangle's unused fourth corner in SmoothElement (lrr_shaders::NO_CORNER).
const NO_CORNER: u32 = 0xFFFFFFFFu;
// DirectLight kinds (lrr_shaders::DirectKind).
const DIRECT_POINT: u32 = 0u;
const DIRECT_SPOT: u32 = 1u;
const DIRECT_SUN: u32 = 2u;

// The per-tile uniform. Mirrored by lrr_shaders::TraceParams (shaders/src/trace.rs), 96 bytes;
// a naga test compares names and offsets.
struct TraceParams {
    eye: vec3<f32>,
    // Offset of secondary and shadow ray origins off their surface.
    epsilon: f32,
    // Unit view direction.
    forward: vec3<f32>,
    // Bounces below a camera ray.
    max_depth: u32,
    // Right and up, scaled by the half extents of the image plane at distance 1.
    right: vec3<f32>,
    light_count: u32,
    up: vec3<f32>,
    width: u32,
    height: u32,
    // This dispatch's pixels, row-major from the top left.
    first_pixel: u32,
    pixel_count: u32,
    // Index of this tile's counters.
    tile: u32,
    // Lights in direct_lights (DIRECT only).
    direct_count: u32,
}

// A BVH node as the file stores it, reordered for 16-byte alignment.
struct Node {
    min: vec3<f32>,
    // Leaf: number of triangles; 0 for an interior node.
    count: u32,
    max: vec3<f32>,
    // Interior: the first child (the second is first + 1). Leaf: first leaf-order triangle.
    first: u32,
}

// A material's optics (runtime/src/trace/scene.rs Optics).
struct Optics {
    specular: vec3<f32>,
    shininess: f32,
    mirror: vec3<f32>,
    ior: f32,
    transmission: vec3<f32>,
    reserved: f32,
}

// A point light with this frame's intensity (its own times its group's).
struct Light {
    position: vec3<f32>,
    reserved0: f32,
    intensity: vec3<f32>,
    reserved1: f32,
}

// A light that is not a surface (direct.rs Light; lrr_shaders::direct_light, 64 bytes; a naga
// test compares offsets), with what the CPU computes per light rather than per point computed on
// the host in the CPU's operations: direction is a spot's unit axis (normalize(direction)) or
// the unit direction towards a sun (-normalize(direction)); a spot's cone cosines and
// falloff_scale = 1 / max(cos_inner - cos_outer, 1e-3). The host leaves out dark lights (the
// CPU's at_point skips them before any ray).
struct DirectLight {
    position: vec3<f32>,
    kind: u32,
    direction: vec3<f32>,
    cos_inner: f32,
    // Colour times intensity: W/sr (point, spot) or W/m2 (sun).
    strength: vec3<f32>,
    cos_outer: f32,
    falloff_scale: f32,
    reserved0: f32,
    reserved1: f32,
    reserved2: f32,
}

// One display face's polygon for smooth shading (lrr_shaders::smooth_element, 64 bytes; a naga
// test compares offsets): corner i and its smooth vertex ci; a triangle's c3 is NO_CORNER.
struct SmoothElement {
    v0: vec3<f32>,
    c0: u32,
    v1: vec3<f32>,
    c1: u32,
    v2: vec3<f32>,
    c2: u32,
    v3: vec3<f32>,
    c3: u32,
}

@group(0) @binding(0) var<uniform> params: TraceParams;
@group(0) @binding(1) var<storage, read> nodes: array<Node>;
// Leaf-order triangles, 9 f32 each: v0, v1, v2.
@group(0) @binding(2) var<storage, read> tris: array<f32>;
// Per leaf-order triangle: its display face (a triangle of the fan of the file's display faces).
@group(0) @binding(3) var<storage, read> tri_face: array<u32>;
// Per display face: the original id of its element (the index into the radiosity).
@group(0) @binding(4) var<storage, read> face_id: array<u32>;
// Per display face: unit normal, 3 f32.
@group(0) @binding(5) var<storage, read> normals: array<f32>;
// Per display face: its element's material (index into optics).
@group(0) @binding(6) var<storage, read> face_material: array<u32>;
@group(0) @binding(7) var<storage, read> optics: array<Optics>;
@group(0) @binding(8) var<storage, read> lights: array<Light>;
// The relighting's B: 3 f32 per element, original ids (GpuEvaluator::radiosity_buffer).
@group(0) @binding(9) var<storage, read> radiosity: array<f32>;
// This tile's pixels: linear RGB radiance, alpha 1.
@group(0) @binding(10) var<storage, read_write> image: array<vec4<f32>>;
// Rays by kind (primary, shadow, secondary), 3 per tile.
@group(0) @binding(11) var<storage, read_write> counts: array<atomic<u32>>;
// Per display face: its corners and smooth vertices (read with SMOOTH only).
@group(0) @binding(12) var<storage, read> smooth_faces: array<SmoothElement>;
// This frame's smooth-vertex values, 3 f32 each (smooth.wgsl's output; SMOOTH only).
@group(0) @binding(13) var<storage, read> vertex_values: array<f32>;
// This frame's lights that are not surfaces, params.direct_count of them (DIRECT only).
@group(0) @binding(14) var<storage, read> direct_lights: array<DirectLight>;
// Reflectance per element, 3 f32 each, original ids (DIRECT only).
@group(0) @binding(15) var<storage, read> reflectance: array<f32>;

// This invocation's ray counts: primary, shadow, secondary.
var<private> counted: vec3<u32>;

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

fn max_component(a: vec3<f32>) -> f32 {
    return max(max(a.x, a.y), a.z);
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

// smooth.rs `nearest_edge_weights` (mirror: lrr_shaders::cpu, same name): linear interpolation
// along the edge nearest the point, at its nearest point on it, from d, the m corners relative
// to the point and projected onto the polygon's plane (the CPU measures x - v_i in 3D: for a
// planar polygon the same edge and parameter, and in f32 the small relative vectors keep a few
// ulp where x - v_i would round at the coordinates' magnitude).
fn nearest_edge_weights(d: array<vec3<f32>, 4>, m: u32) -> vec4<f32> {
    var rel = d;
    var best = 0u;
    var best_s = 0.0;
    var best_dist = 0.0;
    for (var i = 0u; i < m; i++) {
        let ab = rel[(i + 1u) % m] - rel[i];
        let len2 = dot3(ab, ab);
        var s = 0.0;
        if len2 > 0.0 {
            s = clamp(-dot3(rel[i], ab) / len2, 0.0, 1.0);
        }
        // The nearest point of edge i, relative to the point.
        let q = rel[i] + s * ab;
        let dist = dot3(q, q);
        if i == 0u || dist < best_dist {
            best = i;
            best_s = s;
            best_dist = dist;
        }
    }
    var w = array<f32, 4>(0.0, 0.0, 0.0, 0.0);
    w[best] = 1.0 - best_s;
    w[(best + 1u) % m] += best_s;
    return vec4<f32>(w[0], w[1], w[2], w[3]);
}

// smooth.rs `mean_value_weights`, step 1: corner v relative to x, projected onto the plane of
// unit normal n (d_i).
fn relative(v: vec3<f32>, n: vec3<f32>, x: vec3<f32>) -> vec3<f32> {
    let e = v - x;
    let h = dot3(e, n);
    return e - h * n;
}

fn distance3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    let e = b - a;
    return sqrt(dot3(e, e));
}

// smooth.rs `mean_value_weights` in f32 (mirror: lrr_shaders::cpu::mean_value_weights, the same
// operations in the same order): the mean value coordinates of x, projected onto the plane of
// the element's convex polygon (corners s.v0..s.v2, and s.v3 when quad; unit normal n), in
// Hormann and Floater's stable form w_i ~ (t_{i-1} + t_i) / r_i with
// t_i = tan(alpha_i / 2) = (r_i r_{i+1} - d_i.d_{i+1}) / ((d_i x d_{i+1}).n). The CPU's cases and
// thresholds: on a vertex (r_i <= 1e-12 of the longest edge) that vertex; on or beyond an
// edge's line (a half-angle's sine <= 1e-12) linear interpolation at the nearest boundary
// point. In f32 near an edge, t_i's relative error grows like 1 / sin(alpha_i), but t_i then
// dominates the two weights of its edge and cancels in their ratio, so the weights keep a few
// ulp; t_i <= 2e12 and r_i > 1e-12 of the edge keep every sum finite. Written out corner by
// corner (no array indexed at run time, which a compiler may keep in memory); a triangle's
// weight w is 0.
fn mean_value_weights(s: SmoothElement, quad: bool, n: vec3<f32>, x: vec3<f32>) -> vec4<f32> {
    let d0 = relative(s.v0, n, x);
    let d1 = relative(s.v1, n, x);
    let d2 = relative(s.v2, n, x);
    // A triangle's fourth corner is its first again (read only through `quad` below).
    let v3 = select(s.v0, s.v3, quad);
    let d3 = select(d0, relative(s.v3, n, x), quad);
    let r = vec4<f32>(sqrt(dot3(d0, d0)), sqrt(dot3(d1, d1)), sqrt(dot3(d2, d2)), sqrt(dot3(d3, d3)));
    var scale = max(max(max(0.0, distance3(s.v0, s.v1)), distance3(s.v1, s.v2)), distance3(s.v2, v3));
    if quad {
        scale = max(scale, distance3(v3, s.v0));
    }
    let eps = 1e-12 * scale;
    if r.x <= eps {
        return vec4<f32>(1.0, 0.0, 0.0, 0.0);
    }
    if r.y <= eps {
        return vec4<f32>(0.0, 1.0, 0.0, 0.0);
    }
    if r.z <= eps {
        return vec4<f32>(0.0, 0.0, 1.0, 0.0);
    }
    if quad && r.w <= eps {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    // The corner after corner 2: 3 on a quad, 0 on a triangle.
    let r_next = select(r.x, r.w, quad);
    let a0 = dot3(cross3(d0, d1), n);
    let a1 = dot3(cross3(d1, d2), n);
    let a2 = dot3(cross3(d2, d3), n);
    let a3 = dot3(cross3(d3, d0), n);
    if a0 <= 1e-12 * r.x * r.y || a1 <= 1e-12 * r.y * r.z || a2 <= 1e-12 * r.z * r_next
        || (quad && a3 <= 1e-12 * r.w * r.x) {
        return nearest_edge_weights(array<vec3<f32>, 4>(d0, d1, d2, d3), select(3u, 4u, quad));
    }
    let t0 = (r.x * r.y - dot3(d0, d1)) / a0;
    let t1 = (r.y * r.z - dot3(d1, d2)) / a1;
    let t2 = (r.z * r_next - dot3(d2, d3)) / a2;
    var t3 = 0.0;
    var w3 = 0.0;
    if quad {
        t3 = (r.w * r.x - dot3(d3, d0)) / a3;
        w3 = (t2 + t3) / r.w;
    }
    let w = vec4<f32>((select(t2, t3, quad) + t0) / r.x, (t0 + t1) / r.y, (t1 + t2) / r.z, w3);
    var total = w.x + w.y + w.z;
    if quad {
        total += w.w;
    }
    return w / total;
}

// The smooth-vertex value of vertex c (3 f32 each in vertex_values).
fn vertex_value(c: u32) -> vec3<f32> {
    let at = 3u * c;
    return vec3<f32>(vertex_values[at], vertex_values[at + 1u], vertex_values[at + 2u]);
}

// smooth.rs Reconstruction::at: the smooth radiosity at p on display face f, its corners'
// smooth-vertex values weighted by p's mean value coordinates.
fn smooth_radiosity(f: u32, p: vec3<f32>) -> vec3<f32> {
    let s = smooth_faces[f];
    let quad = s.c3 != NO_CORNER;
    let n = vec3<f32>(normals[3u * f], normals[3u * f + 1u], normals[3u * f + 2u]);
    let w = mean_value_weights(s, quad, n, p);
    var sum = w.x * vertex_value(s.c0) + w.y * vertex_value(s.c1) + w.z * vertex_value(s.c2);
    if quad {
        sum += w.w * vertex_value(s.c3);
    }
    return sum;
}

// direct.rs `spot_falloff`: glTF's cone falloff at cos_axis, the cosine of the angle off the
// spot's axis, from the cosines and the scale the host computed.
fn spot_falloff(light: DirectLight, cos_axis: f32) -> f32 {
    if cos_axis < light.cos_outer {
        return 0.0;
    }
    if light.cos_inner <= light.cos_outer {
        return 1.0;
    }
    let t = clamp((cos_axis - light.cos_outer) * light.falloff_scale, 0.0, 1.0);
    return t * t;
}

// direct.rs Light::towards: a light's irradiance per unit strength at x (front normal n, unit)
// before visibility, g; the shadow ray's unit direction towards the light, w, and length, dist
// (a sun's is unbounded and not read); lit false when no light arrives.
struct Towards {
    g: f32,
    w: vec3<f32>,
    dist: f32,
    lit: bool,
}

fn towards(light: DirectLight, x: vec3<f32>, n: vec3<f32>) -> Towards {
    var out = Towards(0.0, vec3<f32>(0.0), 0.0, false);
    if light.kind == DIRECT_SUN {
        let cos = dot3(n, light.direction);
        if cos > 0.0 {
            out = Towards(cos, light.direction, FAR, true);
        }
        return out;
    }
    let to = light.position - x;
    let d2 = dot3(to, to);
    if d2 <= 0.0 {
        return out;
    }
    let dist = sqrt(d2);
    let w = to * (1.0 / dist);
    let cos = dot3(n, w);
    if cos <= 0.0 {
        return out;
    }
    if light.kind == DIRECT_SPOT {
        let falloff = spot_falloff(light, -dot3(light.direction, w));
        if falloff > 0.0 {
            out = Towards(cos * falloff / d2, w, dist, true);
        }
        return out;
    }
    return Towards(cos / d2, w, dist, true);
}

// direct.rs `at_point`: the direct irradiance of the frame's lights at x (front normal n,
// unit), each behind its own shadow ray from just off the surface to just short of the light
// (a sun's to the far end), counted as a shadow ray.
fn direct_irradiance(x: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let origin = mad3(x, n, params.epsilon);
    var sum = vec3<f32>(0.0);
    for (var i = 0u; i < params.direct_count; i++) {
        let light = direct_lights[i];
        let to = towards(light, x, n);
        if !to.lit {
            continue;
        }
        counted.y += 1u;
        var reach = FAR;
        if light.kind != DIRECT_SUN {
            reach = to.dist * (1.0 - 1e-5);
        }
        if !occluded(make_ray(origin, to.w), 0.0, reach) {
            sum = sum + light.strength * to.g;
        }
    }
    return sum;
}

// shade.rs `diffuse`: the radiosity of the hit point on display face f as a radiance, B / pi:
// smooth (SMOOTH) or the flat value of the face's element; plus (DIRECT) the frame's direct
// light at p on the face's front, rho H(p) / pi.
fn diffuse(f: u32, p: vec3<f32>) -> vec3<f32> {
    let at = 3u * face_id[f];
    var b: vec3<f32>;
    if SMOOTH {
        b = smooth_radiosity(f, p);
    } else {
        b = vec3<f32>(radiosity[at], radiosity[at + 1u], radiosity[at + 2u]);
    }
    if DIRECT {
        let n = vec3<f32>(normals[3u * f], normals[3u * f + 1u], normals[3u * f + 2u]);
        let h = direct_irradiance(p, n);
        let rho = vec3<f32>(reflectance[at], reflectance[at + 1u], reflectance[at + 2u]);
        b = b + rho * h;
    }
    return b * FRAC_1_PI;
}

// Rust's powf where WGSL's pow (exp2(s log2 x)) is undefined or NaN: x^0 = 1, 0^s = 0.
fn powf(x: f32, s: f32) -> f32 {
    if s == 0.0 {
        return 1.0;
    }
    if x <= 0.0 {
        return 0.0;
    }
    return pow(x, s);
}

// shade.rs `highlights`: the Phong highlights at p seen along d (unit), behind shadow rays.
fn highlights(o: Optics, p: vec3<f32>, n_f: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    let norm = (o.shininess + 2.0) * (0.5 * FRAC_1_PI);
    let reflected = mad3(d, n_f, -2.0 * dot3(d, n_f));
    let origin = mad3(p, n_f, params.epsilon);
    for (var i = 0u; i < params.light_count; i++) {
        let light = lights[i];
        if max_component(light.intensity) <= 0.0 {
            continue;
        }
        let to = light.position - p;
        let dist = length3(to);
        if dist <= 0.0 {
            continue;
        }
        let l = to * (1.0 / dist);
        let cos_l = dot3(n_f, l);
        if cos_l <= 0.0 {
            continue;
        }
        counted.y += 1u;
        let to_light = light.position - origin;
        let reach = length3(to_light);
        let shadow = make_ray(origin, to_light * (1.0 / reach));
        if occluded(shadow, 0.0, reach * (1.0 - 1e-5)) {
            continue;
        }
        let lobe = powf(max(dot3(reflected, l), 0.0), o.shininess) * norm;
        let e = light.intensity * (cos_l / (dist * dist));
        sum = sum + (o.specular * e) * lobe;
    }
    return sum;
}

// shade.rs `fresnel`: unpolarised Fresnel reflectance for cos_i (> 0) and eta = n_i / n_t, 1
// past the critical angle; and the refracted cosine.
fn fresnel(cos_i: f32, eta: f32) -> vec2<f32> {
    let sin2_t = eta * eta * max(1.0 - cos_i * cos_i, 0.0);
    if sin2_t >= 1.0 {
        return vec2<f32>(1.0, 0.0);
    }
    let cos_t = sqrt(1.0 - sin2_t);
    let rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    return vec2<f32>(0.5 * (rs * rs + rp * rp), cos_t);
}

// shade.rs Pending: a ray of the tree with its weight.
struct Pending {
    origin: vec3<f32>,
    depth: u32,
    dir: vec3<f32>,
    weight: vec3<f32>,
}

// shade.rs `radiance`: the radiance arriving at origin from -dir (dir unit), with the effects
// the overrides switch on; the ray tree on an explicit stack.
fn radiance(origin: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {
    if !HIGHLIGHTS && !SECONDARY {
        // The diffuse loop: one closest hit, one load.
        counted.x += 1u;
        let hit = closest_hit(make_ray(origin, dir), 0.0, FAR);
        if hit.tri == NO_HIT {
            return vec3<f32>(0.0);
        }
        return diffuse(tri_face[hit.tri], mad3(origin, dir, hit.t));
    }
    var total = vec3<f32>(0.0);
    var stack: array<Pending, RAY_STACK>;
    stack[0] = Pending(origin, 0u, dir, vec3<f32>(1.0));
    var sp = 1u;
    while sp > 0u {
        sp -= 1u;
        let ray = stack[sp];
        if ray.depth == 0u {
            counted.x += 1u;
        } else {
            counted.z += 1u;
        }
        let hit = closest_hit(make_ray(ray.origin, ray.dir), 0.0, FAR);
        if hit.tri == NO_HIT {
            continue;
        }
        let f = tri_face[hit.tri];
        let p = mad3(ray.origin, ray.dir, hit.t);
        var local = diffuse(f, p);
        let o = optics[face_material[f]];
        let n = vec3<f32>(normals[3u * f], normals[3u * f + 1u], normals[3u * f + 2u]);
        let cos_n = dot3(ray.dir, n);
        var n_f = n;
        if !(cos_n < 0.0) {
            n_f = n * -1.0;
        }
        if HIGHLIGHTS && max_component(o.specular) > 0.0 {
            local = local + highlights(o, p, n_f, ray.dir);
        }
        total = total + ray.weight * local;
        if !SECONDARY || ray.depth >= params.max_depth {
            continue;
        }
        let cos_i = -dot3(ray.dir, n_f);
        var w_r = ray.weight * o.mirror;
        var w_t = vec3<f32>(0.0);
        var refracted = vec3<f32>(0.0);
        if max_component(o.transmission) > 0.0 {
            // Entering when the ray meets the normal's front side.
            var eta = o.ior;
            if cos_n < 0.0 {
                eta = 1.0 / o.ior;
            }
            let fr = fresnel(cos_i, eta);
            w_r = w_r * fr.x;
            w_t = (ray.weight * o.transmission) * (1.0 - fr.x);
            refracted = normalize3(mad3(ray.dir * eta, n_f, eta * cos_i - fr.y));
        }
        let depth = ray.depth + 1u;
        if max_component(w_t) > 0.0 {
            stack[sp] = Pending(mad3(p, n_f, -params.epsilon), depth, refracted, w_t);
            sp += 1u;
        }
        if max_component(w_r) > 0.0 {
            let reflected = normalize3(mad3(ray.dir, n_f, 2.0 * cos_i));
            stack[sp] = Pending(mad3(p, n_f, params.epsilon), depth, reflected, w_r);
            sp += 1u;
        }
    }
    return total;
}

// camera.rs View::direction: the unit direction through pixel (x, y)'s centre.
fn direction(x: u32, y: u32) -> vec3<f32> {
    let u = 2.0 * (f32(x) + 0.5) / f32(params.width) - 1.0;
    let v = 1.0 - 2.0 * (f32(y) + 0.5) / f32(params.height);
    return normalize3(mad3(mad3(params.forward, params.right, u), params.up, v));
}

@compute @workgroup_size(TRACE_LANES)
fn trace(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= params.pixel_count {
        return;
    }
    let pixel = params.first_pixel + i;
    let x = pixel % params.width;
    let y = pixel / params.width;
    counted = vec3<u32>(0u);
    let l = radiance(params.eye, direction(x, y));
    image[i] = vec4<f32>(l, 1.0);
    if COUNT_RAYS {
        let at = 3u * params.tile;
        atomicAdd(&counts[at], counted.x);
        atomicAdd(&counts[at + 1u], counted.y);
        atomicAdd(&counts[at + 2u], counted.z);
    }
}
