//! Visibility between sample points: ray casts against the scene's faces.
//!
//! The default backend is [`obvhs`] (pure Rust). A segment query asks whether anything blocks
//! the open segment between two surface points: the faces the points lie on never count (nor
//! coincident back faces), every other face does, at any scale.
//!
//! [`nothing_occludes`] detects scenes where no line of sight can be blocked (every face sees
//! all others from its front: an empty convex room, two facing squares); those bakes cast no
//! rays at all.

pub mod obvhs;
pub mod watertight;

use glam::DVec3;

use crate::formfactor::kernel::Polygon;
use crate::scene::Scene;

/// Fraction of a segment excluded at each end: only a guard against a zero parameter. The
/// faces the end points lie on are skipped by plane and orientation instead (see
/// [`PLANE_TOLERANCE`]). Excluding a relative 1e-4 of each end (the first design) let a point
/// sampled within 1e-4 of a wall's foot see through the wall: a 5e-5 leak into a closed room
/// behind a zero-thickness wall.
pub const SEGMENT_EPSILON: f32 = 1e-9;

/// Distance, relative to the scene's bounding-box diagonal, under which a segment's end point
/// counts as lying in the plane of a face parallel to its own surface: that face is its own
/// (or a coincident back face) and cannot block the segment.
pub const PLANE_TOLERANCE: f64 = 1e-6;

/// Answers "is the segment between two surface points blocked?". The normals are those of
/// the surfaces the points lie on.
pub trait Occluder: Sync {
    fn occluded(&self, from: DVec3, from_normal: DVec3, to: DVec3, to_normal: DVec3) -> bool;

    /// Answers [`Occluder::occluded`] for a bundle of segments from points of polygon `e` to
    /// points of polygon `t` (the rays of one element-target pair: short of the polygons' own
    /// faces, a coherent bundle inside the shaft between them). `blocked[i]` answers
    /// `segments[i]`. A backend may exploit the bundle (shaft culling, packets); its answers
    /// must equal the single queries'. The default asks them one by one.
    fn occluded_bundle(
        &self,
        e: &Polygon,
        t: &Polygon,
        segments: &[Segment],
        blocked: &mut [bool],
    ) {
        debug_assert_eq!(segments.len(), blocked.len());
        for (s, b) in segments.iter().zip(blocked.iter_mut()) {
            *b = self.occluded(s.from, e.normal, s.to, t.normal);
        }
    }
}

/// A line of sight between a point of an element and a point of a target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    pub from: DVec3,
    pub to: DVec3,
}

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
