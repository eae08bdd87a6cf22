// sky.wgsl (entry point sky_pass): a sky's direct light on the GPU, the twin of
// lrr_runtime::lights::DirectLighting::sky_irradiance followed by `reflected`
// (runtime/src/lights.rs): per element, H = max(0, sum over the nine order-2 spherical harmonics
// of L_lm * T_lm) per channel, with T the element's transfer (the bake's section SKY_TRANSFER, or
// the CPU pass's projection, uploaded once) and L the frame's sky coefficients; then
// emission += rho * H over the emission the GPU evaluator bounces next (after direct_pass, which
// wrote base + rho * H of the lights there, or over the base alone). No readback, no ray.
//
// Self-contained (no common.wgsl). One invocation per element (original id) of
// first_element .. first_element + element_count; lrr_shaders::workgroups(ceil(count /
// SKY_LANES)) groups, a 2D grid past 65535 groups, whose surplus invocations return at once.
//
// The CPU's order of operations: sum = 0, then sum + L_l * T_l for l = 0 .. 8 per channel,
// clamped at zero; E = base + rho * (H_lights + H_sky) there, here (base + rho * H_lights) +
// rho * H_sky: equal to rounding (runtime/tests/gpu_direct.rs measures it).
//
// Indices (the host, runtime/src/gpu/direct.rs, checks them; the module is compiled with bounds
// checks anyway): e < first_element + element_count <= n; transfer: 9 f32 per element;
// reflectance and emission: 3 f32 per element; coefficients: 27 f32.

const SKY_LANES: u32 = 64u;

// The uniform. Mirrored by lrr_shaders::SkyParams (shaders/src/sky.rs), 16 bytes; a naga test
// compares names and offsets.
struct SkyParams {
    first_element: u32,
    element_count: u32,
    reserved0: u32,
    reserved1: u32,
}

@group(0) @binding(0) var<uniform> params: SkyParams;
// The frame's sky: nine order-2 coefficients, 3 f32 (r, g, b) each.
@group(0) @binding(1) var<storage, read> coefficients: array<f32>;
// The transfer: 9 f32 per element, original ids.
@group(0) @binding(2) var<storage, read> transfer: array<f32>;
// Reflectance per element, 3 f32 each, original ids.
@group(0) @binding(3) var<storage, read> reflectance: array<f32>;
// In: the frame's emission so far; out: plus rho * H. 3 f32 per element, original ids.
@group(0) @binding(4) var<storage, read_write> emission: array<f32>;

@compute @workgroup_size(SKY_LANES)
fn sky_pass(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = id.x + id.y * (groups.x * SKY_LANES);
    if i >= params.element_count {
        return;
    }
    let e = params.first_element + i;
    var h = vec3<f32>(0.0);
    for (var l = 0u; l < 9u; l++) {
        let c = vec3<f32>(coefficients[3u * l], coefficients[3u * l + 1u], coefficients[3u * l + 2u]);
        h = h + c * transfer[9u * e + l];
    }
    h = max(h, vec3<f32>(0.0));
    let at = 3u * e;
    let rho = vec3<f32>(reflectance[at], reflectance[at + 1u], reflectance[at + 2u]);
    let out = vec3<f32>(emission[at], emission[at + 1u], emission[at + 2u]) + rho * h;
    emission[at] = out.x;
    emission[at + 1u] = out.y;
    emission[at + 2u] = out.z;
}
