// fk_f32.wgsl: F_k stored as f32, for gather.wgsl (concatenated between common.wgsl and it).
// The other storage, with the same binding and `load_fk`: fk_f16.wgsl.

// A view of n x k row-major F_k: all of it, or a chunk of rows (see Params.fk_offset).
@group(0) @binding(1) var<storage, read> fk: array<f32>;

// Entry `i` of the bound view.
fn load_fk(i: u32) -> f32 {
    return fk[i];
}
