//! Rays through an operator file's display triangles: what the direct pass's shadow rays
//! ([`lights`](crate::lights)) and, with the cargo feature `trace`, the ray tracer traverse.
//!
//! - `math.rs`: `[f32; 3]` vectors.
//! - `bvh.rs`: rays, the watertight ray/triangle test and the binary traversal the WGSL twins
//!   run (the tests' reference).
//! - `bvh4.rs`: the file's BVH collapsed at load into 4-wide nodes, what the CPU traverses (any
//!   hits for shadow rays, one ray or a packet of four; closest hits, one ray or packets of four
//!   and eight, with `trace` only: `bvh4/packet8.rs` and its one `unsafe` call are compiled for
//!   the tracer alone).
//! - `scene.rs`: [`RayScene`], the display triangles and the BVH copied and checked once.
//!
//! The runtime builds no BVH: a file without one is an error saying to re-bake.

mod bvh;
mod bvh4;
mod math;
mod scene;

#[cfg(feature = "trace")]
pub(crate) use bvh::Hit;
pub(crate) use bvh::Ray;
pub(crate) use math::{V3, add, cross, dot, length, mad, normalize, scale, sub};
#[cfg(feature = "trace")]
pub(crate) use math::{max_component, mul};
pub(crate) use scene::RayScene;
#[cfg(feature = "trace")]
pub(crate) use scene::bad;
