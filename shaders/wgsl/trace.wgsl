// trace.wgsl (entry point trace): the GPU twin of the CPU ray tracer (lrr_runtime::trace,
// runtime/src/trace/): a Whitted ray tree per pixel over the operator file's flattened binary
// BVH, shaded with the radiosity the relighting passes left in their storage buffer. Every
// function here mirrors one of the CPU twin's, with the same operations in the same order
// (named in each comment), so the two images agree to rounding: see runtime/tests/gpu_trace.rs
// for the tolerance and why.
//
// Its source is bvh.wgsl + direct_light.wgsl + this file (lrr_shaders::TRACE; no common.wgsl):
// the BVH, its traversal and watertight test, and the lights that are not surfaces are shared
// with direct_pass.wgsl. One invocation per pixel; a dispatch covers the tile of
// pixels first_pixel .. first_pixel + pixel_count in row-major order (the host cuts an image
// into tiles so that no dispatch runs long enough for a driver's watchdog).
//
// Indices (the argument for building this pass without bounds checks; the host checks all of
// it once, in TraceScene::new (with RayScene::new) and runtime/src/gpu/trace.rs):
// - nodes and tris: bvh.wgsl's argument (the host renders a scene without triangles black,
//   without this pass);
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
// runtime/src/trace/shade.rs STACK: MAX_DEPTH_LIMIT + 2.
const RAY_STACK: u32 = 18u;
// f32 FRAC_1_PI.
const FRAC_1_PI: f32 = 0.318309886183790671537767526745028724;
// A triangle's unused fourth corner in SmoothElement (lrr_shaders::NO_CORNER).
const NO_CORNER: u32 = 0xFFFFFFFFu;

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
// Bindings 1 (nodes) and 2 (tris, leaf-order triangles): bvh.wgsl.
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

fn max_component(a: vec3<f32>) -> f32 {
    return max(max(a.x, a.y), a.z);
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

// lights.rs `at_point`: the direct irradiance of the frame's lights at x (front normal n,
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
