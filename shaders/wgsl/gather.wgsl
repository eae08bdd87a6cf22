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
// Latency: each lane takes ROWS rows per iteration (rows q * rows_per_group apart), and its
// octet loop has a constant trip count (OCTETS_PER_LANE; a lane past the row's end loads the
// row's last octet again and adds nothing), so the compiler can unroll it and issue every load
// of every row before the first use; each row's file-order reads (order, reflectance) are
// issued before its octets, and the emission reads of all ROWS rows together after them. A
// row past the chunk's end is clamped to its last row for the loads and writes nothing.
//
// Indices (what lets the runtime build this pass without bounds checks): a row r < row_count
// (clamped: min(r, row_count - 1), row_count >= 1 as the host dispatches only non-empty
// chunks) of the chunk reads octets r * KP / 8 + j, j = min(j, KP / 8 - 1) < KP / 8, inside
// the binding of row_count * KP entries the host binds; stored row first_row + r < blocks * n, so s < n and block < 3;
// order[s] < n (a permutation, validated by the file reader); emission, reflectance and
// radiosity hold 3 n values; zs and z hold 3 KP / 4 vec4s.

// Lanes per row: a power of two, at most 32, and at most the adapter's smallest subgroup in
// the subgroup variant.
override ROW_LANES: u32 = 8u;
// Octets each lane takes of a row: ceil(KP / 8 / ROW_LANES).
override OCTETS_PER_LANE: u32 = 1u;
// Rows each lane takes per iteration: 1 to MAX_ROWS.
override ROWS: u32 = 1u;
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
// The most rows per lane and iteration (the size of the per-row register arrays).
const MAX_ROWS: u32 = 4u;

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
    let last = params.row_count - 1u;
    // Uniform across the workgroup: row_sum's barriers and shuffles see every lane.
    for (var base = group.x * rows * ROWS; base < params.row_count; base = base + groups.x * rows * ROWS) {
        var w: array<vec3<f32>, MAX_ROWS>;
        var s: array<u32, MAX_ROWS>;
        var block: array<u32, MAX_ROWS>;
        var id: array<u32, MAX_ROWS>;
        var rho: array<vec3<f32>, MAX_ROWS>;
        var e: array<vec3<f32>, MAX_ROWS>;
        for (var q = 0u; q < ROWS; q = q + 1u) {
            let r = min(base + q * rows + slot / ROW_LANES, last);
            let stored = params.first_row + r;
            block[q] = 0u;
            if PER_BLOCK {
                block[q] = stored / params.n;
            }
            s[q] = stored - block[q] * params.n;
            id[q] = order[s[q]];
            if FACTORED {
                let t = 3u * s[q];
                rho[q] = vec3<f32>(reflectance[t], reflectance[t + 1u], reflectance[t + 2u]);
            }
            var acc = vec3<f32>(0.0);
            for (var p = 0u; p < OCTETS_PER_LANE; p = p + 1u) {
                let j = lane + p * ROW_LANES;
                let jc = min(j, octets - 1u);
                let f = load_octet(r * octets + jc);
                var d: vec3<f32>;
                if PER_BLOCK {
                    d = vec3<f32>(dot_octet(f, block[q], jc), 0.0, 0.0);
                } else {
                    d = vec3<f32>(dot_octet(f, 0u, jc), dot_octet(f, 1u, jc), dot_octet(f, 2u, jc));
                }
                acc = acc + select(vec3<f32>(0.0), d, j < octets);
            }
            w[q] = acc;
        }
        for (var q = 0u; q < ROWS; q = q + 1u) {
            let i = 3u * id[q];
            e[q] = vec3<f32>(emission[i], emission[i + 1u], emission[i + 2u]);
        }
        for (var q = 0u; q < ROWS; q = q + 1u) {
            w[q] = row_sum(w[q], slot);
        }
        if lane == 0u {
            for (var q = 0u; q < ROWS; q = q + 1u) {
                if base + q * rows + slot / ROW_LANES > last {
                    continue;
                }
                let i = 3u * id[q];
                if PER_BLOCK {
                    let b = block[q];
                    radiosity[i + b] = e[q][b] - w[q].x;
                } else if FACTORED {
                    let b = e[q] + rho[q] * w[q];
                    radiosity[i] = b.x;
                    radiosity[i + 1u] = b.y;
                    radiosity[i + 2u] = b.z;
                } else {
                    let b = e[q] - w[q];
                    radiosity[i] = b.x;
                    radiosity[i + 1u] = b.y;
                    radiosity[i + 2u] = b.z;
                }
            }
        }
    }
}
