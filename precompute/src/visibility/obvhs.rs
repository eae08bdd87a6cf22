//! Occlusion queries through a BVH built by obvhs (pure Rust) and traversed by our own code.
//!
//! Build: obvhs' PLOC binary BVH (`medium_build` preset with `search_depth_threshold = 0`; the
//! stock value 3 made traversal of grid-tessellated walls about 30× slower in our measurements
//! with obvhs' traversal; at most 2 triangles per leaf, leaf-collapse cost 1), collapsed into
//! the flat 4-wide BVH of `flat` (four f32 slab tests per node, an any-hit traversal). Before
//! it, obvhs' compressed wide BVH (`CwBvh::ray_traverse_miss`) answered the queries at about
//! 0.85–1.1× Embree's rate on the bake's rays; the flat 4-wide BVH at 1.2–1.5×
//! (docs/PERFORMANCE.md).
//! Triangles are tested with the watertight test of `watertight`, not obvhs' own.
//! Coordinates are shifted to the scene's centre before the f32 conversion to keep precision,
//! and scaled by a power of two to a diagonal of 2048..4096 (see `F32_DIAGONAL`).
//!
//! The BVH only proposes candidates; every decision is the exact f64 test, or what it must
//! answer (the groups of `groups`: a closed surface's balls, a polygon's hint), so the
//! traversal must never cull a face the exact test would call crossed. obvhs' own traversal did: its
//! node test ignores `Ray::tmin` and culls every box the ray leaves before t = 1e-4 in absolute
//! units, so in a scene a few units across a wall crossed within ~1e-4 of a segment's start
//! (its padded box left before 1e-4) was never tested (5365 of 16 000 segments starting
//! 1e-7..1e-4 diagonals from a wall missed it at size 1, 5186 of 16 000 at size 0.01, none at
//! size 1000); and a direction component of -0.0 made every box test fail. The unit tests
//! below keep both cases.

use glam::{DVec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::triangle::Triangle;

use super::flat::{Enter, FlatBvh, FlatRay, Hit, NO_GROUP};
use super::groups::{Ball, Groups, MARGIN, lowest};
use super::occluder::{
    Clear, ClosestHit, FirstHit, NO_SKIP, Occluder, PLANE_TOLERANCE, SEGMENT_EPSILON, Segment,
    own_face, relative_segment, triangle_plane,
};
use super::watertight::ShearedRay;
use crate::geometry::Polygon;
use crate::scene::Scene;

/// The scene's diagonal in the f32 coordinates of the BVH is scaled (by a power of two) into
/// `(F32_DIAGONAL / 2, F32_DIAGONAL]`.
///
/// Why: the traversal's culling must stay conservative: a face crossed at t_c ≥ 0 has a padded
/// box the ray leaves at t ≥ t_c + pad (pad = [`PLANE_TOLERANCE`] × diagonal, the box's
/// half-thickness: a unit direction moves no coordinate faster than 1), minus f32 rounding (a
/// few ulps of the coordinates, well under pad), so the interval `[0, length]` always meets it.
/// A power of two scales exactly, so the f32 precision relative to the diagonal is that of any
/// scale, and no coordinate, distance or inverse direction over- or underflows f32 however
/// large or small the scene. (The scaling was introduced for obvhs' `CwBvh` traversal, which
/// clamped the entry distance to an absolute 1e-4: at this diagonal pad ≥ 2e-3 ≥ 20 × 1e-4.)
/// The faces through the start point (its own face, a wall it stands on) are always
/// candidates; the own-face rule answers those.
const F32_DIAGONAL: f64 = 4096.0;

/// How far outside a group's outer ball, relative to the scene's diagonal, both ends of a
/// segment must lie for its inner ball to answer "blocked" (`groups::Ball`): far above the
/// part of the segment the exact test leaves out at each end (`SEGMENT_EPSILON` of its
/// length), and far enough that an end within the own-face rule's tolerance
/// ([`PLANE_TOLERANCE`]) of a plane keeps the segment within `2 × PLANE_TOLERANCE /
/// BALL_CLEARANCE` of the outer radius of that plane over the ball (the inner ball is taken
/// that much smaller).
const BALL_CLEARANCE: f64 = 1e-3;

/// The default occluder: a flat 4-wide BVH (f32 traversal, built by obvhs) with the exact f64
/// triangle test.
pub struct ObvhsOccluder {
    bvh: FlatBvh,
    /// The triangles in f64 (relative to `centre`) in BVH primitive order, for the exact test.
    exact: Vec<[DVec3; 3]>,
    /// Their planes (unit normal, offset), same order.
    planes: Vec<(DVec3, f64)>,
    centre: DVec3,
    /// Factor (a power of two) from coordinates relative to `centre` to the BVH's f32 ones.
    scale: f64,
    /// Distance under which an end point counts as lying in a triangle's plane.
    plane_tolerance: f64,
    /// The scene's bounding-box diagonal: no ray from inside the box is longer inside it.
    diagonal: f64,
    /// The connected pieces the BVH's children are tagged with (`groups`), for the hints of
    /// [`Occluder::clear_of`].
    groups: Groups,
}

impl ObvhsOccluder {
    /// Builds the BVH over the scene's faces (quads as two triangles).
    pub fn build(scene: &Scene) -> Self {
        let (lo, hi) = scene.bounds();
        let centre = (lo + hi) * 0.5;
        let scale = f32_scale((hi - lo).length());
        let to_f32 = |v: DVec3| Vec3A::from(((v - centre) * scale).as_vec3());
        let mut tris = Vec::with_capacity(scene.faces.len() * 2);
        let mut exact_tris = Vec::with_capacity(scene.faces.len() * 2);
        for f in &scene.faces {
            let v = f.polygon.vertices();
            for i in 1..v.len() - 1 {
                exact_tris.push([v[0] - centre, v[i] - centre, v[i + 1] - centre]);
                tris.push(Triangle {
                    v0: to_f32(v[0]),
                    v1: to_f32(v[i]),
                    v2: to_f32(v[i + 1]),
                });
            }
        }
        let params = BvhBuildParams {
            search_depth_threshold: 0,
            max_prims_per_leaf: 2,
            collapse_traversal_cost: 1.0,
            ..BvhBuildParams::medium_build()
        };
        // Boxes padded by a hair: an axis-aligned wall has a box of zero thickness, which the
        // traversal's slab test can reject for rays that cross it (a corner leak we measured).
        let pad = Vec3A::splat((PLANE_TOLERANCE * (hi - lo).length() * scale) as f32);
        let boxes: Vec<Aabb> = tris
            .iter()
            .map(|t| {
                let b = t.aabb();
                Aabb::new(b.min - pad, b.max + pad)
            })
            .collect();
        let mut bvh = FlatBvh::build(&boxes, params);
        drop((tris, boxes));
        let exact: Vec<[DVec3; 3]> = bvh.order.iter().map(|&i| exact_tris[i as usize]).collect();
        drop(exact_tris);
        let planes: Vec<(DVec3, f64)> = exact.iter().map(triangle_plane).collect();
        let (groups, tags) = Groups::of(&exact, &planes);
        bvh.tag(&tags);
        drop(tags);
        let plane_tolerance = PLANE_TOLERANCE * (hi - lo).length();
        Self {
            bvh,
            exact,
            planes,
            centre,
            scale,
            plane_tolerance,
            diagonal: (hi - lo).length(),
            groups,
        }
    }

    /// Whether the segment (relative to `centre`: start, end, unit direction, length) is
    /// blocked, the children tagged with a group in `skip` not entered, and a closed group
    /// answered by its balls where they decide (`groups::Ball`); `None`: by the triangles
    /// alone (what the groups must agree with, for tests).
    #[inline]
    fn segment_blocked(
        &self,
        (origin, target, direction, length): (DVec3, DVec3, DVec3, f64),
        from_normal: DVec3,
        to_normal: DVec3,
        skip: Option<[u16; 2]>,
    ) -> bool {
        // The BVH is traversed in f32 (scaled coordinates, see `F32_DIAGONAL`) over a slightly
        // longer range (culling stays conservative under rounding); the decision is the exact
        // f64 test over the segment. A face crossed at the very start is still entered: its
        // padded box reaches past t = 0. (Zero and -0.0 direction components are handled by
        // `FlatRay`, consistently with the near side it picks.)
        let scaled = length * self.scale;
        let ray = FlatRay::new(
            Vec3A::from((origin * self.scale).as_vec3()),
            Vec3A::from(direction.as_vec3()),
            0.0,
            (scaled * (1.0 + 1e-5)) as f32,
        );
        let eps = f64::from(SEGMENT_EPSILON) * length;
        let sheared = ShearedRay::new(origin, direction, eps, length - eps);
        let mut known = (NO_GROUP, Enter::Yes);
        let decide = |group: u16| {
            let Some(skip) = skip else {
                return Enter::Yes;
            };
            if group == skip[0] || group == skip[1] {
                return Enter::No;
            }
            if group != known.0 {
                let ball = self.groups.balls[group as usize - 1];
                let answer = ball.map_or(Enter::Yes, |b| {
                    self.by_ball(&b, (origin, target, direction, length))
                });
                known = (group, answer);
            }
            known.1
        };
        let hit = self.bvh.any_hit_by_group(&ray, decide, |id| {
            // The face an end point lies on (or a coincident back face) meets the segment
            // only at that end point: skip it, whatever the rounding says. Every other face
            // counts over the whole segment, however close to an end point it is crossed.
            if self.own_face(id, origin, from_normal) || self.own_face(id, target, to_normal) {
                return false;
            }
            let [a, b, c] = self.exact[id];
            sheared.hit(a, b, c).is_some()
        });
        hit != Hit::Nothing
    }

    /// What a closed group's balls say of the segment: it keeps out of the outer ball
    /// ([`Enter::No`]); it passes through the inner one, both ends outside the outer one by
    /// [`BALL_CLEARANCE`] (so that the surface is crossed well inside the part of the segment
    /// the exact test looks at): [`Enter::Blocked`]; otherwise the group's triangles decide.
    #[inline]
    fn by_ball(
        &self,
        ball: &Ball,
        (origin, target, direction, length): (DVec3, DVec3, DVec3, f64),
    ) -> Enter {
        let margin = MARGIN * self.diagonal;
        let t = (ball.centre - origin).dot(direction).clamp(0.0, length);
        let distance = (origin + direction * t).distance(ball.centre);
        if distance > ball.outer + margin {
            return Enter::No;
        }
        let outside = ball.outer + BALL_CLEARANCE * self.diagonal;
        // An end within the own-face rule's tolerance of the plane of the triangle the
        // segment crosses by keeps the segment within this of that plane over the ball.
        let tilt = 2.0 * PLANE_TOLERANCE / BALL_CLEARANCE * ball.outer;
        if distance < ball.inner - tilt - margin
            && origin.distance(ball.centre) > outside
            && target.distance(ball.centre) > outside
        {
            return Enter::Blocked;
        }
        Enter::Yes
    }

    /// [`Occluder::occluded`] by the triangles alone, without the groups' hints and balls.
    #[cfg(test)]
    fn occluded_by_triangles(
        &self,
        from: DVec3,
        from_normal: DVec3,
        to: DVec3,
        to_normal: DVec3,
    ) -> bool {
        relative_segment(self.centre, from, to)
            .is_some_and(|s| self.segment_blocked(s, from_normal, to_normal, None))
    }

    /// How far above a group's support plane a segment must stay for a hint to skip the
    /// group (`groups::MARGIN` of the scene's size: its sample points are rounded in world
    /// coordinates).
    fn hint_margin(&self) -> f64 {
        MARGIN * (self.diagonal + self.centre.abs().max_element())
    }

    /// Number of groups of faces the BVH's children are tagged with (`groups`).
    pub fn group_count(&self) -> usize {
        self.groups.len()
    }

    /// Which triangles block the segment, tested one by one without the BVH (a cross-check of
    /// the traversal for tests; ignores the own-face rule).
    pub fn blockers_brute_force(&self, from: DVec3, to: DVec3) -> Vec<usize> {
        let (origin, target) = (from - self.centre, to - self.centre);
        let d = target - origin;
        let length = d.length();
        let eps = f64::from(SEGMENT_EPSILON) * length;
        let sheared = ShearedRay::new(origin, d / length, eps, length - eps);
        (0..self.exact.len())
            .filter(|&i| {
                let [a, b, c] = self.exact[i];
                sheared.hit(a, b, c).is_some()
            })
            .collect()
    }

    /// True when triangle `id` is the face a point `p` (relative to `centre`) with surface
    /// normal `normal` lies on, or a coincident back face: it cannot block a segment from `p`.
    #[inline]
    fn own_face(&self, id: usize, p: DVec3, normal: DVec3) -> bool {
        own_face(self.planes[id], self.plane_tolerance, p, normal)
    }

    /// Number of triangles in the BVH (quads count twice).
    pub fn triangle_count(&self) -> usize {
        self.exact.len()
    }
}

/// The power of two that brings a scene diagonal into `(F32_DIAGONAL / 2, F32_DIAGONAL]`
/// (1 for a diagonal that is zero or not finite).
fn f32_scale(diagonal: f64) -> f64 {
    if !(diagonal.is_finite() && diagonal > 0.0) {
        return 1.0;
    }
    let exponent = (F32_DIAGONAL / diagonal)
        .log2()
        .floor()
        .clamp(-900.0, 900.0);
    2f64.powi(exponent as i32)
}

impl ClosestHit for ObvhsOccluder {
    fn first_hit(&self, from: DVec3, from_normal: DVec3, direction: DVec3) -> FirstHit {
        let origin = from - self.centre;
        let length = 2.0 * self.diagonal;
        if !(origin.is_finite() && direction.is_finite() && length > 0.0) {
            return FirstHit::Nothing;
        }
        let ray = FlatRay::new(
            Vec3A::from((origin * self.scale).as_vec3()),
            Vec3A::from(direction.as_vec3()),
            0.0,
            (length * self.scale * (1.0 + 1e-5)) as f32,
        );
        let eps = f64::from(SEGMENT_EPSILON) * length;
        let sheared = ShearedRay::new(origin, direction, eps, length);
        let (mut front, mut back) = (f64::INFINITY, f64::INFINITY);
        // Every candidate is decided (no early exit): the nearest of each kind is wanted.
        self.bvh.any_hit(&ray, |id| {
            if self.own_face(id, origin, from_normal) {
                return false;
            }
            let [a, b, c] = self.exact[id];
            if let Some(t) = sheared.hit(a, b, c) {
                if self.planes[id].0.dot(direction) < 0.0 {
                    front = front.min(t);
                } else {
                    back = back.min(t);
                }
            }
            false
        });
        if front.is_finite() && front <= back + self.plane_tolerance {
            FirstHit::Front
        } else if back.is_finite() {
            FirstHit::Back
        } else {
            FirstHit::Nothing
        }
    }
}

impl Occluder for ObvhsOccluder {
    fn closest_hit(&self) -> Option<&dyn ClosestHit> {
        Some(self)
    }

    fn occluded(&self, from: DVec3, from_normal: DVec3, to: DVec3, to_normal: DVec3) -> bool {
        let Some(segment) = relative_segment(self.centre, from, to) else {
            return false; // a point does not block itself
        };
        self.segment_blocked(segment, from_normal, to_normal, Some([NO_SKIP; 2]))
    }

    /// One by one, as [`Occluder::occluded`], but a segment that keeps clear of an end's
    /// group (`groups`: `clearance + ε·s` above the group's support plane, `s` the cosine
    /// at that end) does not enter the BVH children of that group.
    fn occluded_bundle(
        &self,
        e: &Polygon,
        t: &Polygon,
        ends: [Clear; 2],
        segments: &[Segment],
        blocked: &mut [bool],
    ) {
        debug_assert_eq!(segments.len(), blocked.len());
        let margin = self.hint_margin();
        // Each hint checked against the polygon it is given with: made for its normal, and
        // the polygon's height over the group's support plane worked out here.
        let clearance = |p: &Polygon, end: Clear| {
            if end.group == NO_SKIP || p.normal != end.normal {
                f64::NEG_INFINITY
            } else {
                lowest(p, self.centre) - end.support
            }
        };
        let clearances = [clearance(e, ends[0]), clearance(t, ends[1])];
        for (s, b) in segments.iter().zip(blocked.iter_mut()) {
            let Some(segment) = relative_segment(self.centre, s.from, s.to) else {
                *b = false; // a point does not block itself
                continue;
            };
            let (direction, length) = (segment.2, segment.3);
            let eps = f64::from(SEGMENT_EPSILON) * length;
            // At `t` from the end the segment is `clearance + t · cosine` above the plane;
            // the exact test looks from `t = eps` on.
            let clear = |end: usize, cosine: f64| {
                if cosine > 0.0 && clearances[end] + eps * cosine > margin {
                    ends[end].group
                } else {
                    NO_SKIP
                }
            };
            let skip = [
                clear(0, direction.dot(e.normal)),
                clear(1, -direction.dot(t.normal)),
            ];
            *b = self.segment_blocked(segment, e.normal, t.normal, Some(skip));
        }
    }

    fn clear_of(&self, p: &Polygon) -> Clear {
        self.groups.clear_of(p, self.centre, self.hint_margin())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::visibility::fixtures;

    #[test]
    fn block_in_a_room_casts_a_shadow() {
        let scene = fixtures::block_in_a_room();
        fixtures::assert_block_casts_a_shadow(&ObvhsOccluder::build(&scene));
    }

    /// Two closed rooms of side `size` (inward boxes) touching at zero-thickness walls: the
    /// second's minimum corner is `offset · size`.
    fn rooms(size: f64, offset: [f64; 3]) -> Scene {
        let [x, y, z] = offset.map(|o| o * size);
        let text = format!(
            "[[material]]\nname = \"w\"\nreflectance = [0.5, 0.5, 0.5]\n\
             [[box]]\nname = \"a\"\nmaterial = \"w\"\nmin = [0.0, 0.0, 0.0]\n\
             max = [{size:?}, {size:?}, {size:?}]\ninward = true\n\
             [[box]]\nname = \"b\"\nmaterial = \"w\"\nmin = [{x:?}, {y:?}, {z:?}]\n\
             max = [{:?}, {:?}, {:?}]\ninward = true\n",
            x + size,
            y + size,
            z + size
        );
        let d = crate::scene::description::SceneDescription::parse(&text, "t").unwrap();
        d.build("t", std::path::Path::new(".")).unwrap()
    }

    /// The answer `occluded` must give: a face the exact test says is crossed that is not the
    /// own face of either end point (brute force over all triangles).
    fn expected(
        occ: &ObvhsOccluder,
        from: DVec3,
        fnormal: DVec3,
        to: DVec3,
        tnormal: DVec3,
    ) -> bool {
        let (origin, target) = (from - occ.centre, to - occ.centre);
        occ.blockers_brute_force(from, to)
            .into_iter()
            .any(|i| !occ.own_face(i, origin, fnormal) && !occ.own_face(i, target, tnormal))
    }

    #[test]
    fn walls_crossed_next_to_the_start_are_found() {
        // Segments starting within 1e-7..1e-4 of the diagonal of a zero-thickness wall (either
        // side, or exactly on it) and crossing it (or the corner edge) into the other room, the
        // start's normal never parallel to the wall. Several scales: the traversal's own
        // epsilon is absolute.
        let mut state = 0x5eed_u64;
        let mut next = move || {
            state = crate::geometry::hash::mix(state);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut failures = Vec::new();
        let mut blocked = 0;
        let mut total = 0;
        for size in [0.01, 1.0, 1000.0] {
            for offset in [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0]] {
                let scene = rooms(size, offset);
                let occ = ObvhsOccluder::build(&scene);
                let diagonal = scene.extent();
                let inside = |lo: [f64; 3], next: &mut dyn FnMut() -> f64| {
                    DVec3::from_array(lo.map(|l| (l + 0.05 + 0.9 * next()) * size))
                };
                for _ in 0..8000 {
                    // The start: a point of room a moved onto or next to a shared wall.
                    let mut from = inside([0.0; 3], &mut next);
                    let axis = if offset[1] > 0.0 && next() < 0.5 {
                        1
                    } else {
                        0
                    };
                    let distance = if next() < 0.125 {
                        0.0
                    } else {
                        diagonal * 10f64.powf(-7.0 + 3.0 * next())
                    };
                    let side = if next() < 0.5 { -1.0 } else { 1.0 };
                    from[axis] = size + side * distance;
                    // The end: inside the room across the wall.
                    let to = if side > 0.0 {
                        inside([0.0; 3], &mut next)
                    } else {
                        inside(offset, &mut next)
                    };
                    let mut from_normal = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
                    from_normal[axis] = 0.0;
                    let from_normal = from_normal.normalize_or(DVec3::Z);
                    let want = expected(&occ, from, from_normal, to, DVec3::Z);
                    let got = occ.occluded(from, from_normal, to, DVec3::Z);
                    total += 1;
                    blocked += usize::from(want);
                    if got != want {
                        failures.push((size, offset, from, to, want));
                    }
                }
            }
        }
        assert!(blocked > total / 2, "{blocked} of {total} blocked");
        assert!(
            failures.is_empty(),
            "{} of {total} disagree with brute force ({} at size 0.01, {} at 1, {} at 1000), \
             e.g. {:?}",
            failures.len(),
            failures.iter().filter(|f| f.0 == 0.01).count(),
            failures.iter().filter(|f| f.0 == 1.0).count(),
            failures.iter().filter(|f| f.0 == 1000.0).count(),
            &failures[..failures.len().min(5)]
        );
    }

    #[test]
    fn a_negative_zero_direction_component_still_finds_walls() {
        // A scene centred at x = 0: from x = +0 to x = -0 the direction's x is -0.0.
        let text = "[[material]]\nname = \"w\"\nreflectance = [0.5, 0.5, 0.5]\n\
             [[box]]\nname = \"a\"\nmaterial = \"w\"\nmin = [-1, 0, 0]\nmax = [1, 1, 1]\ninward = true\n\
             [[box]]\nname = \"b\"\nmaterial = \"w\"\nmin = [-1, 1, 0]\nmax = [1, 2, 1]\ninward = true\n";
        let d = crate::scene::description::SceneDescription::parse(text, "t").unwrap();
        let occ = ObvhsOccluder::build(&d.build("t", std::path::Path::new(".")).unwrap());
        for (x0, x1) in [(0.0, -0.0), (-0.0, 0.0), (0.0, -1e-300), (0.0, 0.0)] {
            let from = DVec3::new(x0, 0.5, 0.5);
            let to = DVec3::new(x1, 1.5, 0.3);
            assert!(expected(&occ, from, DVec3::Z, to, DVec3::Z));
            assert!(
                occ.occluded(from, DVec3::Z, to, DVec3::Z),
                "{x0:?} → {x1:?}"
            );
        }
    }

    /// A room 4 units wide holding a sphere of radius 1 (an icosphere of 5 120 triangles, one
    /// closed group) and a second sphere of radius 0.5 (320 triangles) 1e-7 from the first.
    fn spheres_in_a_room() -> (Scene, Vec<[DVec3; 3]>) {
        use crate::scene::description::{SceneDescription, SurfaceDesc};
        let text = "[[material]]\nname = \"w\"\nreflectance = [0.5, 0.5, 0.5]\n\
             [[box]]\nname = \"room\"\nmaterial = \"w\"\nmin = [0, 0, 0]\nmax = [4, 4, 4]\ninward = true\n";
        let mut d = SceneDescription::parse(text, "t").unwrap();
        let mut tris = Vec::new();
        for (name, centre, radius, levels) in [
            ("big", [2.0, 2.0, 2.0], 1.0, 4),
            ("small", [2.0, 2.0, 3.5 + 1e-7], 0.5, 2),
        ] {
            let polygons = crate::scene::procedural::icosphere(levels, centre, radius);
            tris.extend(
                polygons
                    .iter()
                    .map(|p| [0, 1, 2].map(|i| DVec3::from_array(p[i]))),
            );
            let surface = SurfaceDesc {
                name: name.into(),
                material: "w".into(),
                polygons,
                ..Default::default()
            };
            d.surfaces.push(surface.indexed());
        }
        (d.build("t", std::path::Path::new(".")).unwrap(), tris)
    }

    /// The balls and the hints answer every segment as the triangles do: segments between the
    /// walls, the spheres' faces, points just outside a sphere's outer ball and points inside
    /// it, with the balls and hints deciding many of them.
    #[test]
    fn groups_answer_as_the_triangles_do() {
        let (scene, tris) = spheres_in_a_room();
        let occ = ObvhsOccluder::build(&scene);
        assert_eq!(occ.group_count(), 2);
        let balls: Vec<Ball> = occ.groups.balls.iter().map(|b| b.unwrap()).collect();
        let mut state = 0x5eed_u64;
        let mut next = move || {
            state = crate::geometry::hash::mix(state);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        // A point and its normal: on a wall, on a sphere's face (outwards), just outside the
        // big sphere's outer ball, or inside it.
        let mut point = |kind: u32| -> (DVec3, DVec3, Option<Polygon>) {
            match kind {
                0 => {
                    let (u, v) = (4.0 * next(), 4.0 * next());
                    let (p, n) = match (next() * 6.0) as u32 {
                        0 => (DVec3::new(u, v, 0.0), DVec3::Z),
                        1 => (DVec3::new(u, v, 4.0), -DVec3::Z),
                        2 => (DVec3::new(0.0, u, v), DVec3::X),
                        3 => (DVec3::new(4.0, u, v), -DVec3::X),
                        4 => (DVec3::new(u, 0.0, v), DVec3::Y),
                        _ => (DVec3::new(u, 4.0, v), -DVec3::Y),
                    };
                    // A small square of the wall about the point, facing the room.
                    let (a, b) = n.any_orthonormal_pair();
                    let mut square = [-a - b, a - b, a + b, b - a].map(|c| p + c * 0.01);
                    if (square[1] - square[0]).cross(square[2] - square[0]).dot(n) < 0.0 {
                        square.reverse();
                    }
                    (p, n, Polygon::new(&square))
                }
                1 => {
                    let t = tris[(next() * tris.len() as f64) as usize];
                    let (a, b) = (next(), next());
                    let (a, b) = if a + b > 1.0 {
                        (1.0 - a, 1.0 - b)
                    } else {
                        (a, b)
                    };
                    let p = t[0] + (t[1] - t[0]) * a + (t[2] - t[0]) * b;
                    let face = Polygon::new(&t).unwrap();
                    (p, face.normal, Some(face))
                }
                2 => {
                    let d = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
                    let r = balls[0].outer + 1e-3 * (4.0 * 3f64.sqrt()) * (1.0 + next());
                    (occ.centre + balls[0].centre + d * r, d, None)
                }
                _ => {
                    let d = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
                    (occ.centre + balls[0].centre + d * 0.9 * next(), d, None)
                }
            }
        };
        let (mut by_ball, mut hinted, mut blocked) = (0, 0, 0);
        for i in 0..40_000u32 {
            let (from, from_normal, from_face) = point(i % 4);
            let (to, to_normal, to_face) = point((i / 4) % 4);
            let want = occ.occluded_by_triangles(from, from_normal, to, to_normal);
            assert_eq!(
                occ.occluded(from, from_normal, to, to_normal),
                want,
                "{from} → {to}"
            );
            blocked += u32::from(want);
            let segment = relative_segment(occ.centre, from, to).unwrap();
            if balls.iter().any(|b| occ.by_ball(b, segment) != Enter::Yes) {
                by_ball += 1;
            }
            // The bundle, with the hints of the faces the ends lie on, where the segment
            // leaves the first to its front and reaches the second's front.
            let (Some(e), Some(t)) = (from_face, to_face) else {
                continue;
            };
            let d = to - from;
            if d.dot(e.normal) <= 0.0 || d.dot(t.normal) >= 0.0 {
                continue;
            }
            let ends = [occ.clear_of(&e), occ.clear_of(&t)];
            hinted += u32::from(ends != [Clear::NONE; 2]);
            let mut got = [false];
            occ.occluded_bundle(&e, &t, ends, &[Segment { from, to }], &mut got);
            assert_eq!(got[0], want, "bundle {from} → {to}");
        }
        assert!(
            by_ball > 10_000 && hinted > 500 && blocked > 5_000,
            "{by_ball} {hinted} {blocked}"
        );
    }

    #[test]
    fn traversal_agrees_with_brute_force_near_walls_and_corners() {
        // Two rooms side by side sharing zero-thickness walls at x = 1 and y = 1: segments
        // between random points of the two boxes' faces, many passing near the corner edge.
        let scene = fixtures::two_rooms([1, 1, 0]);
        let occ = ObvhsOccluder::build(&scene);
        let mut disagreements = 0;
        for (from, to) in fixtures::corner_segments(100_000) {
            let traversed = occ.occluded(from, DVec3::Z, to, DVec3::Z);
            let brute = !occ.blockers_brute_force(from, to).is_empty();
            if traversed != brute {
                disagreements += 1;
            }
            assert!(brute, "every segment between the two rooms crosses a wall");
        }
        assert_eq!(disagreements, 0);
    }
}
