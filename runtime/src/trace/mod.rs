//! The CPU ray tracer: a Whitted ray tree over an operator file's display data, shaded with a
//! frame's radiosity (cargo feature `trace`; the default build, and the C interface's, compile
//! none of it). Lights that are not surfaces and their per-frame direct pass are
//! [`lights`](crate::lights), in every build; the tracer shades their direct light at its hits.
//!
//! [`Tracer::new`] copies what the file holds for display (format 1.2): the display triangles
//! (the fan triangulation of the display faces, `OperatorFile::faces`: section FACES of format
//! 1.4, else GEOMETRY's elements; a hit on a face shows its element's radiosity), the flattened
//! binary BVH the bake built (the runtime builds none: a file without one is an error saying to
//! re-bake), materials, point lights and cameras. [`Tracer::render`] takes a [`View`] (pinhole
//! camera, vertical field of view in degrees) and a frame's [`Lighting`] (the evaluator's
//! radiosity, the light groups' intensities) and returns linear RGB radiance per pixel:
//!
//! - the radiosity of the hit point as a radiance, `B / π` (the smooth reconstruction of the
//!   file's SMOOTH weights by default, the element's flat value where a file has none);
//! - Phong highlights from every point light, each behind a shadow ray;
//! - mirror reflection and refraction (Snell, total internal reflection, Fresnel weights) as a
//!   ray tree walked with an explicit stack up to a depth limit.
//!
//! Only what the scene calls for is simulated ([`Effects`], decided per frame and explained by
//! [`Decision::text`]); the loop is monomorphised per decision. Closest-hit and any-hit
//! traversal run over the file's BVH collapsed into 4-wide nodes at load (`rays/bvh4.rs`: four
//! boxes and four triangles per SIMD test) and use the watertight ray/triangle test
//! (`rays/bvh.rs` says why); between triangles at the same distance the lower leaf-order index
//! wins. The batch API ([`Tracer::closest_hits`]) traces eight consecutive rays at a time as a
//! packet where the CPU has AVX2 (`rays/bvh4/packet8.rs`), four otherwise
//! (`rays/bvh4/packet.rs`; the same answers), the renderer its camera rays likewise.
//! Tiles of rows
//! go to std threads; the image does not depend on their number.
//!
//! The structure is the one a WGSL twin mirrors: flat arrays indexed by `u32`, fixed-size
//! stacks, no recursion, no trait objects in the hot loop (the twin traverses the binary BVH,
//! `rays/bvh.rs`'s reference loop, to the same hits).
//!
//! ```
//! use lrr_runtime::trace::{Lighting, Tracer, View};
//! # use lrr_runtime::{Operator, testkit};
//! # let mut file = testkit::synthetic::file(64, 4, 3, lrr_runtime::Precision::F32,
//! #     lrr_runtime::Layout::Factored, 1)?;
//! # file.display.bvh = Some(testkit::bvh::build(&file.geometry));
//! # let op = Operator::from_file(file)?;
//! let tracer = Tracer::new(op.file())?;
//! let camera = lrr_formats::Camera {
//!     name: String::new(),
//!     eye: [4.0, 4.0, 10.0],
//!     target: [4.0, 4.0, 0.0],
//!     up: [0.0, 1.0, 0.0],
//!     fov_y_deg: 60.0,
//! };
//! let view = View::new(&camera, 64, 48)?;
//! let radiosity = op.evaluate_baked();
//! let groups = vec![1.0; op.light_groups().len()];
//! let lighting = Lighting { radiosity: &radiosity, group_intensities: &groups, direct: None };
//! let (image, report) = tracer.render(&view, &lighting, 64, 48, 2)?;
//! assert_eq!(image.pixels.len(), 64 * 48);
//! assert!(!report.decision.effects.secondary);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod batch;
mod camera;
mod effects;
mod scene;
mod shade;
mod tracer;

pub use batch::{RayBatch, TraceHit};
pub use camera::{CameraChoiceError, CameraFields, View};
pub use effects::{DEFAULT_MAX_DEPTH, Decision, Effects, MAX_DEPTH_LIMIT};
pub use shade::RayCounts;
pub use tracer::{DirectShading, Image, Lighting, RenderReport, TILE_ROWS, Tracer};
