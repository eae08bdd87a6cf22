// lightmap_tiles.wgsl (entry point lightmap_tiles): the smooth lightmap fill on the GPU in one
// dispatch with no smooth pass before it, the twin of lrr_runtime::Lightmap::fill
// (runtime/src/lightmap.rs) and of lightmap.wgsl after smooth.wgsl, which it replaces for
// smooth lightmaps whose texels each read at most TILE_VERTICES smooth vertices.
//
// The texels written (samples and dilated texels) are cut into tiles on the host, once
// (Lightmap::gpu_tiles): the texels of one 16 x 8 block of the atlas, cut further where they
// read over TILE_VERTICES smooth vertices together. One workgroup per tile:
// 1. its lanes compute the tile's smooth vertices (each vertex's row of SMOOTH weights over
//    the frame's radiosity, summed as smooth.wgsl sums it, clamped at zero) into workgroup
//    memory;
// 2. after a barrier, lane l writes the tile's texel l from those values: a sample four
//    weighted corners, a dilated texel its expanded terms (as lightmap.wgsl's rings).
// With the two dispatches (vertices, then texels) the GPU waits for one dispatch's last loads
// before the next begins; here a tile waits only for its own vertices. A vertex read by
// several tiles is computed by each (the building: 2.8 times in all). On an H200 the
// building's fill took 15 us against 17-18 us in passes; blocks of 8 x 8 texels (64 lanes)
// 20 us, 16 x 16 (256 lanes) 16 us, 32 x 8 17 us, and 64 texels along a row 28 us (each
// vertex computed 12.6 times): docs/PERFORMANCE.md.
//
// Tables (built and checked by the host, runtime/src/gpu/lightmap.rs; the module is compiled
// with bounds checks anyway):
// - tiles: per tile t, vec2(its first texel item, its first vertex in tile_vertices); tile
//   t + 1's entry ends both (one entry more than the tiles).
// - tile_vertices: per tile its smooth vertices, each as the range of its SMOOTH weights in
//   entries (start, end): one dependent load fewer than a vertex id and its row's offsets.
// - entries: vec2(element's original id, weight's f32 bits), SMOOTH's rows one after another.
// - items: per texel item vec2(texel, corners): the texel's index y * width + x, with DILATED
//   set for a dilated texel; a sample's four corners' tile-local vertex indices, a byte each
//   (TILE_VERTICES <= 256; unused corners 0, with weight 0).
// - slots: per texel item a sample's four weights times 1/pi (f32 bits), or a dilated
//   texel's terms' start and end.
// - terms: per term of a dilated texel, vec2(tile-local vertex index, weight's f32 bits).
// Workgroup memory is not zeroed first (runtime/src/gpu/lightmap.rs): every tile-local index is
// below the tile's vertex count, which the first phase writes in full before the barrier (a
// sample has a corner of non-zero weight, a dilated texel a term, so no tile is empty of
// vertices).

const TILE_LANES: u32 = 128u;
const TILE_VERTICES: u32 = 256u;
const DILATED: u32 = 0x80000000u;

// The uniform. Mirrored by lrr_shaders::TileParams (shaders/src/lightmap.rs), 16 bytes; a naga
// test compares names and offsets.
struct TileParams {
    // Texels across the atlas.
    width: u32,
    // Tiles (workgroups that compute; the rest return).
    tiles: u32,
    reserved0: u32,
    reserved1: u32,
}

@group(0) @binding(0) var<uniform> params: TileParams;
@group(0) @binding(1) var<storage, read> tiles: array<vec2<u32>>;
@group(0) @binding(2) var<storage, read> tile_vertices: array<vec2<u32>>;
@group(0) @binding(3) var<storage, read> entries: array<vec2<u32>>;
// The relighting's B: 3 f32 per element, original ids (GpuEvaluator::radiosity_buffer).
@group(0) @binding(4) var<storage, read> radiosity: array<f32>;
@group(0) @binding(5) var<storage, read> items: array<vec2<u32>>;
@group(0) @binding(6) var<storage, read> slots: array<vec4<u32>>;
@group(0) @binding(7) var<storage, read> terms: array<vec2<u32>>;
@group(0) @binding(8) var atlas: texture_storage_2d<rgba16float, write>;

var<workgroup> values: array<vec3<f32>, TILE_VERTICES>;

fn element_value(e: u32) -> vec3<f32> {
    return vec3<f32>(radiosity[3u * e], radiosity[3u * e + 1u], radiosity[3u * e + 2u]);
}

// The value of the smooth vertex whose weights are entries[row.x .. row.y]: smooth.wgsl's loop
// (four entries a step, in stored order, products past the row's end not added), clamped at
// zero.
fn vertex_value(row: vec2<u32>) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    let end = row.y;
    let zero = vec3<f32>(0.0);
    for (var j = row.x; j < end; j += 4u) {
        let last = end - 1u;
        let e0 = entries[j];
        let e1 = entries[min(j + 1u, last)];
        let e2 = entries[min(j + 2u, last)];
        let e3 = entries[min(j + 3u, last)];
        let b0 = element_value(e0.x);
        let b1 = element_value(e1.x);
        let b2 = element_value(e2.x);
        let b3 = element_value(e3.x);
        sum = sum + bitcast<f32>(e0.y) * b0;
        sum = sum + select(zero, bitcast<f32>(e1.y) * b1, j + 1u < end);
        sum = sum + select(zero, bitcast<f32>(e2.y) * b2, j + 2u < end);
        sum = sum + select(zero, bitcast<f32>(e3.y) * b3, j + 3u < end);
    }
    return max(sum, vec3<f32>(0.0));
}

@compute @workgroup_size(TILE_LANES)
fn lightmap_tiles(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lane: u32,
) {
    let tile = group.x + group.y * groups.x;
    // Uniform across the workgroup: every lane reaches the barrier or none does.
    if tile >= params.tiles {
        return;
    }
    let here = tiles[tile];
    let next = tiles[tile + 1u];
    // The texel item's table entries first, so that their loads overlap the vertices'.
    let item = here.x + lane;
    let mine = item < next.x;
    var head = vec2<u32>(0u);
    var slot = vec4<u32>(0u);
    if mine {
        head = items[item];
        slot = slots[item];
    }
    for (var k = lane; here.y + k < next.y; k += TILE_LANES) {
        values[k] = vertex_value(tile_vertices[here.y + k]);
    }
    workgroupBarrier();
    if !mine {
        return;
    }
    var v = vec3<f32>(0.0);
    if (head.x & DILATED) == 0u {
        let c = head.y;
        let w = bitcast<vec4<f32>>(slot);
        // A corner of weight 0 (a triangle's fourth) indexes the tile's first vertex: its
        // product is not added, so that a vertex that overflowed spoils no other sample.
        let zero = vec3<f32>(0.0);
        v = select(zero, w.x * values[c & 0xffu], w.x != 0.0)
            + select(zero, w.y * values[(c >> 8u) & 0xffu], w.y != 0.0)
            + select(zero, w.z * values[(c >> 16u) & 0xffu], w.z != 0.0)
            + select(zero, w.w * values[c >> 24u], w.w != 0.0);
    } else {
        let end = slot.y;
        // Four terms a step, their loads in flight together; past the end a term reads the
        // last term, and its product is not added.
        let last = end - 1u;
        let zero = vec3<f32>(0.0);
        for (var k = slot.x; k < end; k += 4u) {
            let t0 = terms[k];
            let t1 = terms[min(k + 1u, last)];
            let t2 = terms[min(k + 2u, last)];
            let t3 = terms[min(k + 3u, last)];
            v = v + bitcast<f32>(t0.y) * values[t0.x];
            v = v + select(zero, bitcast<f32>(t1.y) * values[t1.x], k + 1u < end);
            v = v + select(zero, bitcast<f32>(t2.y) * values[t2.x], k + 2u < end);
            v = v + select(zero, bitcast<f32>(t3.y) * values[t3.x], k + 3u < end);
        }
    }
    let t = head.x & ~DILATED;
    textureStore(atlas, vec2<u32>(t % params.width, t / params.width), vec4<f32>(v, 1.0));
}
