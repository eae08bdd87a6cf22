//! # lrr-precompute: the bake
//!
//! Scene in, operator file out. The stages, one module each, in pipeline order:
//!
//! | stage | module | what |
//! |---|---|---|
//! | import | [`scene`] | OBJ/MTL (tobj) and lrr scene descriptions (TOML) → planar convex faces |
//! | mesh | [`mesh`] | fine elements and coarse patches: 2MF (uniform cut) or 2MSC (adaptive), clusters for dense meshes |
//! | visibility | [`visibility`] | occlusion rays (obvhs), skipped when nothing occludes |
//! | form factors | [`formfactor`] | element→patch `F_k`: closed-form kernel × visibility fraction |
//! | operator | `cores` | per-channel cores `M_c = (I - Vᵀ diag(ρ_c) F_k)⁻¹` (faer) |
//! | write | [`write`](mod@write) | the lrr-formats file, atomically |
//! | shards | [`shard`] | a bake cut into N processes (`--shard i/N`) and merged byte for byte |
//!
//! [`exact`] solves the full fine-mesh system exactly for checking; [`bake`] strings the
//! stages together; the `lrr` command line is the crate lrr-cli.
//!
//! ```
//! use lrr_precompute::{bake, progress::Progress, scene::procedural};
//! // A furnace: a closed cube, uniform reflectance 0.5, uniform emission π.
//! let scene = procedural::furnace(0.5, 1.0).build("furnace", std::path::Path::new(".")).unwrap();
//! let baked = bake::bake(&scene, &bake::BakeSettings::default(), &Progress::hidden()).unwrap();
//! let file = lrr_precompute::write::operator_file(&baked).unwrap();
//! let op = lrr_runtime::Operator::from_file(file).unwrap();
//! let b = op.evaluate_baked();
//! // B = E / (1 - ρ) = 2π everywhere.
//! assert!(b.iter().all(|b| (b[0] - 2.0 * std::f32::consts::PI).abs() < 1e-3));
//! ```

// Indexed loops over RGB channels and matrix entries read like the maths they implement.
#![allow(clippy::needless_range_loop)]
#![warn(missing_docs)]

pub mod bake;
pub mod checkpoint;
mod cores;
pub mod display;
pub mod error;
pub mod exact;
pub mod formfactor;
pub mod geometry;
pub mod lights;
mod memory;
pub mod mesh;
pub mod patches;
pub mod pool;
pub mod progress;
pub mod radiosity;
pub mod refine;
pub mod scene;
pub mod shard;
pub mod storage;
pub mod visibility;
pub mod write;

pub use error::{Error, Result};
