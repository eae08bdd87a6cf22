//! # lrr-runtime: relight a baked scene
//!
//! Loads an lrr operator file and evaluates the low-rank radiosity solution
//!
//! ```text
//! B_c = E_c + ρ_c ⊙ F_k M_c (Vᵀ E_c)          (c = r, g, b; factored layout)
//! B_c = E_c - Y_c (Vᵀ E_c)                   (plain layout, Y_c = -diag(ρ_c) F_k M_c)
//! ```
//!
//! for any emission `E`, in O(nk) per frame: `X = Vᵀ E` is a segment sum over the index vector
//! (O(n), or O(k) per light group from sums stored in the file), `Z_c = M_c X_c` a k×k product,
//! and one pass over `F_k` serves all three channels. That pass reads `n·k·4` bytes (f32) or
//! `n·k·2` (f16, widened on the fly) and is the floor of a frame's cost.
//!
//! No third-party dependencies. The only `unsafe` code on the CPU is the AVX2/FMA/F16C kernel
//! (`kernel/avx2.rs`) and, with the feature `trace`, the tracer's one call of its packet
//! traversal compiled for AVX2 (`rays/bvh4/packet8.rs`), used when the CPU has those features
//! and checked against their safe twins.
//!
//! # Cargo features
//!
//! The default build is what an application calls every frame: load, evaluate (light groups,
//! albedo edits), the smooth reconstruction, lightmaps ([`Lightmap`]), and the direct pass of
//! lights that are not surfaces ([`lights`], shadow rays through the file's BVH). It compiles
//! no ray tracer.
//! - `trace`: the ray tracer that renders pictures (module `trace`: cameras, the ray
//!   tree, closest-hit traversal; `lrr render`), and with `gpu` its WGSL twin.
//! - `gpu`: the same frames on a GPU through wgpu (the only third-party dependency).
//! - `testkit`: synthetic operators, the f64 reference and the dense-`V_k` baseline, for tests
//!   and benchmarks.
//!
//! # Embedding
//!
//! ```
//! use lrr_runtime::{Operator, Rgb, RgbMut};
//! # use lrr_runtime::{Layout, Precision, testkit::synthetic};
//! # let bytes = synthetic::file(1000, 40, 3, Precision::F32, Layout::Factored, 7)?.to_bytes()?;
//!
//! // `bytes`: an operator file the application already holds, e.g. std::fs::read("cornell.lrr")?
//! let op = Operator::from_bytes(&bytes)?;
//!
//! // A persistent evaluator: 2 threads in all, every buffer allocated here, none per frame.
//! let mut eval = op.evaluator(2)?;
//! let mut emission = op.baked_emission(); // per element, original ids, RGB exitance
//! let mut radiosity = vec![[0.0f32; 3]; op.n()];
//! for frame in 0..3 {
//!     emission[0] = [frame as f32, 1.0, 1.0];
//!     eval.evaluate(Rgb::triples(&emission), RgbMut::triples(&mut radiosity))?;
//! }
//!
//! // Planar buffers work too, and light groups skip the O(n) pass over the emission.
//! let (mut r, mut g, mut b) = (vec![0.0; op.n()], vec![0.0; op.n()], vec![0.0; op.n()]);
//! let intensities = vec![1.0; op.light_groups().len()];
//! eval.evaluate_groups(&intensities, RgbMut::Planar([&mut r, &mut g, &mut b]))?;
//!
//! // Albedo edit: new k×k cores in O(nk + k³), no re-bake.
//! eval.set_reflectance(&vec![[0.5, 0.4, 0.3]; op.n()])?;
//! eval.evaluate(Rgb::triples(&emission), RgbMut::triples(&mut radiosity))?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Loading from a path is [`Operator::load`]. [`Operator::evaluate`] is the one-call form (this
//! thread, scratch allocated per call).
//!
//! # Accuracy
//!
//! `X` and `Z` are computed in f64; the pass over the stored matrix sums in f32 lanes over blocks
//! of 256 columns and adds the blocks in f64, so with the non-negative terms of a physical
//! operator a value is within about 2.5e-6 relative of an f64 evaluation of the same file
//! (`testkit::reference::evaluate`), for any n and k (tested below 1e-5 for every layout, precision,
//! thread count and buffer form, and at n = 10⁶). Storing `F_k` in f16 adds the rounding of the
//! stored values: at most 2⁻¹¹ ≈ 4.9e-4 relative per entry in the normal range, hence at most
//! 4.9e-4 relative on `ρ W` and on `B` against the f32 file (plus `k · 2⁻²⁵ max z` for entries
//! below 2⁻¹⁴, stored as f16 subnormals).
//!
//! # Modules
//!
//! Bottom first:
//! - `kernel/`: the hot loops (safe scalar twin and AVX2, [`SimdLevel`]): the gather over the
//!   stored matrix, its read roofline, the segment sums of `X = Vᵀ E`.
//! - `lu.rs`, `albedo.rs`: new cores for new reflectance.
//! - [`Operator`] (`operator.rs`): load, inspect, edit albedo; `locate.rs` the element under a
//!   surface point.
//! - `runs.rs` (the permutation as runs of ids), `pass.rs` (step 3 of a frame per block of
//!   rows), `pool.rs` (persistent threads taking chunks of rows from a queue), `frame.rs` (the
//!   other steps of a frame).
//! - [`Reconstruction`] (`smooth.rs`): smooth radiosity at any surface point from a frame's
//!   element values and the file's SMOOTH weights.
//! - [`Lightmap`] (`lightmap.rs`): a frame's radiosity as lightmap texels, one pass over a
//!   sparse table built once from the file's lightmap coordinates.
//! - [`Evaluator`] (`evaluator.rs`): frames over the pool; the one-call evaluations of
//!   [`Operator`] stand there too.
//! - `rays/`: the file's display triangles and BVH checked once, rays and the 4-wide traversal
//!   (any hits always; closest hits with `trace`).
//! - [`lights`]: lights that are not surfaces, the per-frame direct pass whose `ρ ⊙ H` the
//!   operator bounces, and the direct light at a point.
//! - `testkit` (cargo feature `testkit`): synthetic operators, the f64 reference evaluation and
//!   the papers' dense-`V_k` baseline, for tests and benchmarks.
//! - `gpu` (cargo feature `gpu`): the same frames on a GPU through wgpu.
//! - `trace` (cargo feature `trace`): the CPU ray tracer over the file's display data, shaded
//!   with a frame's radiosity.

#![deny(unsafe_code)]
#![warn(missing_docs)]
// Indexed loops over RGB channels read like the maths they implement.
#![allow(clippy::needless_range_loop)]

mod albedo;
mod error;
mod evaluator;
mod frame;
#[cfg(feature = "gpu")]
pub mod gpu;
mod kernel;
mod lightmap;
pub mod lights;
mod locate;
mod lu;
mod operator;
mod pass;
mod pool;
mod rays;
mod rgb;
mod runs;
mod smooth;
#[cfg(feature = "testkit")]
pub mod testkit;
#[cfg(feature = "trace")]
pub mod trace;

pub use error::RuntimeError;
pub use evaluator::Evaluator;
pub use kernel::SimdLevel;
pub use lightmap::{Lightmap, LightmapSample, LightmapValues, hidden_elements};
pub use lrr_formats::{FormatError, Layout, MAX_CONDITION, OperatorFile, Precision};
pub use operator::Operator;
pub use rgb::{Rgb, RgbMut};
pub use smooth::Reconstruction;
