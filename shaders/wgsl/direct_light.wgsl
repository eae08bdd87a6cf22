// direct_light.wgsl: lights that are not surfaces as the GPU passes read them, shared by
// trace.wgsl (per hit) and direct_pass.wgsl (per element's sample point); after bvh.wgsl (it uses
// its math). The record the host uploads per light (struct DirectLight) and the geometry of one
// light at one point, lights.rs's `spot_falloff` and `Light::towards`, with the CPU's operations
// in the CPU's order. No bindings: each pass binds its records itself.

// DirectLight kinds (lrr_shaders::DirectKind).
const DIRECT_POINT: u32 = 0u;
const DIRECT_SPOT: u32 = 1u;
const DIRECT_SUN: u32 = 2u;

// A light that is not a surface (lights.rs Light; lrr_shaders::direct_light, 64 bytes; a naga
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
    // The direct pass's cache word (direct_pass.wgsl; lrr_shaders::direct_cache_word): which of
    // its stored terms this light's is and whether to trace it this frame. The tracer ignores it.
    cache: u32,
    reserved1: f32,
    reserved2: f32,
}

// lights.rs `spot_falloff`: glTF's cone falloff at cos_axis, the cosine of the angle off the
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

// lights.rs Light::towards: a light's irradiance per unit strength at x (front normal n, unit)
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
