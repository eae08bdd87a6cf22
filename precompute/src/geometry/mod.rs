//! The floor every stage stands on: planar convex polygons, regions made of several of them,
//! deterministic sample points on both, and the hash that seeds them.
//!
//! Nothing here knows about scenes, meshes, rays or form factors; every later stage (import,
//! meshing, visibility, form factors, patches) uses these types.

pub(crate) mod boxes;
pub(crate) mod cluster;
pub(crate) mod hash;
mod polygon;
mod region;
pub mod sampling;

#[cfg(test)]
pub(crate) use polygon::rectangle;
pub use polygon::{Polygon, area_vector};
pub(crate) use polygon::{at_least, within};
pub use region::{Outline, Region};
