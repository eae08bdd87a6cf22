//! Visibility between sample points: ray casts against the scene's faces.
//!
//! The default backend is [`obvhs`] (pure Rust). With the cargo feature `embree`, `embree`
//! answers the same queries through Embree 4 (`lrr bake --visibility embree`). A segment query
//! asks whether anything blocks the open segment between two surface points: the faces the
//! points lie on never count (nor coincident back faces), every other face does, at any scale.
//! The recorder of a bake's segments (to compare backends on the same rays) lives in the
//! command line crate (`lrr_cli::record`).
//!
//! [`nothing_occludes`] detects scenes where no line of sight can be blocked (every face sees
//! all others from its front: an empty convex room, two facing squares); those bakes cast no
//! rays at all.

#[cfg(feature = "embree")]
pub mod embree;
mod flat;
mod groups;
pub mod obvhs;
mod occluder;
mod watertight;

use crate::error::Result;
use crate::scene::Scene;

pub use occluder::{Clear, ClosestHit, FirstHit, Occluder, Segment};

/// Which implementation answers the occlusion queries of a bake (`--visibility`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Backend {
    /// The pure-Rust BVH of [`obvhs`] with the exact f64 triangle test (the default).
    #[default]
    Obvhs,
    /// Embree 4 single-ray occlusion (`rtcOccluded1`); needs the cargo feature `embree`.
    Embree,
}

impl Backend {
    /// The name `--visibility` takes and the file metadata records.
    pub fn name(self) -> &'static str {
        match self {
            Backend::Obvhs => "obvhs",
            Backend::Embree => "embree",
        }
    }

    /// True when this build can use the backend (Embree needs the cargo feature `embree`).
    pub fn available(self) -> bool {
        match self {
            Backend::Obvhs => true,
            Backend::Embree => cfg!(feature = "embree"),
        }
    }

    /// Builds the backend's acceleration structure over the scene's surfaces: its faces, with
    /// each planar group whose union is one convex polygon taken whole
    /// (`mesh::occluder_faces`), so that a finer tessellation of the same surfaces does not
    /// deepen every ray's traversal. Embree is held to 80% of the memory available, as
    /// [`build_within`](Self::build_within) without `--max-memory`.
    pub fn build(self, scene: &Scene) -> Result<Box<dyn Occluder>> {
        self.build_within(scene, None)
    }

    /// [`build`](Self::build) under `max_memory` (`--max-memory`; none: 80% of what is
    /// available). Embree's own allocations are held by its memory monitor to what the limit
    /// leaves beside the arrays kept for its filter (`EmbreeOccluder::build_within`); the
    /// default backend allocates what [`build_bytes`](Self::build_bytes) plans.
    pub fn build_within(
        self,
        scene: &Scene,
        #[cfg_attr(not(feature = "embree"), allow(unused_variables))] max_memory: Option<u64>,
    ) -> Result<Box<dyn Occluder>> {
        let merged = crate::mesh::occluder_faces(scene).map(|faces| {
            let mut s = Scene::default();
            s.faces = faces;
            s
        });
        let scene = merged.as_ref().unwrap_or(scene);
        match self {
            Backend::Obvhs => Ok(Box::new(obvhs::ObvhsOccluder::build(scene))),
            #[cfg(feature = "embree")]
            Backend::Embree => Ok(Box::new(embree::EmbreeOccluder::build_within(
                scene, max_memory,
            )?)),
            #[cfg(not(feature = "embree"))]
            Backend::Embree => Err(crate::error::Error::Settings(EMBREE_MISSING.into())),
        }
    }

    /// What this backend's build over `scene` may hold at once, planned before it starts:
    /// [`BUILD_BYTES_PER_TRIANGLE`] for each triangle of its faces, and Embree's device
    /// ([`EMBREE_DEVICE_BYTES`]).
    pub(crate) fn build_bytes(self, scene: &Scene) -> u128 {
        let device = match self {
            Backend::Obvhs => 0,
            Backend::Embree => EMBREE_DEVICE_BYTES,
        };
        occluder::triangles(scene) * BUILD_BYTES_PER_TRIANGLE + device
    }
}

/// Bytes a backend's build may hold at once, per triangle of the scene (a quad is two),
/// planned before it starts. The default backend holds per triangle: the scene's faces merged
/// into convex planar groups (`mesh::occluder_faces`: a copy of each face, about 300 bytes,
/// fewer where faces merge); the triangle in f32 (48) and in f64 (72, twice: in input and in
/// BVH order), its plane (32) and box (32); obvhs' PLOC build, per primitive, two arrays of
/// leaf nodes (48 each), the binary tree's two nodes (96), Morton codes and indices (40), all
/// freed before the leaf collapse copies the tree (96); then the 4-wide tree (under 64);
/// then its groups (`groups`, counted, not measured: a corner's id in a hash map, its
/// position twice and its union-find entries, a triangle's corner ids, tag and place in its
/// group, and a closed group's edges, about 100 bytes a triangle while they are made where
/// corners are shared, up to about 400 for a soup of triangles that share none; 20 kept,
/// after the f32 triangles, their boxes and the input-order f64 copy are freed). About 1 KiB at the most, 0.85 KiB with the PLOC buffers gone before the collapse.
///
/// Measured as the rise of the resident peak over the build, the peak reset as it began
/// (2 threads; 2026-11-29; triangles of the faces as imported, before the planar merge):
/// zdm2's 57 645 triangles 694 bytes a triangle, a box-sphere's 397 650 478, the 256× dense
/// sphere's 20 500 587. Embree (`--visibility embree`, build quality HIGH) on the same scenes:
/// 564, 453 and 666, of which 144–150 are its own allocations (its memory monitor's peak: the
/// triangle buffers and the BVH) and the rest the merged faces and the exact triangles and
/// planes its filter reads.
pub(crate) const BUILD_BYTES_PER_TRIANGLE: u128 = 1024;

/// What an Embree device takes whatever the scene, planned beside its triangles: measured
/// 1.8 MB (the Cornell box, 38 triangles) and 2.5 MB (the building, 930) on 2 cores. Its task
/// scheduler starts a thread per core, so a larger machine takes somewhat more.
pub(crate) const EMBREE_DEVICE_BYTES: u128 = 8 << 20;

/// What `--visibility embree` says in a build without the feature.
#[cfg(not(feature = "embree"))]
const EMBREE_MISSING: &str = "--visibility embree: this lrr was built without Embree; \
    run scripts/setup-embree.sh, then rebuild with `cargo build --release --features embree` \
    (or use the default --visibility obvhs)";

/// Most faces for which the quadratic convexity test is run; larger scenes are assumed to
/// have occluders.
const MAX_FACES_FOR_CONVEXITY_TEST: usize = 4096;

/// True when no face can block a line of sight between two others: every vertex of the scene
/// lies on the closed front side of every face's plane (then a segment between two front-facing
/// points never crosses a face).
pub fn nothing_occludes(scene: &Scene) -> bool {
    if scene.faces.len() > MAX_FACES_FOR_CONVEXITY_TEST {
        return false;
    }
    let tol = 1e-9 * scene.extent();
    scene.faces.iter().all(|f| {
        scene
            .faces
            .iter()
            .flat_map(|g| g.polygon.vertices())
            .all(|v| f.polygon.height(*v) >= -tol)
    })
}

/// Scenes and checks the backends' unit tests share.
#[cfg(test)]
pub(crate) mod fixtures {
    use std::path::Path;

    use glam::DVec3;

    use super::Occluder;
    use crate::scene::description::{BoxDesc, SceneDescription};
    use crate::scene::{Scene, procedural};

    /// The furnace room (unit cube) with a 0.2 × 0.2 × 0.5 block standing on its floor.
    pub fn block_in_a_room() -> Scene {
        let mut d = procedural::furnace(0.5, 1.0);
        d.boxes.push(BoxDesc {
            name: "block".into(),
            material: "wall".into(),
            min: [0.4, 0.4, 0.0],
            max: [0.6, 0.6, 0.5],
            inward: false,
            omit: vec!["-z".into()],
        });
        d.build("c", Path::new(".")).unwrap()
    }

    /// In [`block_in_a_room`]: blocked through the block, free to the ceiling, free along the
    /// floor between the two walls the end points lie on.
    pub fn assert_block_casts_a_shadow(occ: &dyn Occluder) {
        let floor = DVec3::new(0.1, 0.5, 0.0);
        assert!(occ.occluded(floor, DVec3::Z, DVec3::new(1.0, 0.5, 0.2), -DVec3::X));
        assert!(!occ.occluded(floor, DVec3::Z, DVec3::new(0.1, 0.5, 1.0), -DVec3::Z));
        assert!(!occ.occluded(
            DVec3::new(0.0, 0.1, 0.5),
            DVec3::X,
            DVec3::new(1.0, 0.1, 0.5),
            -DVec3::X
        ));
    }

    /// Two closed unit rooms (inward boxes) touching at zero-thickness walls: the second's
    /// minimum corner is `offset` (`[1, 0, 0]`: side by side; `[1, 1, 0]`: meeting at an edge).
    pub fn two_rooms(offset: [u32; 3]) -> Scene {
        let [x, y, z] = offset;
        let text = format!(
            "[[material]]\nname = \"w\"\nreflectance = [0.5, 0.5, 0.5]\n\
             [[box]]\nname = \"a\"\nmaterial = \"w\"\nmin = [0, 0, 0]\nmax = [1, 1, 1]\ninward = true\n\
             [[box]]\nname = \"b\"\nmaterial = \"w\"\nmin = [{x}, {y}, {z}]\n\
             max = [{}, {}, {}]\ninward = true\n",
            x + 1,
            y + 1,
            z + 1
        );
        let d = SceneDescription::parse(&text, "t").unwrap();
        d.build("t", Path::new(".")).unwrap()
    }

    /// Random segments from the first of [`two_rooms`]`([1, 1, 0])` to the second: every one
    /// crosses a wall, many near the shared edge.
    pub fn corner_segments(count: usize) -> impl Iterator<Item = (DVec3, DVec3)> {
        let mut state = 0x9e37_79b9u64;
        let mut next = move || {
            state = crate::geometry::hash::mix(state);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..count).map(move |_| {
            let from = DVec3::new(next(), next(), next());
            let to = DVec3::new(1.0 + next(), 1.0 + next(), next());
            (from, to)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::procedural;
    use std::path::Path;

    #[test]
    fn convex_scenes_are_recognised() {
        let furnace = procedural::furnace(0.5, 1.0)
            .build("f", Path::new("."))
            .unwrap();
        assert!(nothing_occludes(&furnace));
        let pair = procedural::parallel_squares(1.0, 1.0)
            .build("p", Path::new("."))
            .unwrap();
        assert!(nothing_occludes(&pair));
        let mut d = procedural::furnace(0.5, 1.0);
        d.boxes.push(crate::scene::description::BoxDesc {
            name: "block".into(),
            material: "wall".into(),
            min: [0.4; 3],
            max: [0.6; 3],
            inward: false,
            omit: vec![],
        });
        let cluttered = d.build("c", Path::new(".")).unwrap();
        assert!(!nothing_occludes(&cluttered));
    }
}
