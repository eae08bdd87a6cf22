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

use std::sync::OnceLock;

use glam::DVec3;

use crate::geometry::Polygon;
use crate::geometry::boxes::{BoxGrid, overlaps};
use crate::scene::Face;

/// Relative distance under which a vertex counts as lying in a plane.
const CONTACT_TOLERANCE: f64 = 1e-7;
/// Pieces smaller than this fraction of their face's area are not cut off.
const MIN_PIECE_FRACTION: f64 = 1e-9;

/// The faces of a scene indexed for contact searches: their bounding boxes, in the sweep order
/// (by the low x of the box) that contacts come in, in a hierarchy of grids; and the contacts
/// meshing found for each face it cut whole, kept for the smooth weights.
///
/// A bake searched a face's contacts up to three times, each time over an index of its own:
/// the fine mesh cuts the face at them, and the smooth weights of the refinement's indicator
/// and of the display keep their lines. The mesh builds one index and keeps it
/// (`patches::Mesh`), so the faces are indexed once and searched once (on an 81 920-triangle
/// sphere the searches and the index's builds were a quarter of a one-thread bake).
pub(crate) struct ContactIndex {
    /// The faces in sweep order (by the low x of their boxes, then by index): the grid answers
    /// places in it, so sorting its answers puts them in sweep order.
    sweep: Vec<u32>,
    /// The boxes in sweep order.
    boxes: Vec<(DVec3, DVec3)>,
    grid: BoxGrid,
    /// What meshing found ([`keep`](Self::keep)), set once.
    kept: OnceLock<Kept>,
    faces: usize,
}

/// Contacts found over whole faces' boxes, one table for all (a vector a face, allocated
/// among meshing's pieces, kept about 40 MB of freed memory from the system on that sphere).
struct Kept {
    /// Per face, its range in `found`; `(u32::MAX, 0)` for a face not kept.
    spans: Vec<(u32, u32)>,
    found: Vec<ContactLine>,
}

/// The lines of faces (each searched over its whole box) gathered in order for
/// [`ContactIndex::keep`], up to the first face that would take them past the allowance.
pub(super) struct Keeper {
    kept: Kept,
    allowance: usize,
    full: bool,
}

impl Keeper {
    /// Face `f`'s lines (what [`ContactLine::of`] made of its contacts over its whole box),
    /// kept unless they, or a face's given before, are past the allowance.
    pub(super) fn add(&mut self, f: usize, lines: &[ContactLine]) {
        let found = &mut self.kept.found;
        self.full |= found.len() + lines.len() > self.allowance;
        if !self.full {
            self.kept.spans[f] = (found.len() as u32, lines.len() as u32);
            found.extend_from_slice(lines);
        }
    }
}

/// Bytes of contacts [`ContactIndex`] keeps at most, per face of the scene: four or five
/// contacts a face (a triangle of a tessellated surface has three, the edges it shares), so
/// that what a mesh keeps stays within what meshing plans
/// ([`crate::mesh::MESH_BYTES_PER_FACE`]) whatever the scene; past it the faces left are
/// searched again when asked again.
pub(crate) const KEPT_BYTES_PER_FACE: usize = 256;

/// A contact line, as [`ContactIndex`] keeps it and the smooth weights ask it: the other
/// face's index and the segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct ContactLine {
    face: u32,
    segment: (DVec3, DVec3),
}

impl ContactLine {
    /// The lines of `contacts`.
    pub(super) fn of(contacts: &[Contact]) -> Box<[ContactLine]> {
        (contacts.iter())
            .map(|c| ContactLine {
                face: c.face as u32,
                segment: c.segment,
            })
            .collect()
    }

    /// Index of the other face.
    pub(super) fn face(&self) -> usize {
        self.face as usize
    }

    /// [`Contact::holds`].
    pub(super) fn holds(&self, mid: DVec3, dir: DVec3, tol: f64) -> bool {
        holds(self.segment, mid, dir, tol)
    }

    /// Bounding box of the contact segment.
    pub(super) fn bounds(&self) -> (DVec3, DVec3) {
        let (a, b) = self.segment;
        (a.min(b), a.max(b))
    }
}

impl ContactIndex {
    /// Indexes `faces` (nothing kept yet).
    pub(crate) fn new(faces: &[Face]) -> Self {
        let by_face: Vec<(DVec3, DVec3)> = faces.iter().map(|f| bounds(&f.polygon)).collect();
        let mut sweep: Vec<u32> = (0..faces.len() as u32).collect();
        sweep.sort_by(|&a, &b| by_face[a as usize].0.x.total_cmp(&by_face[b as usize].0.x));
        let boxes: Vec<(DVec3, DVec3)> = sweep.iter().map(|&g| by_face[g as usize]).collect();
        drop(by_face); // not held beside the grid's build
        let grid = BoxGrid::new(&boxes);
        Self {
            sweep,
            boxes,
            grid,
            kept: OnceLock::new(),
            faces: faces.len(),
        }
    }

    /// An empty table for [`keep`](Self::keep), for these faces.
    pub(super) fn keeper(&self) -> Keeper {
        let allowance = (self.faces * KEPT_BYTES_PER_FACE / std::mem::size_of::<ContactLine>())
            .min(u32::MAX as usize);
        Keeper {
            // Reserved, not touched: the memory that holds no line is never written.
            kept: Kept {
                spans: vec![(u32::MAX, 0); self.faces],
                found: Vec::with_capacity(allowance),
            },
            allowance,
            full: false,
        }
    }

    /// Keeps, once, what `keeper` was given.
    pub(super) fn keep(&self, keeper: Keeper) {
        let mut kept = keeper.kept;
        kept.found.shrink_to_fit();
        let _ = self.kept.set(kept);
    }

    /// What [`keep`](Self::keep) kept of face `f`.
    fn kept(&self, f: usize) -> Option<&[ContactLine]> {
        let kept = self.kept.get()?;
        let (start, len) = kept.spans[f];
        (start != u32::MAX).then(|| &kept.found[start as usize..(start + len) as usize])
    }
}

impl std::fmt::Debug for ContactIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ContactIndex")
            .field("faces", &self.faces)
            .field("kept", &self.kept.get().map_or(0, |k| k.found.len()))
            .finish()
    }
}

/// The faces of a scene with their contact index: their own, or one a mesh keeps.
pub(super) struct Imprinter<'f> {
    faces: &'f [Face],
    index: Held<'f>,
}

enum Held<'f> {
    Own(Box<ContactIndex>),
    Shared(&'f ContactIndex),
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
    /// `faces` with an index of their own.
    pub(super) fn new(faces: &'f [Face]) -> Self {
        Self {
            faces,
            index: Held::Own(Box::new(ContactIndex::new(faces))),
        }
    }

    /// `faces` with the index built for them (`ContactIndex::new(faces)`).
    pub(super) fn with(faces: &'f [Face], index: &'f ContactIndex) -> Self {
        debug_assert_eq!(index.faces, faces.len());
        Self {
            faces,
            index: Held::Shared(index),
        }
    }

    fn index(&self) -> &ContactIndex {
        match &self.index {
            Held::Own(i) => i,
            Held::Shared(i) => i,
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
        let index = self.index();
        // The boxes are tested before the places are sorted: a grid's answer repeats a box
        // for each cell it shares with the query, and most answers are not near enough.
        let mut near = index.grid.candidates((lo, hi));
        near.retain(|&r| overlaps((lo, hi), index.boxes[r as usize]));
        near.sort_unstable();
        near.dedup();
        let mut out = Vec::new();
        for r in near {
            let g = index.sweep[r as usize] as usize;
            if Some(g) == skip {
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

    /// The contact lines on face `f`'s plane of every other face whose box meets `(lo, hi)`
    /// grown by the tolerance, in sweep order: [`contacts`](Self::contacts) of the face
    /// without their planes. Where meshing kept the face's contacts over its whole box and
    /// `(lo, hi)` lies within that box, they are taken from what was kept (the same contacts
    /// in the same order: a contact does not depend on the box it was found in), else
    /// searched.
    pub(super) fn face_lines(&self, f: usize, (lo, hi): (DVec3, DVec3)) -> Vec<ContactLine> {
        let plane = &self.faces[f].polygon;
        let whole = bounds(plane);
        let within = whole.0.cmple(lo).all() && hi.cmple(whole.1).all();
        let Some(found) = self.index().kept(f).filter(|_| within) else {
            return ContactLine::of(&self.contacts(plane, (lo, hi), Some(f))).into_vec();
        };
        let grow = DVec3::splat(CONTACT_TOLERANCE * plane.scale.max(1e-300));
        let (lo, hi) = (lo - grow, hi + grow);
        (found.iter())
            .filter(|c| overlaps((lo, hi), bounds(&self.faces[c.face()].polygon)))
            .copied()
            .collect()
    }

    /// Face `f`'s `polygon` (the face itself or a merged region) cut at its contact lines;
    /// also its contacts and which of them cut something.
    pub(super) fn split(
        &self,
        polygon: Polygon,
        f: usize,
    ) -> (Vec<Polygon>, Vec<Contact>, Vec<bool>) {
        let contacts = self.contacts(&polygon, bounds(&polygon), Some(f));
        let mut used = vec![false; contacts.len()];
        let pieces = cut_all(vec![polygon], &contacts, polygon.area(), &mut used);
        (pieces, contacts, used)
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
///
/// Each piece meets the contacts in order, and what a contact makes of one piece does not
/// depend on the others: so a piece is followed on its own, from the first later contact that
/// changes it, its pieces in its place. Past [`INDEXED_CONTACTS`] contacts, a piece is tested
/// only against those whose edge comes near enough to touch it ([`Reach`]): a floor under
/// 10 000 boxes (40 000 contacts) was cut in minutes, each contact copying every piece made so
/// far. The pieces, their order and `used` are those of cutting every piece by each contact in
/// turn.
pub(super) fn cut_all(
    pieces: Vec<Polygon>,
    contacts: &[Contact],
    area: f64,
    used: &mut [bool],
) -> Vec<Polygon> {
    let reach = (contacts.len() > INDEXED_CONTACTS)
        .then(|| pieces.first().and_then(|p| Reach::new(p.normal, contacts)))
        .flatten();
    // Pieces each contact added (it is used when they are more than it removed).
    let mut gained = vec![0i64; contacts.len()];
    // Depth first, a piece's pieces pushed last to first so that they come out in order; each
    // with the first contact that may still cut it (those before it came before the piece).
    let mut stack: Vec<(Polygon, usize)> = pieces.into_iter().rev().map(|p| (p, 0)).collect();
    let mut out = Vec::new();
    let mut near = Vec::new();
    while let Some((p, from)) = stack.pop() {
        near.clear();
        match reach.as_ref().and_then(|r| r.near(&p, from)) {
            Some(found) => near.extend(found),
            None => near.extend(from as u32..contacts.len() as u32),
        }
        let first = near.iter().find_map(|&c| {
            let contact = &contacts[c as usize];
            if !touches(&p, contact) {
                return None;
            }
            cut_across(&p, &contact.plane, area).map(|pieces| (c as usize, pieces))
        });
        let Some((c, pieces)) = first else {
            out.push(p);
            continue;
        };
        gained[c] += pieces.len() as i64 - 1;
        stack.extend(pieces.into_iter().rev().map(|q| (q, c + 1)));
    }
    for (used, gained) in used.iter_mut().zip(gained) {
        *used |= gained > 0;
    }
    out
}

/// Contacts up to which [`cut_all`] tests every piece against every later contact (and
/// `subdivide::cut_cells` every cell against every contact).
pub(super) const INDEXED_CONTACTS: usize = 64;

/// The contacts' edges in the plane of the pieces (2D coordinates along two unit vectors
/// across the normal), indexed, to find those that may touch a piece.
struct Reach {
    /// The pieces' normal (as given), and two unit vectors across it.
    normal: DVec3,
    u: DVec3,
    v: DVec3,
    grid: BoxGrid,
    /// The largest contact polygon's scale (the contact tolerance grows with it).
    scale: f64,
}

impl Reach {
    /// None where the normal gives no plane (then every contact is tested).
    fn new(normal: DVec3, contacts: &[Contact]) -> Option<Self> {
        let n = normal.try_normalize()?;
        let u = if n.x.abs() < 0.9 {
            n.cross(DVec3::X)
        } else {
            n.cross(DVec3::Y)
        }
        .try_normalize()?;
        let v = n.cross(u);
        let flat = |x: DVec3| DVec3::new(x.dot(u), x.dot(v), 0.0);
        let boxes: Vec<(DVec3, DVec3)> = (contacts.iter())
            .map(|c| {
                let (a, b) = (flat(c.segment.0), flat(c.segment.1));
                (a.min(b), a.max(b))
            })
            .collect();
        let scale = contacts.iter().map(|c| c.plane.scale).fold(0.0, f64::max);
        Some(Self {
            normal,
            u,
            v,
            grid: BoxGrid::new(&boxes),
            scale,
        })
    }

    /// Contacts from `from` on, in order, whose edge may touch `p` (a superset of those
    /// [`touches`] says do), or None where `p` has no bound (then every later contact).
    ///
    /// [`segment_touches`] clips an edge to `p`'s sides each moved out by the tolerance `t`,
    /// in the plane (the normal's component is ignored): a polygon whose corner of interior
    /// angle θ moves out by `t / sin(θ/2)`. So a touching edge meets `p`'s box, in the plane,
    /// grown by that at `p`'s sharpest corner.
    fn near(&self, p: &Polygon, from: usize) -> Option<Vec<u32>> {
        // Another plane, or an edge so short that its direction in the plane is the rounding
        // of the projection (`segment_touches` takes it from the 3D difference): no bound.
        let vs = p.vertices();
        let shortest = (0..vs.len())
            .map(|i| vs[i].distance(vs[(i + 1) % vs.len()]))
            .fold(f64::INFINITY, f64::min);
        if p.normal != self.normal || shortest.is_nan() || shortest <= 1e-6 * p.scale {
            return None;
        }
        let flat: Vec<DVec3> = (p.vertices().iter())
            .map(|x| DVec3::new(x.dot(self.u), x.dot(self.v), 0.0))
            .collect();
        let k = flat.len();
        let mut sharpest = 1.0f64;
        for i in 0..k {
            let (before, at, after) = (flat[(i + k - 1) % k], flat[i], flat[(i + 1) % k]);
            // Convex and counter-clockwise about the normal in the plane, else no bound.
            let (e, f) = (at - before, after - at);
            let turn = e.x * f.y - e.y * f.x;
            if turn.is_nan() || turn <= 0.0 {
                return None;
            }
            let a = (before - at).try_normalize()?;
            let b = (after - at).try_normalize()?;
            // sin(θ/2) = |a − b| / 2 for unit a, b at angle θ.
            sharpest = sharpest.min(0.5 * (a - b).length());
        }
        if sharpest.is_nan() || sharpest <= 1e-6 {
            return None;
        }
        let t = CONTACT_TOLERANCE * p.scale.max(self.scale);
        // Past the bound by a margin for the rounding of the two planes' coordinates.
        let grow = t / sharpest * (1.0 + 1e-6) + 1e-9 * p.scale;
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for &f in &flat {
            (lo, hi) = (lo.min(f), hi.max(f));
        }
        let g = DVec3::new(grow, grow, 0.0);
        if !(lo.is_finite() && hi.is_finite() && grow.is_finite()) {
            return None;
        }
        let mut found: Vec<u32> = self.grid.candidates((lo - g, hi + g));
        found.retain(|&c| c as usize >= from);
        found.sort_unstable();
        found.dedup();
        Some(found)
    }
}

impl Contact {
    /// True when a segment along the unit direction `dir` with midpoint `mid` lies on this
    /// contact line (parallel to it, `mid` within `tol` of the contact segment): an edge the
    /// light may differ across (`smooth`).
    pub(super) fn holds(&self, mid: DVec3, dir: DVec3, tol: f64) -> bool {
        holds(self.segment, mid, dir, tol)
    }

    /// Distance from `x` (on the cut face, whose unit normal is `normal`) to the contact
    /// segment, and whether `x` lies behind the other face there: the other face's normal,
    /// taken in the cut face's plane, points away from `x` (a point under a box standing on
    /// the face lies behind the box's sides). A face lying along the cut plane has nothing
    /// behind it.
    pub(super) fn behind(&self, x: DVec3, normal: DVec3) -> (f64, bool) {
        let (a, b) = self.segment;
        let ab = b - a;
        let len2 = ab.length_squared();
        let t = if len2 > 0.0 {
            ((x - a).dot(ab) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let q = a + ab * t;
        let n = self.plane.normal - normal * self.plane.normal.dot(normal);
        let behind = n.length_squared() > 1e-12 && (x - q).dot(n) < 0.0;
        (q.distance(x), behind)
    }

    /// Length of the contact segment.
    pub(super) fn length(&self) -> f64 {
        self.segment.0.distance(self.segment.1)
    }

    /// Bounding box of the contact segment.
    pub(super) fn bounds(&self) -> (DVec3, DVec3) {
        let (a, b) = self.segment;
        (a.min(b), a.max(b))
    }
}

/// [`Contact::holds`] of a contact segment `(a, b)`.
fn holds((a, b): (DVec3, DVec3), mid: DVec3, dir: DVec3, tol: f64) -> bool {
    let ab = b - a;
    let len = ab.length();
    if len <= tol || dir.dot(ab).abs() < (1.0 - 1e-6) * len {
        return false;
    }
    let t = ((mid - a).dot(ab) / (len * len)).clamp(0.0, 1.0);
    (a + ab * t).distance(mid) <= tol
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
        let (pieces, _, _) = imprinter.split(face.polygon, f);
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

/// Whether contact `c`'s edge meets `p` over a positive length (within the contact
/// tolerance): where it does not, its plane leaves `p` whole.
fn touches(p: &Polygon, c: &Contact) -> bool {
    segment_touches(p, c.segment, CONTACT_TOLERANCE * p.scale.max(c.plane.scale))
}

/// `p` cut by the plane of `g` (whose contact edge touches `p`), or None where that leaves
/// `p` whole: the plane does not pass through it, or a piece would be under
/// `MIN_PIECE_FRACTION` of `face_area`.
fn cut_across(p: &Polygon, g: &Polygon, face_area: f64) -> Option<Vec<Polygon>> {
    let tol = CONTACT_TOLERANCE * p.scale.max(g.scale);
    let side = |v: &DVec3| (*v - g.vertices[0]).dot(g.normal);
    // A corner within the tolerance of the plane lies on it: the cut passes through the
    // corner. Clipped at the sign of its rounding, it made a sliver beside the corner whose
    // area the rounding decided, and a sliver under `MIN_PIECE_FRACTION` refused the whole
    // cut: the same scene scaled by 1.0000001 or 0.01 imprinted 43 and 41 fewer of the
    // Godot living room's 605 interpenetrations.
    let d: Vec<f64> = (p.vertices().iter())
        .map(|v| match side(v) {
            x if x.abs() <= tol => 0.0,
            x => x,
        })
        .collect();
    if !(d.iter().any(|&x| x > tol) && d.iter().any(|&x| x < -tol)) {
        return None;
    }
    let front = clip(p.vertices(), &d, 1.0);
    let back = clip(p.vertices(), &d, -1.0);
    let pieces: Vec<Polygon> = [front, back]
        .iter()
        .flat_map(|v| convex_pieces(v, p.normal))
        .collect();
    let min_area = MIN_PIECE_FRACTION * face_area;
    if pieces.iter().any(|q| q.area() < min_area) {
        return None;
    }
    Some(pieces)
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

    /// A plane through a corner cuts the polygon there whether rounding puts the corner on
    /// the plane, just in front of it or just behind it (within the contact tolerance): the
    /// same pieces. Clipped at the sign of the rounding, a corner off by 1e-12 made a
    /// sliver beside it, and the sliver refused the cut.
    #[test]
    fn a_plane_through_a_corner_cuts_alike_whatever_the_rounding() {
        let square = |corner: DVec3| {
            Polygon::new(&[DVec3::ZERO, corner, DVec3::new(1.0, 1.0, 0.0), DVec3::Y]).unwrap()
        };
        // The plane x + y/2 = 1, upright: through the corner (1, 0, 0) and across the square.
        let normal = DVec3::new(1.0, 0.5, 0.0).normalize();
        let along = DVec3::new(-0.5, 1.0, 0.0).normalize();
        let at = DVec3::X;
        let g = Polygon::new(&[
            at - along,
            at + along,
            at + along + DVec3::Z,
            at - along + DVec3::Z,
        ])
        .unwrap();
        assert!(g.normal.dot(normal).abs() > 1.0 - 1e-12);
        let areas = |corner: DVec3| {
            let mut a: Vec<f64> = cut_across(&square(corner), &g, 1.0)
                .expect("the plane cuts the square")
                .iter()
                .map(Polygon::area)
                .collect();
            a.sort_by(f64::total_cmp);
            a
        };
        // In front a triangle of 1/4, behind a quad of 3/4; the clip repeats the corner on the
        // plane, so the back comes as a quad and a triangle (a zero-length edge between them).
        let exact = areas(DVec3::X);
        assert_eq!(exact.len(), 3);
        assert!((exact.iter().sum::<f64>() - 1.0).abs() < 1e-12, "{exact:?}");
        for off in [1e-12, -1e-12, 3e-9, -3e-9] {
            let got = areas(DVec3::new(1.0 + off, 0.0, 0.0));
            assert_eq!(got.len(), exact.len(), "corner off by {off}: {got:?}");
            for (a, b) in got.iter().zip(&exact) {
                assert!((a - b).abs() < 1e-8, "corner off by {off}: {got:?}");
            }
        }
    }

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

    /// Every contact applied to every piece in turn: what [`cut_all`] must give.
    fn cut_in_turn(
        mut pieces: Vec<Polygon>,
        contacts: &[Contact],
        area: f64,
        used: &mut [bool],
    ) -> Vec<Polygon> {
        for (c, used) in contacts.iter().zip(used) {
            let before = pieces.len();
            pieces = (pieces.into_iter())
                .flat_map(|p| match touches(&p, c) {
                    true => cut_across(&p, &c.plane, area).unwrap_or_else(|| vec![p]),
                    false => vec![p],
                })
                .collect();
            *used |= pieces.len() > before;
        }
        pieces
    }

    /// A floor under 64 boxes and 40 fins at odd angles (edges in the floor, or through it,
    /// their pieces with sharp corners), as built and turned about an oblique axis: past
    /// `INDEXED_CONTACTS`, the pieces found near each contact are those of every contact
    /// applied to every piece in turn, in the same order, bit for bit, and the same contacts
    /// are used.
    #[test]
    fn indexed_cuts_are_the_cuts_in_turn() {
        let mut d = procedural::furnace(0.5, 1.0);
        d.boxes[0].max = [4.0, 1.0, 4.0];
        for i in 0..8 {
            for j in 0..8 {
                let (x, z) = (0.2 + 0.47 * f64::from(i), 0.3 + 0.45 * f64::from(j));
                d.boxes.push(crate::scene::description::BoxDesc {
                    name: format!("b{i}_{j}"),
                    material: "wall".into(),
                    min: [x, 0.0, z],
                    max: [x + 0.2, 0.3, z + 0.15],
                    inward: false,
                    omit: vec![],
                });
            }
        }
        let mut state = 0x5eed_u64;
        let mut next = move || {
            state = crate::geometry::hash::mix(state);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut fins = Vec::new();
        for k in 0..40 {
            let (x, z) = (0.1 + 3.8 * next(), 0.1 + 3.8 * next());
            let (dx, dz) = (0.9 * next() - 0.45, 0.9 * next() - 0.45);
            // Half stand on the floor, half pass through it.
            let low = if k % 2 == 0 { 0.0 } else { -0.05 };
            fins.push(vec![
                [x, low, z],
                [x + dx, low, z + dz],
                [x + 0.3 * next(), 0.2, z + 0.3 * next()],
            ]);
        }
        d.surfaces.push(crate::scene::description::SurfaceDesc {
            name: "fins".into(),
            material: "wall".into(),
            polygons: fins,
            ..Default::default()
        });
        let mut scene = d.build("t", Path::new(".")).unwrap();
        let floor = scene.surfaces.iter().position(|s| s == "cube.-y").unwrap();
        let f = scene.faces.iter().position(|x| x.surface == floor).unwrap();
        let original: Vec<Polygon> = scene.faces.iter().map(|x| x.polygon).collect();
        // As built (a floor across an axis), and turned about an oblique axis (the plane's
        // coordinates then round).
        let turns = [
            glam::DQuat::IDENTITY,
            glam::DQuat::from_axis_angle(DVec3::new(0.3, 0.8, -0.5).normalize(), 0.7),
        ];
        for turn in turns {
            for (face, p) in scene.faces.iter_mut().zip(&original) {
                let v: Vec<DVec3> = p.vertices().iter().map(|&x| turn * x).collect();
                face.polygon = Polygon::new(&v).unwrap();
            }
            let imprinter = Imprinter::new(&scene.faces);
            let polygon = scene.faces[f].polygon;
            let contacts = imprinter.contacts(&polygon, bounds(&polygon), Some(f));
            assert!(contacts.len() > 4 * INDEXED_CONTACTS, "{}", contacts.len());
            let mut used = vec![false; contacts.len()];
            let mut expected_used = used.clone();
            let pieces = cut_all(vec![polygon], &contacts, polygon.area(), &mut used);
            let expected =
                cut_in_turn(vec![polygon], &contacts, polygon.area(), &mut expected_used);
            assert!(pieces.len() > 500, "{}", pieces.len());
            assert_eq!(pieces, expected);
            assert_eq!(used, expected_used);
            assert!(used.iter().any(|&u| !u) && used.iter().filter(|&&u| u).count() > 100);
        }
    }

    /// `Reach::near` answers every contact that `touches` a piece, however sharp its corners:
    /// edges ending within the tolerance of a corner of 0.5° to 90°, in any direction, among
    /// far ones that fill the index.
    #[test]
    fn near_contacts_include_every_touching_one() {
        let mut state = 0xc0ffee_u64;
        let mut next = move || {
            state = crate::geometry::hash::mix(state);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let normal = DVec3::Y;
        let flat = |x: f64, z: f64| DVec3::new(x, 0.0, z);
        let plane = Polygon::new(&[flat(0.0, 0.0), flat(0.0, 1.0), flat(1.0, 0.0)]).unwrap();
        let (mut touching, mut answered) = (0, 0);
        for case in 0..2000 {
            // A triangle with a corner of angle θ at the origin, counter-clockwise about +y.
            let theta = (0.5 + 89.5 * next()).to_radians();
            let r = 0.01 + next();
            let (a, b) = (flat(0.0, 0.0), flat(r, 0.0));
            let c = flat(r * theta.cos(), -r * theta.sin());
            let p = Polygon::new(&[a, b, c]).unwrap();
            assert!(p.normal.dot(normal) > 0.99, "{:?}", p.normal);
            let t = CONTACT_TOLERANCE * p.scale.max(plane.scale);
            // Edges ending up to 3 tolerances past the sharp corner's bisector, any direction.
            let mid = -(b.normalize() + c.normalize()).normalize();
            let end = mid * (t / (0.5 * theta).sin() * 3.0 * next());
            let dir = flat(next() - 0.5, next() - 0.5).normalize() * r;
            let mut contacts: Vec<Contact> = (0..80)
                .map(|k| Contact {
                    plane,
                    segment: (flat(5.0 + f64::from(k), 5.0), flat(5.5 + f64::from(k), 5.0)),
                    through: false,
                    face: 0,
                })
                .collect();
            contacts.push(Contact {
                plane,
                segment: (end, end + dir),
                through: false,
                face: 0,
            });
            let reach = Reach::new(normal, &contacts).unwrap();
            if touches(&p, &contacts[80]) {
                touching += 1;
                let near = reach
                    .near(&p, 0)
                    .expect("a bound for corners of 0.5° and more");
                assert!(near.contains(&80), "case {case}: θ {theta}");
                answered += 1;
            }
        }
        assert!(touching > 200 && answered == touching, "{touching}");
    }

    #[test]
    fn walls_along_a_boundary_cut_nothing() {
        let scene = procedural::furnace(0.5, 1.0)
            .build("t", Path::new("."))
            .unwrap();
        assert_eq!(split_at_contacts(&scene.faces).len(), 6);
    }

    /// The lines the index kept for a face are those a search finds, for a box within the
    /// face's and past it, and for faces not kept (here every third, and the faces past the
    /// allowance): 400 boxes on a floor (1 600 contacts on it) and a block through the floor.
    #[test]
    fn kept_lines_are_the_lines_searched() {
        let mut scene = crate::mesh::boxes_on_floor_and(&[([1.0, 1.0], [1.2, 1.2])]);
        let through = scene.faces.len();
        // A tilted quad through the floor (an interpenetration: `through` contacts).
        let v = [
            [2.0, 2.0, -0.1],
            [2.3, 2.0, 0.2],
            [2.3, 2.2, 0.2],
            [2.0, 2.2, -0.1],
        ]
        .map(|[x, y, z]| DVec3::new(x, y, z));
        scene.faces.push(Face {
            polygon: Polygon::new(&v).unwrap(),
            ..scene.faces[0].clone()
        });
        let floor = scene.surfaces.iter().position(|s| s == "cube.-z").unwrap();
        let floor = scene.faces.iter().position(|x| x.surface == floor).unwrap();
        let index = ContactIndex::new(&scene.faces);
        let imprinter = Imprinter::with(&scene.faces, &index);
        let lines: Vec<(usize, Box<[ContactLine]>)> = (0..scene.faces.len())
            .filter(|&f| f == floor || f % 3 != 1)
            .map(|f| {
                let p = &scene.faces[f].polygon;
                (
                    f,
                    ContactLine::of(&imprinter.contacts(p, bounds(p), Some(f))),
                )
            })
            .collect();
        let under = lines.iter().find(|(f, _)| *f == floor).unwrap().1.len();
        assert!(under >= 1_600, "{under}");
        let mut keeper = index.keeper();
        for (f, l) in &lines {
            keeper.add(*f, l);
        }
        index.keep(keeper);
        let kept = (0..scene.faces.len())
            .filter(|&f| index.kept(f).is_some())
            .count();
        println!("{kept} of {} faces kept", scene.faces.len());
        assert!(kept > scene.faces.len() / 2, "{kept}");
        let fresh = Imprinter::new(&scene.faces);
        let mut passing = 0;
        for (f, face) in scene.faces.iter().enumerate() {
            let (lo, hi) = bounds(&face.polygon);
            let boxes = [(lo, hi), (lo, 0.5 * (lo + hi)), (lo - (hi - lo) * 0.1, hi)];
            for b in boxes {
                let found = imprinter.face_lines(f, b);
                assert_eq!(found, fresh.face_lines(f, b), "face {f}, box {b:?}");
                passing += found.len();
            }
        }
        assert!(passing > 3 * 1_600, "{passing}");
        let on_floor = imprinter.face_lines(floor, bounds(&scene.faces[floor].polygon));
        assert!(on_floor.iter().any(|l| l.face() == through));
    }
}
