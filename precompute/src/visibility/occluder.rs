//! The occlusion query every backend answers, and the rules they share so they agree: the
//! own-face rule (a segment is never blocked by the faces its end points lie on), the segment
//! in coordinates relative to the scene's centre, and the tolerances.

use glam::DVec3;

use crate::geometry::Polygon;
use crate::scene::Scene;

/// Fraction of a segment excluded at each end: only a guard against a zero parameter. The
/// faces the end points lie on are skipped by plane and orientation instead (see
/// [`PLANE_TOLERANCE`]). Excluding a relative 1e-4 of each end (the first design) let a point
/// sampled within 1e-4 of a wall's foot see through the wall: a 5e-5 leak into a closed room
/// behind a zero-thickness wall.
pub(super) const SEGMENT_EPSILON: f32 = 1e-9;

/// Distance, relative to the scene's bounding-box diagonal, under which a segment's end point
/// counts as lying in the plane of a face parallel to its own surface: that face is its own
/// (or a coincident back face) and cannot block the segment.
pub(super) const PLANE_TOLERANCE: f64 = 1e-6;

/// Answers "is the segment between two surface points blocked?". The normals are those of
/// the surfaces the points lie on.
pub trait Occluder: Sync {
    /// Whether anything blocks the open segment `from → to`, ignoring the faces its end points lie on.
    fn occluded(&self, from: DVec3, from_normal: DVec3, to: DVec3, to_normal: DVec3) -> bool;

    /// Answers [`Occluder::occluded`] for a bundle of segments from points of polygon `e` to
    /// points of polygon `t` (the rays of one element-target pair: short of the polygons' own
    /// faces, a coherent bundle inside the shaft between them), each leaving `e` to its front
    /// and arriving at `t`'s front. `blocked[i]` answers `segments[i]`. `ends` are
    /// [`clear_of`](Self::clear_of) `e` and `t` (or [`Clear::NONE`]). A backend may exploit
    /// the bundle (shaft culling, packets) and the hints; its answers must equal the single
    /// queries'. The default asks them one by one.
    fn occluded_bundle(
        &self,
        e: &Polygon,
        t: &Polygon,
        ends: [Clear; 2],
        segments: &[Segment],
        blocked: &mut [bool],
    ) {
        debug_assert_eq!(segments.len(), blocked.len());
        let _ = ends;
        for (s, b) in segments.iter().zip(blocked.iter_mut()) {
            *b = self.occluded(s.from, e.normal, s.to, t.normal);
        }
    }

    /// A hint for the segments that leave polygon `p` to its front, or arrive at its front:
    /// the faces they cannot meet, for [`occluded_bundle`](Self::occluded_bundle), which
    /// checks it against the polygons it is given: answers never depend on it. The default
    /// knows none.
    fn clear_of(&self, p: &Polygon) -> Clear {
        let _ = p;
        Clear::NONE
    }

    /// The closest-hit query of this backend, when it is the one that decides which rows must
    /// sum to one (`formfactor::enclosure`: the default backend's; others build one for that,
    /// so that every backend rescales the same rows).
    fn closest_hit(&self) -> Option<&dyn ClosestHit> {
        None
    }
}

/// Which of a backend's faces the segments leaving a polygon to its front (or arriving at
/// its front) cannot meet ([`Occluder::clear_of`]; the default backend's groups,
/// `visibility::groups`): opaque to callers. A backend checks a hint against the polygon it
/// is given with, so a wrong one costs time, never an answer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Clear {
    /// The group's tag; [`NO_SKIP`]: none.
    pub(super) group: u16,
    /// The polygon's normal the hint was made for.
    pub(super) normal: DVec3,
    /// The group's support along `normal`: the largest `normal · v` over its corners
    /// (relative to the backend's centre).
    pub(super) support: f64,
}

/// A [`Clear`] group that skips nothing: never a group's tag.
pub(super) const NO_SKIP: u16 = u16::MAX;

impl Clear {
    /// No hint.
    pub const NONE: Clear = Clear {
        group: NO_SKIP,
        normal: DVec3::ZERO,
        support: f64::INFINITY,
    };
}

/// What a ray from a surface meets first ([`ClosestHit::first_hit`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FirstHit {
    /// The front of a face: light leaving that face arrives along the ray.
    Front,
    /// The back of a face (one-sided faces emit and reflect from their front only).
    Back,
    /// Nothing: the ray leaves the scene.
    Nothing,
}

/// Answers "what does this ray meet first?" under the occlusion rules of [`Occluder`].
pub trait ClosestHit: Sync {
    /// What the ray from the surface point `from` (normal `from_normal`) in the unit
    /// `direction` meets first: the front of a face, its back, or nothing (it leaves the
    /// scene). The own-face rule applies as for segments (the faces through `from` parallel to
    /// its surface are skipped); where faces are crossed at the same distance (a zero-thickness
    /// wall: two coincident faces back to back) a front among them wins.
    fn first_hit(&self, from: DVec3, from_normal: DVec3, direction: DVec3) -> FirstHit;
}

/// |cos| above which two faces count as parallel (the own-face rule).
const PARALLEL: f64 = 1.0 - 1e-5;

/// A triangle's plane: unit normal `n` and offset `n · x` of its points.
pub(crate) fn triangle_plane(t: &[DVec3; 3]) -> (DVec3, f64) {
    let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
    (n, n.dot(t[0]))
}

/// The own-face rule every backend applies: a face whose `plane` holds the end point `p`
/// (within `tolerance`) and is parallel to the point's surface (`normal`) is the face the point
/// lies on, or a coincident back face; it meets the segment only at `p` and never blocks it.
#[inline]
pub(crate) fn own_face(plane: (DVec3, f64), tolerance: f64, p: DVec3, normal: DVec3) -> bool {
    let (n, offset) = plane;
    (n.dot(p) - offset).abs() <= tolerance && n.dot(normal).abs() > PARALLEL
}

/// The segment `from → to` relative to `centre`: its start, end, unit direction and length, or
/// `None` when it is a point or not finite (a point does not block itself).
pub(crate) fn relative_segment(
    centre: DVec3,
    from: DVec3,
    to: DVec3,
) -> Option<(DVec3, DVec3, DVec3, f64)> {
    let (origin, target) = (from - centre, to - centre);
    let d = target - origin;
    let length = d.length();
    if length.is_nan() || length <= 0.0 {
        return None;
    }
    Some((origin, target, d / length, length))
}

/// A line of sight between a point of an element and a point of a target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// Start point, on the element, in scene units.
    pub from: DVec3,
    /// End point, on the target, in scene units.
    pub to: DVec3,
}

/// Triangles of `scene`'s faces (a polygon of c corners is c − 2), as the backends build them.
pub(crate) fn triangles(scene: &Scene) -> u128 {
    (scene.faces.iter())
        .map(|f| f.polygon.count.saturating_sub(2) as u128)
        .sum()
}
