// gather.wgsl: the one pass over the stored matrix, all three channels at once, then the
// radiosity. Factored (F_k, Z = M X):
//     W[s][c] = sum over q of F_k[s][q] * Z[c][q],   B[order[s]][c] = E[order[s]][c] + rho[s][c] W[s][c]
// plain (Y_k, Z = X): B = E - W, with one Y_k block for all channels (grey) or block c for
// channel c (RGB, PER_BLOCK).
// Needs common.wgsl, one `fk_*.wgsl` loader (binding 1, `load_octet`) and one `reduce_*.wgsl`
// (`row_sum`). CPU mirror: `lrr_shaders::cpu::gather`.
//
// Bandwidth: the matrix is read once, in 32-byte (f32) or 16-byte (binary16) loads; ROW_LANES
// consecutive lanes share a row (lane l loads octets l, l + ROW_LANES, ... of 8 entries), so a
// subgroup reads ROW_LANES * 32 contiguous bytes per row and several rows at once; Z is copied
// once per workgroup into workgroup memory (Z_SHARED) where it fits; a workgroup walks its rows
// in a grid-stride loop, so the copy is paid once for many rows; the row's partial sums are
// added across its lanes by subgroup shuffles (reduce_subgroup.wgsl) or through workgroup
// memory (reduce_workgroup.wgsl).
//
// Indices (what lets the runtime build this pass without bounds checks): a row r < row_count
// of the chunk reads octets r * KP / 8 + j, j < KP / 8, inside the binding of row_count * KP
// entries the host binds; stored row first_row + r < blocks * n, so s < n and block < 3;
// order[s] < n (a permutation, validated by the file reader); emission, reflectance and
// radiosity hold 3 n values; zs and z hold 3 KP / 4 vec4s.

// Lanes per row: a power of two, at most 32, and at most the adapter's smallest subgroup in
// the subgroup variant.
override ROW_LANES: u32 = 8u;
// Copy Z into workgroup memory (12 KP bytes of it) once per workgroup; else read it from z.
override Z_SHARED: bool = true;
// Elements of zs: 3 KP / 4 with Z_SHARED, else 1.
override ZS_QUADS: u32 = 6u;
// Factored: B = E + rho W. Plain: B = E - W.
override FACTORED: bool = true;
// Plain RGB: stored row block c (rows c n .. c n + n - 1) serves channel c alone.
override PER_BLOCK: bool = false;

// Invocations per workgroup: GATHER_SIZE / ROW_LANES rows at a time.
const GATHER_SIZE: u32 = 256u;

// 3 planes of KP / 4 vec4s: Z (factored) or X (plain).
@group(0) @binding(2) var<storage, read> z: array<vec4<f32>>;
// n x 3 emission E, original id order.
@group(0) @binding(3) var<storage, read> emission: array<f32>;
// n x 3 reflectance rho, file order (read only when FACTORED).
@group(0) @binding(4) var<storage, read> reflectance: array<f32>;
// n file position -> original id.
@group(0) @binding(5) var<storage, read> order: array<u32>;
// n x 3 output radiosity B, original id order.
@group(0) @binding(6) var<storage, read_write> radiosity: array<f32>;

var<workgroup> zs: array<vec4<f32>, ZS_QUADS>;

// Entries 4 i .. 4 i + 3 of channel c's plane of Z.
fn z_quad(c: u32, i: u32) -> vec4<f32> {
    if Z_SHARED {
        return zs[c * (KP / 4u) + i];
    }
    return z[c * (KP / 4u) + i];
}

// Octet j of a row (entries 8 j .. 8 j + 7) against channel c of Z.
fn dot_octet(f: mat2x4<f32>, c: u32, j: u32) -> f32 {
    return dot(f[0], z_quad(c, 2u * j)) + dot(f[1], z_quad(c, 2u * j + 1u));
}

@compute @workgroup_size(GATHER_SIZE)
fn gather(
    @builtin(local_invocation_index) slot: u32,
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    if Z_SHARED {
        for (var i = slot; i < 3u * (KP / 4u); i = i + GATHER_SIZE) {
            zs[i] = z[i];
        }
        workgroupBarrier();
    }
    let lane = slot % ROW_LANES;
    let rows = GATHER_SIZE / ROW_LANES;
    let octets = KP / 8u;
    // Uniform across the workgroup: row_sum's barriers and shuffles see every lane.
    for (var base = group.x * rows; base < params.row_count; base = base + groups.x * rows) {
        let r = base + slot / ROW_LANES;
        let valid = r < params.row_count;
        let stored = params.first_row + r;
        var block = 0u;
        if PER_BLOCK {
            block = stored / params.n;
        }
        let s = stored - block * params.n;
        var w = vec3<f32>(0.0);
        if valid {
            for (var j = lane; j < octets; j = j + ROW_LANES) {
                let f = load_octet(r * octets + j);
                if PER_BLOCK {
                    w.x = w.x + dot_octet(f, block, j);
                } else {
                    w = w + vec3<f32>(dot_octet(f, 0u, j), dot_octet(f, 1u, j), dot_octet(f, 2u, j));
                }
            }
        }
        w = row_sum(w, slot);
        if valid && lane == 0u {
            let i = 3u * order[s];
            if PER_BLOCK {
                radiosity[i + block] = emission[i + block] - w.x;
            } else if FACTORED {
                for (var c = 0u; c < 3u; c = c + 1u) {
                    radiosity[i + c] = emission[i + c] + reflectance[3u * s + c] * w[c];
                }
            } else {
                for (var c = 0u; c < 3u; c = c + 1u) {
                    radiosity[i + c] = emission[i + c] - w[c];
                }
            }
        }
    }
}
