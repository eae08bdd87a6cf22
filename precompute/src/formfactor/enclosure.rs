//! Which elements sit in an enclosure: every direction above them meets the front of a face.
//!
//! The factors of such an element to all targets sum to exactly one (whatever occludes what);
//! sampled visibility does not conserve that sum (a closed room with floating boxes was off by
//! 6.4e-3 in a furnace). [`super::FormFactors::row`] restores it on the rows this marks, by
//! rescaling the row's partly visible pairs, the ones that carry sampling noise, or the whole
//! row when they cannot carry the deficit (DESIGN.md §4, "Rows that sum to one").
//!
//! The test, per element: [`RAYS`] cosine-distributed rays from points spread over the element
//! ([`ClosestHit::first_hit`]: the default backend's, exact f64 triangle test). An element is enclosed when every
//! ray meets the front of a face; a ray that meets a back (a one-sided panel seen from behind,
//! the hidden side of a contact) keeps the element's row as sampled. Because an element's rays
//! can miss a small opening, the scene must be closed as well: one ray of any element that
//! leaves the scene marks no element at all. The result depends only on the geometry and the
//! element ids (hashed sample positions), never on threads.

use glam::DVec3;
use rayon::prelude::*;

use crate::geometry::Polygon;
use crate::geometry::hash::mix;
use crate::geometry::sampling::{pair_point, r2, shift};
use crate::visibility::{ClosestHit, FirstHit};

/// Rays per element. A row is rescaled only when all of them meet fronts; with the scene-wide
/// escape test it is what stands between an undetected opening and a rescaled row.
pub const RAYS: u32 = 64;

/// Bytes the test holds per element: its two ray counts (`u32` each) and its mark.
pub const BYTES_PER_ELEMENT: u128 = 9;

/// The outcome of the test over all elements.
#[derive(Debug, Clone, Default)]
pub struct Enclosure {
    /// Per element id: whether its factors must sum to one.
    pub closed: Vec<bool>,
    /// Rays cast.
    pub rays: u64,
    /// Rays that left the scene (any: the scene is open, no element is marked).
    pub escaped: u64,
    /// Rays that met the back of a face first.
    pub backs: u64,
}

impl Enclosure {
    /// Tests every element (`polygons[i]` is element `i`).
    pub fn probe(occluder: &dyn ClosestHit, polygons: &[Polygon]) -> Self {
        Self::probe_each(occluder, polygons.len(), |i| polygons[i])
    }

    /// [`Enclosure::probe`] of `count` elements, `polygon(i)` giving element `i` (no copy of
    /// the mesh's polygons: what it holds is [`BYTES_PER_ELEMENT`] an element).
    pub fn probe_each(
        occluder: &dyn ClosestHit,
        count: usize,
        polygon: impl Fn(usize) -> Polygon + Sync,
    ) -> Self {
        let counts: Vec<(u32, u32)> = (0..count)
            .into_par_iter()
            .map(|id| element(occluder, &polygon(id), id as u32))
            .collect();
        let escaped: u64 = counts.iter().map(|c| u64::from(c.0)).sum();
        let backs: u64 = counts.iter().map(|c| u64::from(c.1)).sum();
        let closed = counts
            .iter()
            .map(|&(out, back)| escaped == 0 && out == 0 && back == 0)
            .collect();
        Self {
            closed,
            rays: count as u64 * u64::from(RAYS),
            escaped,
            backs,
        }
    }

    /// Number of elements marked.
    pub fn closed_count(&self) -> usize {
        self.closed.iter().filter(|&&c| c).count()
    }
}

/// Rays of one element that leave the scene and that meet a back.
fn element(occluder: &dyn ClosestHit, p: &Polygon, id: u32) -> (u32, u32) {
    let seed = mix(u64::from(id) ^ 0x656e_636c_6f73_6564); // "enclosed"
    // The same rotation as the points': each ray's direction sample equals its point's
    // (u, w) before the point is mapped onto the element (see the note on issue #14).
    let shift = shift(seed);
    let (t, b) = basis(p.normal);
    let (mut out, mut back) = (0, 0);
    for i in 0..RAYS {
        let from = pair_point(p, i, seed).point;
        // Cosine-distributed direction (Malley): a uniform point of the disc lifted onto the
        // hemisphere.
        let (u, v) = r2(i, shift);
        let (r, phi) = (u.sqrt(), std::f64::consts::TAU * v);
        let d = t * (r * phi.cos()) + b * (r * phi.sin()) + p.normal * (1.0 - u).max(0.0).sqrt();
        match occluder.first_hit(from, p.normal, d.normalize()) {
            FirstHit::Front => {}
            FirstHit::Back => back += 1,
            FirstHit::Nothing => out += 1,
        }
    }
    (out, back)
}

/// Two unit vectors completing `n` to an orthonormal basis.
fn basis(n: DVec3) -> (DVec3, DVec3) {
    let t = n.any_orthonormal_vector();
    (t, n.cross(t))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;
    use crate::visibility::obvhs::ObvhsOccluder;

    fn polygons(scene: &Scene) -> Vec<Polygon> {
        scene.faces.iter().map(|f| f.polygon).collect()
    }

    fn scene(toml: &str) -> Scene {
        crate::scene::description::SceneDescription::parse(toml, "t.toml")
            .unwrap()
            .build("t.toml", std::path::Path::new("."))
            .unwrap()
    }

    const ROOM: &str = "[[material]]\nname = \"w\"\nreflectance = [0.5, 0.5, 0.5]\n\
        [[box]]\nname = \"room\"\nmaterial = \"w\"\nmin = [0, 0, 0]\nmax = [4, 3, 5]\ninward = true\n";

    #[test]
    fn a_closed_room_with_a_floating_box_is_enclosed_everywhere() {
        let s = scene(&format!(
            "{ROOM}[[box]]\nname = \"b\"\nmaterial = \"w\"\nmin = [1, 1, 1]\nmax = [2, 2, 2]\n"
        ));
        let occ = ObvhsOccluder::build(&s);
        let e = Enclosure::probe(&occ, &polygons(&s));
        assert_eq!((e.escaped, e.backs), (0, 0));
        assert_eq!(e.closed_count(), s.faces.len());
        assert_eq!(e.rays, s.faces.len() as u64 * u64::from(RAYS));
    }

    #[test]
    fn an_opening_anywhere_marks_no_element() {
        // The room without its ceiling (y = 3): rays leave through the top.
        let s = scene(ROOM);
        let open: Vec<Polygon> = polygons(&s)
            .into_iter()
            .filter(|p| p.centroid().y < 2.999)
            .collect();
        let mut faces = s.clone();
        faces.faces.retain(|f| f.polygon.centroid().y < 2.999);
        let occ = ObvhsOccluder::build(&faces);
        let e = Enclosure::probe(&occ, &open);
        assert!(e.escaped > 0);
        assert_eq!(e.closed_count(), 0);
    }

    #[test]
    fn elements_that_see_a_back_keep_their_rows() {
        // A one-sided panel floating in the room, facing the floor (y = 1.5, normal -y): the
        // ceiling sees its back, the floor its front.
        let s = scene(&format!(
            "{ROOM}[[surface]]\nname = \"panel\"\nmaterial = \"w\"\n\
             polygons = [[[1, 1.5, 1], [3, 1.5, 1], [3, 1.5, 4], [1, 1.5, 4]]]\n"
        ));
        let occ = ObvhsOccluder::build(&s);
        let polys = polygons(&s);
        let e = Enclosure::probe(&occ, &polys);
        assert_eq!(e.escaped, 0);
        assert!(e.backs > 0);
        for (p, &closed) in polys.iter().zip(&e.closed) {
            let c = p.centroid();
            if (c.y - 3.0).abs() < 1e-9 {
                assert!(!closed, "the ceiling sees the panel's back");
            }
            if c.y.abs() < 1e-9 {
                assert!(closed, "the floor sees the panel's front");
            }
        }
    }

    #[test]
    fn first_hit_tells_front_back_and_nothing() {
        let s = scene(ROOM);
        let occ = ObvhsOccluder::build(&s);
        let up = DVec3::Y;
        let floor = DVec3::new(2.0, 0.0, 2.5);
        assert_eq!(occ.first_hit(floor, up, up), FirstHit::Front);
        // From outside the room, below the floor, looking up: the floor's back.
        let below = DVec3::new(2.0, -1.0, 2.5);
        assert_eq!(occ.first_hit(below, up, up), FirstHit::Back);
        assert_eq!(occ.first_hit(below, up, -up), FirstHit::Nothing);
    }
}
