//! Splitting faces along the lines where other faces stand on them ("imprinting").
//!
//! A wall standing on a floor that continues under it, a block on a table: an element that
//! straddles such a contact line is lit on one side and dark (or in another room) on the
//! other, and its one radiosity value smears light across the contact: the classic light leak
//! under walls and boxes. Before subdivision every face is therefore cut by the plane of each
//! face that has an edge lying in it, where that edge crosses the face's interior. Cuts use
//! the whole plane, so every piece stays convex (more pieces than a polygon-with-hole
//! triangulation would give, but no new algorithm to get wrong). Tolerances are relative to
//! the faces' sizes.

use glam::DVec3;

use crate::geometry::Polygon;
use crate::geometry::boxes::{BoxGrid, overlaps};
use crate::scene::Face;

/// Relative distance under which a vertex counts as lying in a plane.
const CONTACT_TOLERANCE: f64 = 1e-7;
/// Pieces smaller than this fraction of their face's area are not cut off.
const MIN_PIECE_FRACTION: f64 = 1e-9;

/// The faces of a scene indexed for contact searches: their bounding boxes, in the sweep order
/// (by the low x of the box) that contacts come in, in a hierarchy of grids.
pub(super) struct Imprinter<'f> {
    faces: &'f [Face],
    /// The faces in sweep order (by the low x of their boxes, then by index): the grid answers
    /// places in it, so sorting its answers puts them in sweep order.
    sweep: Vec<u32>,
    /// The boxes in sweep order.
    boxes: Vec<(DVec3, DVec3)>,
    grid: BoxGrid,
}

/// A line where another face stands on (or cuts through) a polygon: cut by `plane`'s plane
/// where `segment` (in the polygon's plane) crosses it.
#[derive(Debug, Clone, Copy)]
pub(super) struct Contact {
    plane: Polygon,
    segment: (DVec3, DVec3),
    /// True when the other face passes through the plane (an interpenetration), not along it.
    pub through: bool,
    /// Index of the other face.
    pub face: usize,
}

impl<'f> Imprinter<'f> {
    pub(super) fn new(faces: &'f [Face]) -> Self {
        let by_face: Vec<(DVec3, DVec3)> = faces.iter().map(|f| bounds(&f.polygon)).collect();
        let mut sweep: Vec<u32> = (0..faces.len() as u32).collect();
        sweep.sort_by(|&a, &b| by_face[a as usize].0.x.total_cmp(&by_face[b as usize].0.x));
        let boxes: Vec<(DVec3, DVec3)> = sweep.iter().map(|&g| by_face[g as usize]).collect();
        drop(by_face); // not held beside the grid's build
        let grid = BoxGrid::new(&boxes);
        Self {
            faces,
            sweep,
            boxes,
            grid,
        }
    }

    /// The contacts on `plane` (a polygon giving the plane and the tolerance) of every face
    /// but `skip` whose box meets `(lo, hi)` grown by the tolerance, in sweep order.
    pub(super) fn contacts(
        &self,
        plane: &Polygon,
        (lo, hi): (DVec3, DVec3),
        skip: Option<usize>,
    ) -> Vec<Contact> {
        let grow = DVec3::splat(CONTACT_TOLERANCE * plane.scale.max(1e-300));
        let (lo, hi) = (lo - grow, hi + grow);
        // Every face whose box meets the query's, in sweep order (the order a scan of every
        // face by low x would meet them in: the same contacts in the same order).
        let mut near = self.grid.candidates((lo, hi));
        near.sort_unstable();
        near.dedup();
        let mut out = Vec::new();
        for r in near {
            let g = self.sweep[r as usize] as usize;
            if Some(g) == skip || !overlaps((lo, hi), self.boxes[r as usize]) {
                continue;
            }
            let other = &self.faces[g].polygon;
            if let Some((segment, through)) = crossing(plane, other) {
                out.push(Contact {
                    plane: *other,
                    segment,
                    through,
                    face: g,
                });
            }
        }
        out
    }

    /// Face `f`'s `polygon` (the face itself or a merged region) cut at its contact lines;
    /// also the number of cuts by faces passing through it.
    pub(super) fn split(&self, polygon: Polygon, f: usize) -> (Vec<Polygon>, usize) {
        let contacts = self.contacts(&polygon, bounds(&polygon), Some(f));
        let mut used = vec![false; contacts.len()];
        let pieces = cut_all(vec![polygon], &contacts, polygon.area(), &mut used);
        (pieces, through(&contacts, &used))
    }
}

/// How many of the contacts that cut something were interpenetrations.
pub(super) fn through(contacts: &[Contact], used: &[bool]) -> usize {
    contacts
        .iter()
        .zip(used)
        .filter(|(c, u)| c.through && **u)
        .count()
}

/// Pieces cut by each contact in turn (pieces under `MIN_PIECE_FRACTION` of `area` are not cut
/// off); `used[i]` is set when contact `i` cut something.
pub(super) fn cut_all(
    mut pieces: Vec<Polygon>,
    contacts: &[Contact],
    area: f64,
    used: &mut [bool],
) -> Vec<Polygon> {
    for (c, used) in contacts.iter().zip(used) {
        let before = pieces.len();
        pieces = pieces
            .into_iter()
            .flat_map(|p| cut(&p, &c.plane, c.segment, area))
            .collect();
        *used |= pieces.len() > before;
    }
    pieces
}

impl Contact {
    /// True when a segment along the unit direction `dir` with midpoint `mid` lies on this
    /// contact line (parallel to it, `mid` within `tol` of the contact segment): an edge the
    /// light may differ across (`smooth`).
    pub(super) fn holds(&self, mid: DVec3, dir: DVec3, tol: f64) -> bool {
        let (a, b) = self.segment;
        let ab = b - a;
        let len = ab.length();
        if len <= tol || dir.dot(ab).abs() < (1.0 - 1e-6) * len {
            return false;
        }
        let t = ((mid - a).dot(ab) / (len * len)).clamp(0.0, 1.0);
        (a + ab * t).distance(mid) <= tol
    }

    /// Bounding box of the contact segment.
    pub(super) fn bounds(&self) -> (DVec3, DVec3) {
        let (a, b) = self.segment;
        (a.min(b), a.max(b))
    }
}

/// Lower and upper corners of a polygon's bounding box.
pub(super) fn polygon_bounds(p: &Polygon) -> (DVec3, DVec3) {
    bounds(p)
}

/// True when two boxes grown by `grow` overlap.
pub(super) fn boxes_meet(a: (DVec3, DVec3), b: (DVec3, DVec3), grow: f64) -> bool {
    overlaps((a.0 - DVec3::splat(grow), a.1 + DVec3::splat(grow)), b)
}

/// Every face cut at its contact lines: (piece, index of the face it came from).
#[cfg(test)]
pub(super) fn split_at_contacts(faces: &[Face]) -> Vec<(Polygon, usize)> {
    let imprinter = Imprinter::new(faces);
    let mut out = Vec::with_capacity(faces.len());
    for (f, face) in faces.iter().enumerate() {
        let (pieces, _) = imprinter.split(face.polygon, f);
        out.extend(pieces.into_iter().map(|p| (p, f)));
    }
    out
}

fn bounds(p: &Polygon) -> (DVec3, DVec3) {
    let v = p.vertices();
    v.iter()
        .fold((v[0], v[0]), |(lo, hi), x| (lo.min(*x), hi.max(*x)))
}

/// Where `g` meets the plane of `f` when `g` is not parallel to `f`: an edge of `g` lying in
/// the plane (a contact, `false`), or else the segment along which `g` passes through it
/// (`true`).
fn crossing(f: &Polygon, g: &Polygon) -> Option<((DVec3, DVec3), bool)> {
    if f.normal.cross(g.normal).length() < 1e-6 {
        return None; // parallel or coplanar: nothing stands on f
    }
    let tol = CONTACT_TOLERANCE * f.scale.max(g.scale);
    let v = g.vertices();
    if let Some(edge) = (0..v.len())
        .map(|i| (v[i], v[(i + 1) % v.len()]))
        .find(|(a, b)| f.height(*a).abs() <= tol && f.height(*b).abs() <= tol)
    {
        return Some((edge, false));
    }
    let h: Vec<f64> = v.iter().map(|x| f.height(*x)).collect();
    if !(h.iter().any(|&x| x > tol) && h.iter().any(|&x| x < -tol)) {
        return None;
    }
    let mut points = Vec::with_capacity(2);
    for i in 0..v.len() {
        let j = (i + 1) % v.len();
        if h[i].abs() <= tol {
            points.push(v[i]);
        } else if h[j].abs() > tol && (h[i] > 0.0) != (h[j] > 0.0) {
            points.push(v[i] + (v[j] - v[i]) * (h[i] / (h[i] - h[j])));
        }
    }
    (points.len() >= 2).then(|| ((points[0], points[points.len() - 1]), true))
}

/// Cuts `p` by the plane of `g` if the contact edge crosses `p`'s interior.
fn cut(p: &Polygon, g: &Polygon, edge: (DVec3, DVec3), face_area: f64) -> Vec<Polygon> {
    let tol = CONTACT_TOLERANCE * p.scale.max(g.scale);
    if !segment_touches(p, edge, tol) {
        return vec![*p];
    }
    let side = |v: &DVec3| (*v - g.vertices[0]).dot(g.normal);
    let d: Vec<f64> = p.vertices().iter().map(side).collect();
    if !(d.iter().any(|&x| x > tol) && d.iter().any(|&x| x < -tol)) {
        return vec![*p];
    }
    let front = clip(p.vertices(), &d, 1.0);
    let back = clip(p.vertices(), &d, -1.0);
    let pieces: Vec<Polygon> = [front, back]
        .iter()
        .flat_map(|v| convex_pieces(v, p.normal))
        .collect();
    let min_area = MIN_PIECE_FRACTION * face_area;
    if pieces.iter().any(|q| q.area() < min_area) {
        return vec![*p];
    }
    pieces
}

/// True when the segment meets the polygon (in its plane) over a positive length.
fn segment_touches(p: &Polygon, (a, b): (DVec3, DVec3), tol: f64) -> bool {
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    let v = p.vertices();
    for i in 0..v.len() {
        let e = v[(i + 1) % v.len()] - v[i];
        let inward = p.normal.cross(e).normalize();
        let da = (a - v[i]).dot(inward) + tol;
        let db = (b - v[i]).dot(inward) + tol;
        if da < 0.0 && db < 0.0 {
            return false;
        }
        if da < 0.0 || db < 0.0 {
            let t = da / (da - db);
            if da < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    (t1 - t0) * (b - a).length() > tol
}

/// The part of a convex polygon on one side (`sign`) of a plane given signed distances `d`.
fn clip(v: &[DVec3], d: &[f64], sign: f64) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(v.len() + 1);
    for i in 0..v.len() {
        let j = (i + 1) % v.len();
        let (di, dj) = (sign * d[i], sign * d[j]);
        if di >= 0.0 {
            out.push(v[i]);
        }
        if (di >= 0.0) != (dj >= 0.0) {
            let t = di / (di - dj);
            out.push(v[i] + (v[j] - v[i]) * t);
        }
    }
    out
}

/// A convex polygon as pieces of 3 or 4 vertices (a fan beyond 4), keeping the face normal.
fn convex_pieces(v: &[DVec3], normal: DVec3) -> Vec<Polygon> {
    let mut out = Vec::new();
    let mut make = |vs: &[DVec3]| {
        if let Some(mut p) = Polygon::new(vs) {
            p.normal = normal;
            out.push(p);
        }
    };
    match v.len() {
        0..=2 => {}
        3 | 4 => make(v),
        _ => {
            // Quads from the fan where possible: (0, i, i+1, i+2), then a last triangle.
            let mut i = 1;
            while i + 2 < v.len() {
                make(&[v[0], v[i], v[i + 1], v[i + 2]]);
                i += 2;
            }
            if i + 1 < v.len() {
                make(&[v[0], v[i], v[i + 1]]);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::procedural;
    use std::path::Path;

    #[test]
    fn a_wall_standing_on_a_floor_cuts_it() {
        let mut d = procedural::furnace(0.5, 1.0);
        d.boxes[0].max = [2.0, 1.0, 1.0];
        d.boxes.push(crate::scene::description::BoxDesc {
            name: "wall".into(),
            material: "wall".into(),
            min: [1.0, 0.0, 0.0],
            max: [1.01, 1.0, 1.0],
            inward: false,
            omit: vec![],
        });
        let scene = d.build("t", Path::new(".")).unwrap();
        let pieces = split_at_contacts(&scene.faces);
        let floor = scene.surfaces.iter().position(|s| s == "cube.-z").unwrap();
        let floor_pieces: Vec<&Polygon> = pieces
            .iter()
            .filter(|(_, f)| scene.faces[*f].surface == floor)
            .map(|(p, _)| p)
            .collect();
        // Cut at x = 1 and x = 1.01: three pieces, areas 1, 0.01, 0.99.
        let mut areas: Vec<f64> = floor_pieces.iter().map(|p| p.area()).collect();
        areas.sort_by(f64::total_cmp);
        assert_eq!(areas.len(), 3, "{areas:?}");
        assert!(
            (areas[0] - 0.01).abs() < 1e-12
                && (areas[1] - 0.99).abs() < 1e-12
                && (areas[2] - 1.0).abs() < 1e-12
        );
        // Total area is preserved for every face.
        for (f, face) in scene.faces.iter().enumerate() {
            let a: f64 = pieces
                .iter()
                .filter(|(_, g)| *g == f)
                .map(|(p, _)| p.area())
                .sum();
            assert!((a - face.polygon.area()).abs() < 1e-12 * face.polygon.area().max(1.0));
        }
    }

    #[test]
    fn cornell_floor_is_cut_by_the_blocks_sides() {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box/cornell-box.toml");
        let scene = crate::scene::load(&path).unwrap();
        let floor = scene.surfaces.iter().position(|s| s == "floor").unwrap();
        let f = scene.faces.iter().position(|x| x.surface == floor).unwrap();
        let pieces = split_at_contacts(&scene.faces);
        // 8 block sides stand on the floor; each cut line crosses it.
        assert!(pieces.iter().filter(|(_, g)| *g == f).count() >= 9);
    }

    #[test]
    fn walls_along_a_boundary_cut_nothing() {
        let scene = procedural::furnace(0.5, 1.0)
            .build("t", Path::new("."))
            .unwrap();
        assert_eq!(split_at_contacts(&scene.faces).len(), 6);
    }
}
