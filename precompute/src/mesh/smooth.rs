//! Smooth reconstruction weights (`lrr_formats::Smooth`): which element corners share a value,
//! and which element values make it.
//!
//! A corner's *smooth vertex* gathers the elements around its position that lie on the same
//! smooth surface: same surface and material, normals within [`CREASE_DEGREES`], and reached
//! from the corner's element across edges that leave the position (an edge ray shared by both
//! elements) and do not lie on a contact line (where `imprint` cut a face because another face
//! stands on it: the light on its two sides differs; the faces of the two elements themselves do
//! not count, so the triangles of a tessellated sphere join across their edges). Elements meeting only at the position
//! (across the corner of a block standing on a floor) are joined only through such edges, so
//! the lit floor around a block's corner shares one vertex and the dark floor under it another.
//!
//! A vertex on its surface's boundary (its elements' angles short of a full turn: a wall's edge,
//! the foot of a block, a contact line) does not take the mean of its elements, which is the
//! value near their centres, not at the boundary: it takes the value there of the
//! least-squares plane through the values of the elements around it (its own and those sharing
//! a vertex with them), a linear extrapolation whose weights sum to one and may be negative;
//! the runtime clamps it at zero. Against the reference (docs/ACCURACY.md) this takes the
//! Cornell box from 2.07% / 11.6% (median / p90, the mean everywhere) to 1.96% / 9.8%, the
//! cluttered room from 1.69% / 13.6% to 1.46% / 12.8%, the dense sphere from 3.14% / 9.45% to
//! 2.84% / 8.0% (its worst point from 55% to 22%); clamping the value to the range of the
//! elements it sums instead measured 1.85% / 10.4%, 1.58% / 12.9%, 2.84% / 9.45%.
//!
//! Meshes do not conform everywhere (each imprinted piece and each region is subdivided on its
//! own): a corner lying inside an edge of a neighbour on the same smooth surface (a
//! T-junction) also takes that neighbour's value, the edge giving it two rays.
//!
//! Inside a surface, the value of a smooth vertex is the mean of its elements' values weighted by
//! their angle at the position (π for an edge through it). Measured against the path-traced reference
//! (docs/ACCURACY.md; means everywhere, before the boundary extrapolation above), angle weights
//! beat area weights a little: median / p90 on the Cornell
//! box 2.07% / 11.6% against 2.12% / 12.0%, on the cluttered room 1.69% / 13.6% against
//! 1.67% / 15.0%, the same on the dense sphere. Positions coincide within `1e-7` of the scene's
//! extent. Everything runs in file order over maps used only for look-ups (positions and
//! faces are searched in parallel, the results taken in order): the same mesh gives the same
//! bytes whatever the thread count.

use rustc_hash::FxHashMap;

use glam::DVec3;
use lrr_formats::Smooth;
use rayon::prelude::*;

use super::element::Element;
use super::imprint::{ContactIndex, ContactLine, Imprinter, polygon_bounds};
use crate::geometry::boxes::BoxGrid;
use crate::scene::Scene;

/// Largest angle between the normals of two elements that share a smooth vertex (degrees).
/// Above it the edge is a crease (a box's corner: 90°); below it a tessellated curved surface
/// is smoothed (the 1 280-triangle sphere's neighbours differ by about 9°).
pub const CREASE_DEGREES: f64 = 30.0;
/// Positions closer than this fraction of the scene's extent are one position.
const POSITION_TOLERANCE: f64 = 1e-7;
/// A vertex whose elements' angles fall short of a full turn by more than this (radians) lies
/// on its surface's boundary (an icosphere's vertices fall short by 4π / vertices).
const BOUNDARY_DEFICIT: f64 = std::f64::consts::FRAC_PI_4;
/// Largest weight magnitude an extrapolating vertex may take (else it keeps the mean).
const MAX_EXTRAPOLATION_WEIGHT: f64 = 8.0;
/// Two edge rays are one when their directions' dot product exceeds `1 - RAY_TOLERANCE`.
const RAY_TOLERANCE: f64 = 1e-9;

/// Bytes [`weights`] may hold at once per face (element) it is given, planned before it
/// starts. Per face, with its four corners: their positions and look-ups (the corner's
/// position index, the map of bit patterns met and the grid of positions: about 200 bytes),
/// the incidence lists (16 bytes a corner and a list per position: about 110) and the faces'
/// boxes in the grid of boxes (48 and up to 8 cells: about 180); the contact lines of the
/// scene's faces; then the weights three times over (the means, the boundary's plane fits
/// and, for grouped elements, [`per_element`]): a member and a weight (8 bytes) per corner
/// and T-junction, the corners' vertex ids (16) and a vertex's offset and boundary position
/// (36), about 100 bytes each time. A boundary vertex's fit gathers at most
/// [`MAX_RING_TERMS`] members, so nothing grows faster than the faces (a fan of fewer
/// triangles than that with a boundary rim stores up to 8 bytes a face per triangle of the
/// fan). About 800 bytes all told for ordinary meshes; not a worst-case bound. Measured:
/// zdm2's 94 295 display faces (scenes/real) raised the resident memory by 56.7 MB over the
/// stage, 601 bytes a face.
const BUILD_BYTES_PER_FACE: u128 = 1024;

/// What [`weights`] (and [`per_element`] after it) may take over `faces` faces.
pub(crate) fn build_bytes(faces: usize) -> u128 {
    faces as u128 * BUILD_BYTES_PER_FACE
}

/// The smooth reconstruction weights of the fine mesh `elements` (file order) of `scene`.
pub(crate) fn weights(
    scene: &Scene,
    elements: &[&Element],
    index: Option<&ContactIndex>,
) -> Smooth {
    let tol = POSITION_TOLERANCE * scene.extent().max(f64::MIN_POSITIVE);
    let (corner_pos, positions) = positions(elements, tol);
    let incidence = Incidence::new(elements, &positions, &corner_pos, tol);
    let contacts = contacts_per_face(scene, elements, index);
    let cos_crease = CREASE_DEGREES.to_radians().cos();
    // Per smooth vertex: its position when it lies on its surface's boundary.
    let mut boundary: Vec<Option<DVec3>> = Vec::new();
    let mut out = Smooth {
        corners: vec![Smooth::NONE; elements.len() * 4],
        offsets: vec![0],
        positions: Vec::new(),
        weights: Vec::new(),
    };
    // The smooth vertices of each position, found in parallel a chunk of positions at a time
    // (bounded working memory), numbered in position order.
    let found_at = |p: usize| -> Vec<Found> {
        let x = positions[p];
        let around = incidence.around(p, x, elements);
        let joined = |a: &Incident, b: &Incident| {
            let (ea, eb) = (elements[a.element], elements[b.element]);
            let m = |e: &Element| scene.faces[e.face as usize].material;
            ea.surface == eb.surface
                && m(ea) == m(eb)
                && ea.polygon.normal.dot(eb.polygon.normal) >= cos_crease
                && a.shares_free_ray(
                    b,
                    x,
                    [ea.face, eb.face],
                    [&contacts[ea.face as usize], &contacts[eb.face as usize]],
                    tol,
                )
        };
        components(&around, joined)
            .into_iter()
            // only T-junction neighbours: no corner takes this value
            .filter(|group| group.iter().any(|&i| around[i].corner.is_some()))
            .map(|group| {
                let angles: Vec<f64> = group.iter().map(|&i| around[i].weight).collect();
                let total: f64 = angles.iter().filter(|a| a.is_finite()).sum();
                Found {
                    members: group
                        .iter()
                        .map(|&i| (around[i].element, around[i].corner))
                        .collect(),
                    weights: mean_weights(&angles),
                    closed: total >= 2.0 * std::f64::consts::PI - BOUNDARY_DEFICIT,
                }
            })
            .collect()
    };
    for start in (0..positions.len()).step_by(CHUNK) {
        let chunk = start..positions.len().min(start + CHUNK);
        let found: Vec<Vec<Found>> = chunk.clone().into_par_iter().map(found_at).collect();
        for (p, vertices) in chunk.zip(found) {
            for v in vertices {
                let vertex = out.offsets.len() as u32 - 1;
                boundary.push((!v.closed).then_some(positions[p]));
                for (element, corner) in v.members {
                    if let Some(c) = corner {
                        out.corners[element * 4 + c] = vertex;
                    }
                    out.positions.push(element as u32);
                }
                out.weights.extend(v.weights);
                out.offsets.push(out.positions.len() as u32);
            }
        }
    }
    extrapolate(&out, elements, &boundary)
}

/// Positions (smooth vertices) handled in parallel at a time.
const CHUNK: usize = 1 << 14;

/// A smooth vertex found at a position: its members (element, and its corner there unless the
/// position lies inside an edge), their weights, and whether their angles make a full turn.
struct Found {
    members: Vec<(usize, Option<usize>)>,
    weights: Vec<f32>,
    closed: bool,
}

/// The weights `s` of display faces (its positions index faces) as weights of the elements
/// they show (`element_of[face]`, a file position): a vertex's weights on faces of one
/// element add up, and weights that cancel (below [`MIN_MEAN_WEIGHT`] in magnitude) are left
/// out, the rest scaled to sum to one; a vertex whose weights cancel (sum below a half) or
/// would grow past [`MAX_EXTRAPOLATION_WEIGHT`] takes the plain mean of its elements. The
/// corners stay the faces'.
pub fn per_element(s: &Smooth, element_of: &[u32]) -> Smooth {
    let mut out = Smooth {
        corners: s.corners.clone(),
        offsets: vec![0],
        positions: Vec::new(),
        weights: Vec::new(),
    };
    let mut sums: Vec<(u32, f64)> = Vec::new();
    for v in 0..s.vertex_count() {
        let range = s.offsets[v] as usize..s.offsets[v + 1] as usize;
        sums.clear();
        for (&p, &w) in s.positions[range.clone()].iter().zip(&s.weights[range]) {
            let e = element_of[p as usize];
            match sums.iter_mut().find(|(x, _)| *x == e) {
                Some((_, total)) => *total += f64::from(w),
                None => sums.push((e, f64::from(w))),
            }
        }
        sums.sort_by_key(|&(e, _)| e);
        let kept: Vec<(u32, f64)> = sums
            .iter()
            .copied()
            .filter(|(_, w)| w.abs() >= MIN_MEAN_WEIGHT)
            .collect();
        let total: f64 = kept.iter().map(|(_, w)| w).sum();
        let bounded = kept
            .iter()
            .all(|(_, w)| (w / total).abs() <= MAX_EXTRAPOLATION_WEIGHT);
        if kept.is_empty() || total.abs() < 0.5 || !bounded {
            let share = 1.0 / sums.len() as f64;
            for &(e, _) in &sums {
                out.positions.push(e);
                out.weights.push(share as f32);
            }
        } else {
            for (e, w) in kept {
                out.positions.push(e);
                out.weights.push((w / total) as f32);
            }
        }
        out.offsets.push(out.positions.len() as u32);
    }
    out
}

/// Smallest weight a member of a mean takes, relative to the mean's total: a needle's corner
/// (an angle of 1e-9 rad) or a degenerate one (no angle at all) still counts, so that every
/// stored weight is non-zero and the weights sum to one in `f32` whatever the input.
const MIN_MEAN_WEIGHT: f64 = 1e-6;

/// Weights proportional to `angles` (radians), summing to one: a non-finite or negative angle
/// (two corners of one element within the position tolerance) counts as zero, every weight is
/// at least [`MIN_MEAN_WEIGHT`] before the weights are normalised, and a group whose angles
/// are all (nearly) zero (the corners of needles and of coincident vertices) takes the plain
/// mean.
fn mean_weights(angles: &[f64]) -> Vec<f32> {
    let clean: Vec<f64> = angles
        .iter()
        .map(|&a| if a.is_finite() && a > 0.0 { a } else { 0.0 })
        .collect();
    let total: f64 = clean.iter().sum();
    let raw: Vec<f64> = if total > 1e-12 {
        clean
            .iter()
            .map(|a| (a / total).max(MIN_MEAN_WEIGHT))
            .collect()
    } else {
        vec![1.0; clean.len()]
    };
    let sum: f64 = raw.iter().sum();
    raw.iter().map(|w| (w / sum) as f32).collect()
}

/// Most members a boundary vertex's neighbourhood may gather (its elements' corners' smooth
/// vertices' members, counted with repeats) for the plane fit; beyond it the vertex keeps
/// the mean. A regular mesh gathers tens (three elements, three corners, six members each:
/// 54), more along T-junctions and at the hubs of real models: at 128, vertices of the
/// living room, CornellBox-Water and zdm2 (scenes/real) kept their means and those bakes
/// changed; at 512, zdm2 still did; at 2048 none does. The rim of a fan of 10⁴ triangles
/// round one vertex would gather the fan at each of its 10⁴ vertices, 10⁸ weights (1.6 GB and
/// 26 s before this bound). A fan of m < 1020 triangles still stores m weights at each of
/// its m rim vertices: 8m bytes a face, which [`BUILD_BYTES_PER_FACE`] is not sized for
/// beyond about m = 60.
const MAX_RING_TERMS: usize = 2048;

/// `s` with each boundary vertex (`boundary[v]` its position) extrapolated: the value at the
/// vertex of the least-squares plane through the values of the elements around it (its own
/// and those sharing a vertex with them), at their centroids, weighted by area, in the tangent
/// plane of its elements. The weights sum to 1 and may be negative; the runtime clamps the
/// value at zero. A vertex whose neighbourhood gives no plane (its elements' centroids on a
/// line), a weight beyond [`MAX_EXTRAPOLATION_WEIGHT`] or more than [`MAX_RING_TERMS`] to
/// gather keeps the mean, so no vertex holds more weights than that or its own members.
fn extrapolate(s: &Smooth, elements: &[&Element], boundary: &[Option<DVec3>]) -> Smooth {
    let members = |v: usize| &s.positions[s.offsets[v] as usize..s.offsets[v + 1] as usize];
    let mut out = Smooth {
        corners: s.corners.clone(),
        offsets: vec![0],
        positions: Vec::new(),
        weights: Vec::new(),
    };
    for (v, at) in boundary.iter().enumerate() {
        let range = s.offsets[v] as usize..s.offsets[v + 1] as usize;
        // Bounded before it is gathered: the rim of a fan of m triangles would gather the
        // apex's m members at each of its m vertices.
        let gathered = || {
            members(v)
                .iter()
                .map(|&e| {
                    let e = e as usize;
                    let used = elements[e].polygon.count;
                    (s.corners[4 * e..4 * e + used].iter())
                        .map(|&c| members(c as usize).len())
                        .sum::<usize>()
                })
                .sum::<usize>()
        };
        let fitted = at.filter(|_| gathered() <= MAX_RING_TERMS).and_then(|x| {
            let mut ring: Vec<u32> = members(v)
                .iter()
                .flat_map(|&e| {
                    let e = e as usize;
                    let used = elements[e].polygon.count;
                    s.corners[4 * e..4 * e + used]
                        .iter()
                        .flat_map(|&c| members(c as usize).iter().copied())
                })
                .collect();
            ring.sort_unstable();
            ring.dedup();
            let normal = members(v)
                .iter()
                .fold(DVec3::ZERO, |n, &e| n + elements[e as usize].polygon.normal);
            plane_weights(&ring, elements, x, normal)
        });
        match fitted {
            Some(fit) => {
                for (e, w) in fit {
                    out.positions.push(e);
                    out.weights.push(w);
                }
            }
            None => {
                out.positions.extend_from_slice(&s.positions[range.clone()]);
                out.weights.extend_from_slice(&s.weights[range]);
            }
        }
        out.offsets.push(out.positions.len() as u32);
    }
    out
}

/// The weights `λ_e` (summing to 1) with which `Σ λ_e B_e` is the value at `x` of the plane
/// fitted by least squares (weighted by area) through `(centroid_e, B_e)` over `ring`, in the
/// plane of `normal`; `None` when the fit is singular or a weight is beyond
/// [`MAX_EXTRAPOLATION_WEIGHT`].
fn plane_weights(
    ring: &[u32],
    elements: &[&Element],
    x: DVec3,
    normal: DVec3,
) -> Option<Vec<(u32, f32)>> {
    let n = normal.try_normalize()?;
    let t1 = n.any_orthonormal_vector();
    let t2 = n.cross(t1);
    let rows: Vec<(u32, [f64; 3], f64)> = ring
        .iter()
        .map(|&e| {
            let p = &elements[e as usize].polygon;
            let d = p.centroid() - x;
            (e, [1.0, d.dot(t1), d.dot(t2)], p.area())
        })
        .collect();
    let mut a = glam::DMat3::ZERO;
    for (_, r, w) in &rows {
        let r = DVec3::from_array(*r);
        a += glam::DMat3::from_cols(r * r.x, r * r.y, r * r.z) * *w;
    }
    let scale = a.x_axis.x * a.y_axis.y * a.z_axis.z;
    let det = a.determinant();
    if det.is_nan() || det <= 1e-9 * scale {
        return None;
    }
    let z = a.inverse() * DVec3::X;
    let fit: Vec<(u32, f32)> = rows
        .iter()
        .map(|(e, r, w)| (*e, (w * DVec3::from_array(*r).dot(z)) as f32))
        .filter(|(_, l)| *l != 0.0)
        .collect();
    let bounded = fit
        .iter()
        .all(|(_, l)| l.is_finite() && f64::from(l.abs()) <= MAX_EXTRAPOLATION_WEIGHT);
    // The weights of a least-squares plane's value sum to one exactly; an ill-conditioned fit
    // (nearly collinear centroids that passed the determinant test) can lose that in rounding.
    let sum: f64 = fit.iter().map(|(_, l)| f64::from(*l)).sum();
    (bounded && !fit.is_empty() && (sum - 1.0).abs() <= 1e-6).then_some(fit)
}

/// The distinct corner positions (within `tol`) in order of first appearance, and each
/// corner's position index (`elements.len() * 4`, unused corners `usize::MAX`).
fn positions(elements: &[&Element], tol: f64) -> (Vec<usize>, Vec<DVec3>) {
    let cell = |x: DVec3| (x / tol).floor().as_i64vec3().to_array();
    let mut grid: FxHashMap<[i64; 3], Vec<usize>> = FxHashMap::default();
    // Corners met before, bit for bit, and the position each took: a tessellated surface
    // repeats each vertex in every face around it. A corner takes the lowest-numbered position
    // within `tol`; positions are made more than `tol` apart and numbered as made, so the same
    // coordinates always take the same position, and the look-up gives what the search would.
    let mut seen: FxHashMap<[u64; 3], usize> = FxHashMap::default();
    let mut positions: Vec<DVec3> = Vec::new();
    let mut corner_pos = vec![usize::MAX; elements.len() * 4];
    for (s, e) in elements.iter().enumerate() {
        for (i, &v) in e.polygon.vertices().iter().enumerate() {
            let bits = v.to_array().map(f64::to_bits);
            if let Some(&p) = seen.get(&bits) {
                corner_pos[s * 4 + i] = p;
                continue;
            }
            let c = cell(v);
            let found = neighbours(c)
                .filter_map(|k| grid.get(&k))
                .flatten()
                .copied()
                .filter(|&p| positions[p].distance(v) <= tol)
                .min();
            let p = found.unwrap_or_else(|| {
                positions.push(v);
                grid.entry(c).or_default().push(positions.len() - 1);
                positions.len() - 1
            });
            seen.insert(bits, p);
            corner_pos[s * 4 + i] = p;
        }
    }
    (corner_pos, positions)
}

/// The 27 cells around and including `c`.
fn neighbours(c: [i64; 3]) -> impl Iterator<Item = [i64; 3]> {
    (0..27).map(move |i| [c[0] + i % 3 - 1, c[1] + (i / 3) % 3 - 1, c[2] + i / 9 - 1])
}

/// An element around a position: by a corner, or by an edge the position lies inside.
#[derive(Debug, Clone, Copy)]
struct Incident {
    element: usize,
    /// The corner at the position; `None`: the position lies inside an edge (a T-junction).
    corner: Option<usize>,
    /// Unit directions of the two edges leaving the position, and their lengths.
    rays: [(DVec3, f64); 2],
    /// Weight of the element's value at this position: its angle there (π inside an edge).
    weight: f64,
}

impl Incident {
    /// True when `self` and `other` leave the position `x` along one edge that lies on no
    /// contact segment of either element's face.
    /// A face standing on the edge counts unless it is one of the two elements' own `faces`
    /// (neighbours of a tessellated surface meet at an edge of each other's face).
    fn shares_free_ray(
        &self,
        other: &Incident,
        x: DVec3,
        faces: [u32; 2],
        contacts: [&FaceContacts; 2],
        tol: f64,
    ) -> bool {
        self.rays.iter().any(|&(d, la)| {
            other.rays.iter().any(|&(e, lb)| {
                d.dot(e) > 1.0 - RAY_TOLERANCE && {
                    let mid = x + d * (0.5 * la.min(lb));
                    !contacts
                        .iter()
                        .any(|cs| cs.on_edge(mid, d, faces, 10.0 * tol))
                }
            })
        })
    }
}

/// The contact lines in one face's plane, indexed by their boxes past
/// [`INDEXED_CONTACTS`](super::imprint::INDEXED_CONTACTS) of them: the floor of a hall of
/// 10 000 boxes has 40 000, and every edge met at every position of the floor asked them all
/// (the smooth stage ran for minutes).
#[derive(Default)]
struct FaceContacts {
    list: Vec<ContactLine>,
    index: Option<BoxGrid>,
}

impl FaceContacts {
    fn new(list: Vec<ContactLine>) -> Self {
        let index = (list.len() > super::imprint::INDEXED_CONTACTS).then(|| {
            let boxes: Vec<(DVec3, DVec3)> = list.iter().map(ContactLine::bounds).collect();
            BoxGrid::new(&boxes)
        });
        Self { list, index }
    }

    /// Whether a segment along `d` with midpoint `mid` lies on a contact line of a face
    /// other than `faces` (within `tol`: [`ContactLine::holds`]), the index narrowing the
    /// search to the contacts whose boxes come within `tol` of `mid`.
    fn on_edge(&self, mid: DVec3, d: DVec3, faces: [u32; 2], tol: f64) -> bool {
        let holds = |c: &ContactLine| !faces.contains(&(c.face() as u32)) && c.holds(mid, d, tol);
        match &self.index {
            None => self.list.iter().any(holds),
            Some(index) => {
                let g = DVec3::splat(tol);
                let near = index.candidates((mid - g, mid + g));
                near.into_iter().any(|i| holds(&self.list[i as usize]))
            }
        }
    }
}

/// Elements by their boxes (for T-junction search) and by their corners.
struct Incidence {
    /// Each element's box grown by `tol`, indexed: a face of any size is in at most 8 cells
    /// (a uniform grid at the median edge put a game level's 50 m floor triangles in millions
    /// of cells: 0.7 GB of a 1 GB bake).
    grid: BoxGrid,
    /// Per position: (element, corner) pairs, in file order.
    by_position: Vec<Vec<(usize, usize)>>,
    tol: f64,
}

impl Incidence {
    fn new(elements: &[&Element], positions: &[DVec3], corner_pos: &[usize], tol: f64) -> Self {
        let mut by_position = vec![Vec::new(); positions.len()];
        for (k, &p) in corner_pos.iter().enumerate() {
            if p != usize::MAX {
                by_position[p].push((k / 4, k % 4));
            }
        }
        let boxes: Vec<(DVec3, DVec3)> = (elements.iter())
            .map(|e| {
                let (lo, hi) = polygon_bounds(&e.polygon);
                (lo - DVec3::splat(tol), hi + DVec3::splat(tol))
            })
            .collect();
        let grid = BoxGrid::new(&boxes);
        Self {
            grid,
            by_position,
            tol,
        }
    }

    /// The elements around position `p` at `x`: those with a corner there, then those with
    /// `x` inside an edge, each in file order.
    fn around(&self, p: usize, x: DVec3, elements: &[&Element]) -> Vec<Incident> {
        let mut out: Vec<Incident> = self.by_position[p]
            .iter()
            .map(|&(s, i)| {
                let v = elements[s].polygon.vertices();
                let n = v.len();
                let ray = |to: DVec3| ((to - x).normalize(), (to - x).length());
                let rays = [ray(v[(i + 1) % n]), ray(v[(i + n - 1) % n])];
                Incident {
                    element: s,
                    corner: Some(i),
                    rays,
                    weight: rays[0].0.dot(rays[1].0).clamp(-1.0, 1.0).acos(),
                }
            })
            .collect();
        // In file order, as the elements are numbered.
        let mut candidates = self.grid.candidates((x, x));
        candidates.sort_unstable();
        candidates.dedup();
        for s in candidates {
            let s = s as usize;
            if self.by_position[p].iter().any(|&(e, _)| e == s) {
                continue;
            }
            let v = elements[s].polygon.vertices();
            for i in 0..v.len() {
                let (a, b) = (v[i], v[(i + 1) % v.len()]);
                let ab = b - a;
                let t = (x - a).dot(ab) / ab.length_squared();
                let inside = t * ab.length() > self.tol && (1.0 - t) * ab.length() > self.tol;
                if inside && (a + ab * t).distance(x) <= self.tol {
                    let d = ab.normalize();
                    out.push(Incident {
                        element: s,
                        corner: None,
                        rays: [(d, (b - x).length()), (-d, (a - x).length())],
                        weight: std::f64::consts::PI,
                    });
                    break;
                }
            }
        }
        out
    }
}

/// Groups of `items` connected by `joined` (union-find), each group's members in increasing
/// index, groups in order of their first member.
fn components<T>(items: &[T], joined: impl Fn(&T, &T) -> bool) -> Vec<Vec<usize>> {
    let mut parent: Vec<usize> = (0..items.len()).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for a in 0..items.len() {
        for b in a + 1..items.len() {
            if joined(&items[a], &items[b]) {
                let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
                parent[ra.max(rb)] = ra.min(rb);
            }
        }
    }
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut slot = vec![usize::MAX; items.len()];
    for i in 0..items.len() {
        let r = root(&mut parent, i);
        if slot[r] == usize::MAX {
            slot[r] = groups.len();
            groups.push(Vec::new());
        }
        groups[slot[r]].push(i);
    }
    groups
}

/// The contact lines (`imprint`) in the plane of each face that has elements, by face index
/// (none for the others); the faces are searched in parallel, those `index` (the mesh's)
/// holds already are not searched again.
fn contacts_per_face(
    scene: &Scene,
    elements: &[&Element],
    index: Option<&ContactIndex>,
) -> Vec<FaceContacts> {
    let mut bounds: Vec<Option<(DVec3, DVec3)>> = vec![None; scene.faces.len()];
    for e in elements {
        let (lo, hi) = polygon_bounds(&e.polygon);
        let b = &mut bounds[e.face as usize];
        *b = Some(b.map_or((lo, hi), |(l, h)| (l.min(lo), h.max(hi))));
    }
    let imprinter = match index {
        Some(index) => Imprinter::with(&scene.faces, index),
        None => Imprinter::new(&scene.faces),
    };
    bounds
        .par_iter()
        .enumerate()
        .map(|(f, b)| match b {
            Some(b) => FaceContacts::new(imprinter.face_lines(f, *b)),
            None => FaceContacts::default(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{MeshSizes, fine_mesh};
    use crate::scene::description::BoxDesc;
    use crate::scene::procedural;
    use std::path::Path;

    /// The fine mesh of `scene` at `element_size` and its smooth weights (generation order
    /// stands in for file order: the weights do not depend on the order).
    fn mesh_and_weights(scene: &Scene, element_size: f64) -> (Vec<Element>, Smooth) {
        let sizes = MeshSizes {
            element_size,
            patch_size: 4.0 * element_size,
        };
        // What the file draws: a dense mesh's elements as their faces.
        let (elements, _, _) = fine_mesh(scene, sizes).unwrap();
        let (faces, _, _) = crate::mesh::shown_faces(elements.iter());
        let refs: Vec<&Element> = faces.iter().collect();
        let smooth = weights(scene, &refs, None);
        (faces, smooth)
    }

    /// The elements of each smooth vertex.
    fn members(s: &Smooth) -> Vec<Vec<usize>> {
        (0..s.vertex_count())
            .map(|v| {
                let r = s.offsets[v] as usize..s.offsets[v + 1] as usize;
                s.positions[r].iter().map(|&p| p as usize).collect()
            })
            .collect()
    }

    /// Weights non-zero and within ±8, summing to 1, every used corner named, each corner's
    /// element among its vertex's members.
    fn assert_well_formed(elements: &[Element], s: &Smooth) {
        assert_eq!(s.corners.len(), 4 * elements.len());
        for v in 0..s.vertex_count() {
            let r = s.offsets[v] as usize..s.offsets[v + 1] as usize;
            let w = &s.weights[r.clone()];
            assert!(!w.is_empty() && w.iter().all(|&x| x != 0.0 && x.abs() <= 8.0));
            // summed in f64, as the file's check sums them
            let sum: f64 = w.iter().map(|&x| f64::from(x)).sum();
            assert!((sum - 1.0).abs() < 1e-5, "vertex {v}: sum {sum}");
        }
        let m = members(s);
        for (e, el) in elements.iter().enumerate() {
            for i in 0..4 {
                let c = s.corners[4 * e + i];
                if i < el.polygon.count {
                    assert!(m[c as usize].contains(&e), "element {e} corner {i}");
                } else {
                    assert_eq!(c, Smooth::NONE);
                }
            }
        }
    }

    /// The walls of a closed room meet at 90°: no smooth vertex spans two walls; inside a wall
    /// the grid's vertices have their four elements.
    #[test]
    fn creases_are_not_smoothed_across() {
        let scene = procedural::furnace(0.5, 1.0)
            .build("t", Path::new("."))
            .unwrap();
        let (elements, s) = mesh_and_weights(&scene, 0.25);
        assert_well_formed(&elements, &s);
        let mut four = 0;
        for (v, m) in members(&s).iter().enumerate() {
            let surface = elements[m[0]].surface;
            assert!(m.iter().all(|&e| elements[e].surface == surface), "{m:?}");
            let positive = s.weights[s.offsets[v] as usize..s.offsets[v + 1] as usize]
                .iter()
                .all(|&w| w > 0.0);
            four += usize::from(m.len() == 4 && positive);
        }
        // 6 walls of 4×4 elements: 3×3 interior vertices each, the mean of their four elements
        // (the boundary's vertices extrapolate, with negative weights)
        assert_eq!(four, 6 * 9);
    }

    /// Element values of a linear field (at their centroids) give every vertex, inside and on
    /// the boundary (extrapolated), the field's value there.
    #[test]
    fn vertex_values_of_a_linear_field_are_exact() {
        let scene = procedural::furnace(0.5, 1.0)
            .build("t", Path::new("."))
            .unwrap();
        let (elements, s) = mesh_and_weights(&scene, 0.125);
        let field = |x: DVec3| 1.0 + 0.3 * x.x - 0.2 * x.y + 0.1 * x.z;
        let mut boundary = 0;
        for e in 0..elements.len() {
            for (i, x) in elements[e].polygon.vertices().iter().enumerate() {
                let v = s.corners[4 * e + i] as usize;
                let r = s.offsets[v] as usize..s.offsets[v + 1] as usize;
                let value: f64 = s.positions[r.clone()]
                    .iter()
                    .zip(&s.weights[r.clone()])
                    .map(|(&p, &w)| f64::from(w) * field(elements[p as usize].polygon.centroid()))
                    .sum();
                assert!((value - field(*x)).abs() < 2e-6, "{x}: {value}");
                boundary += usize::from(s.weights[r].iter().any(|&w| w < 0.0));
            }
        }
        assert!(
            boundary >= 6 * 4 * 8,
            "{boundary} corners on boundary vertices"
        );
    }

    /// Two materials on one plane (a floor of two faces): the vertices along their common edge
    /// are doubled, one per material.
    #[test]
    fn materials_are_not_smoothed_across() {
        let mut scene = procedural::furnace(0.5, 1.0)
            .build("t", Path::new("."))
            .unwrap();
        let floor = scene.surfaces.iter().position(|s| s == "cube.-z").unwrap();
        let mut other = scene.materials[0].clone();
        other.name = "other".into();
        scene.materials.push(other);
        let f = scene.faces.iter().position(|x| x.surface == floor).unwrap();
        let half = |x0: f64, x1: f64| {
            crate::geometry::Polygon::new(&[
                DVec3::new(x0, 0.0, 0.0),
                DVec3::new(x1, 0.0, 0.0),
                DVec3::new(x1, 1.0, 0.0),
                DVec3::new(x0, 1.0, 0.0),
            ])
        };
        let (mut a, mut b) = (half(0.0, 0.5).unwrap(), half(0.5, 1.0).unwrap());
        a.normal = scene.faces[f].polygon.normal;
        b.normal = a.normal;
        scene.faces[f].polygon = a;
        let mut second = scene.faces[f].clone();
        second.polygon = b;
        second.material = scene.materials.len() - 1;
        scene.faces.push(second);
        let (elements, s) = mesh_and_weights(&scene, 0.25);
        assert_well_formed(&elements, &s);
        let material = |e: usize| scene.faces[elements[e].face as usize].material;
        for m in members(&s) {
            assert!(m.iter().all(|&e| material(e) == material(m[0])), "{m:?}");
        }
        let mut seam: Vec<u32> = (0..elements.len())
            .filter(|&e| elements[e].surface == floor as u32)
            .flat_map(|e| (0..4).map(move |i| (e, i)))
            .filter(|&(e, i)| i < elements[e].polygon.count)
            .filter(|&(e, i)| (elements[e].polygon.vertices[i].x - 0.5).abs() < 1e-12)
            .map(|(e, i)| s.corners[4 * e + i])
            .collect();
        seam.sort_unstable();
        seam.dedup();
        let on_seam = seam.len();
        assert_eq!(
            on_seam,
            2 * 5,
            "one vertex per material at each of the 5 seam positions"
        );
    }

    /// A box standing on a floor: where it stands (x = 1, 0.25 < y < 0.75) the floor's vertices
    /// split into the two sides; along the rest of the cut line (y < 0.25) they join.
    #[test]
    fn contact_lines_are_not_smoothed_across_and_the_cut_line_beyond_is() {
        let mut d = procedural::furnace(0.5, 1.0);
        d.boxes[0].max = [2.0, 1.0, 1.0];
        d.boxes.push(BoxDesc {
            name: "block".into(),
            material: "wall".into(),
            min: [1.0, 0.25, 0.0],
            max: [1.5, 0.75, 0.5],
            inward: false,
            omit: vec![],
        });
        let scene = d.build("t", Path::new(".")).unwrap();
        let floor = scene.surfaces.iter().position(|s| s == "cube.-z").unwrap() as u32;
        let (elements, s) = mesh_and_weights(&scene, 0.125);
        assert_well_formed(&elements, &s);
        let (mut split, mut joined) = (0, 0);
        for (e, el) in elements.iter().enumerate() {
            if el.surface != floor {
                continue;
            }
            for (i, v) in el.polygon.vertices().iter().enumerate() {
                if (v.x - 1.0).abs() > 1e-12 || v.y <= 0.0 || v.y >= 1.0 {
                    continue;
                }
                let m = &members(&s)[s.corners[4 * e + i] as usize];
                let c = |o: usize| elements[o].polygon.centroid();
                let under = |o: &usize| c(*o).x > 1.0 && (0.25..0.75).contains(&c(*o).y);
                let sides: Vec<bool> = m.iter().map(|&o| c(o).x > 1.0).collect();
                let both = sides.contains(&true) && sides.contains(&false);
                if v.y > 0.25 + 1e-9 && v.y < 0.75 - 1e-9 {
                    // lit floor and the floor under the block never mix (a boundary vertex's
                    // extrapolation may reach round the block's corner to lit floor beyond it)
                    assert!(
                        m.iter().all(under) || !m.iter().any(under),
                        "a vertex at {v} under the block's side joins both sides: {m:?}"
                    );
                    split += 1;
                } else if v.y < 0.25 - 1e-9 || v.y > 0.75 + 1e-9 {
                    assert!(both, "a vertex at {v} beside the block is split: {m:?}");
                    joined += 1;
                }
            }
        }
        assert!(split >= 6 && joined >= 6, "{split} split, {joined} joined");
    }

    /// The Cornell box: the meshes of imprinted pieces do not conform, and corners inside a
    /// neighbour's edge take its value (T-junctions); a tessellated sphere joins its triangles.
    #[test]
    fn t_junctions_and_tessellated_surfaces_join() {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box/cornell-box.toml");
        let scene = crate::scene::load(&path).unwrap();
        let (elements, s) = mesh_and_weights(&scene, scene.extent() / 20.0);
        assert_well_formed(&elements, &s);
        let t_junctions = members(&s)
            .iter()
            .enumerate()
            .filter(|(v, m)| {
                m.iter()
                    .any(|&e| !s.corners[4 * e..4 * e + 4].contains(&(*v as u32)))
            })
            .count();
        assert!(
            t_junctions >= 10,
            "{t_junctions} vertices with T-junction members"
        );

        let scene = procedural::dense_sphere(2)
            .build("t", Path::new("."))
            .unwrap();
        let sphere = scene.surfaces.iter().position(|x| x == "sphere").unwrap() as u32;
        let (elements, s) = mesh_and_weights(&scene, 1.0);
        assert_well_formed(&elements, &s);
        let on_sphere: Vec<Vec<usize>> = members(&s)
            .into_iter()
            .filter(|m| elements[m[0]].surface == sphere)
            .collect();
        // an icosphere of level 2: 162 vertices, 5 or 6 triangles each
        assert_eq!(on_sphere.len(), 162);
        assert!(on_sphere.iter().all(|m| m.len() == 5 || m.len() == 6));
    }

    #[test]
    fn the_same_mesh_gives_the_same_weights() {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box/cornell-box.toml");
        let scene = crate::scene::load(&path).unwrap();
        let (_, a) = mesh_and_weights(&scene, scene.extent() / 20.0);
        let (_, b) = mesh_and_weights(&scene, scene.extent() / 20.0);
        assert_eq!(a, b);
    }

    /// A scene of the given triangles, one surface and one material.
    fn triangles(tris: &[[DVec3; 3]]) -> Scene {
        crate::mesh::tests::one_surface("s", tris)
    }

    /// The weights of `scene` meshed at `h` are well formed, and the file's own check (the
    /// one that refused McGuire's CornellBox-Sphere) accepts them.
    fn weights_hold(scene: &Scene, h: f64) -> (Vec<Element>, Smooth) {
        let (elements, s) = mesh_and_weights(scene, h);
        assert!(!elements.is_empty());
        assert_well_formed(&elements, &s);
        (elements, s)
    }

    /// A needle (base 200, height 0.01: area 1) at h = 0.1, and slivers of rising aspect.
    #[test]
    fn needles_and_slivers_get_weights_that_sum_to_one() {
        let needle = [
            DVec3::ZERO,
            DVec3::new(200.0, 0.0, 0.0),
            DVec3::new(100.0, 0.01, 0.0),
        ];
        weights_hold(&triangles(&[needle]), 0.1);
        for aspect in [1e2, 1e4, 1e6] {
            // two slivers meeting along their long edge, folded by 10° (one smooth surface)
            let (a, b) = (DVec3::ZERO, DVec3::new(1.0, 0.0, 0.0));
            let up = DVec3::new(0.5, 1.0 / aspect, 0.0);
            let fold = 10f64.to_radians();
            let down = DVec3::new(0.5, -fold.cos() / aspect, fold.sin() / aspect);
            weights_hold(&triangles(&[[a, b, up], [b, a, down]]), 0.05);
        }
    }

    /// A cone of 10⁴ needle triangles round its apex (one smooth surface; the rim's height
    /// alternates by 1e-5 so that no two neighbours are coplanar and each triangle stays a
    /// face of its own): the apex joins all of them with weights that sum to one.
    #[test]
    fn a_fan_of_ten_thousand_triangles_round_a_vertex() {
        let m = 10_000;
        let apex = DVec3::new(0.0, 0.0, 0.2);
        let rim = |i: usize| {
            let t = std::f64::consts::TAU * i as f64 / m as f64;
            DVec3::new(
                t.cos(),
                t.sin(),
                if i.is_multiple_of(2) { 0.0 } else { 1e-5 },
            )
        };
        let tris: Vec<[DVec3; 3]> = (0..m).map(|i| [apex, rim(i), rim(i + 1)]).collect();
        let scene = triangles(&tris);
        assert_eq!(scene.faces.len(), m);
        let (elements, s) = weights_hold(&scene, 2.0);
        let largest = members(&s).iter().map(Vec::len).max().unwrap();
        assert!(
            largest >= m,
            "{largest} members at the apex, {} elements",
            elements.len()
        );
        // The rim's boundary vertices keep their means: gathering the apex's m members at
        // each of them for a plane fit stored m² weights (10⁸: 1.6 GB and 26 s).
        let stored = s.weights.len();
        assert!(stored <= 8 * m, "{stored} weights stored for {m} faces");
    }

    /// Coincident and duplicated vertices: a quad written twice (duplicate faces), a triangle
    /// whose vertices nearly coincide within the position tolerance, and a zero-area sliver
    /// dropped on import beside them.
    #[test]
    fn coincident_vertices_and_duplicate_faces() {
        let (a, b, c, d) = (
            DVec3::ZERO,
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
        );
        let eps = 1e-9;
        let tris = [
            [a, b, c],
            [a, c, d],
            [a, b, c],
            [a, c, d],
            [
                c,
                b + DVec3::new(eps, 0.0, 1.0),
                c + DVec3::new(0.0, eps, 0.5),
            ],
            [a, b, a + DVec3::new(0.5 * eps, 0.0, 0.0)],
        ];
        weights_hold(&triangles(&tris), 0.25);
    }

    /// Tessellated spheres, coarse to fine, meshed at an element size above and below their
    /// triangles' size.
    #[test]
    fn tessellated_spheres_of_any_density() {
        for level in [1, 3, 4] {
            let scene = procedural::dense_sphere(level)
                .build("t", Path::new("."))
                .unwrap();
            for h in [scene.extent() / 20.0, scene.extent() / 200.0] {
                weights_hold(&scene, h);
            }
        }
    }

    /// The weights with the mesh's contact index (the lines meshing kept) are those with
    /// none (every face searched), for the elements (the refinement's indicator) and for the
    /// display faces, on a tessellated sphere (grouped faces) and boxes standing on a floor.
    #[test]
    fn the_mesh_contact_index_gives_the_same_weights() {
        let sphere = procedural::dense_sphere(3)
            .build("t", Path::new("."))
            .unwrap();
        let boxes = crate::mesh::boxes_on_floor_and(&[]);
        for scene in [sphere, boxes] {
            let h = scene.extent() / 20.0;
            let sizes = MeshSizes {
                element_size: h,
                patch_size: 4.0 * h,
            };
            let mesh = crate::patches::Mesh::two_fixed(&scene, sizes).unwrap();
            let index = mesh.contacts.as_deref();
            assert!(index.is_some());
            let elements: Vec<&Element> = mesh.elements.iter().collect();
            let (faces, _, _) = crate::mesh::shown_faces(mesh.elements.iter());
            let shown: Vec<&Element> = faces.iter().collect();
            for refs in [elements, shown] {
                assert_eq!(weights(&scene, &refs, index), weights(&scene, &refs, None));
            }
        }
    }

    #[test]
    fn mean_weights_are_non_zero_and_sum_to_one() {
        for angles in [
            vec![0.0, 0.0, 0.0],
            vec![f64::NAN, 1.0],
            vec![1e-300, 1.0, 2.0],
            vec![-1.0, f64::INFINITY],
            vec![1e-20; 7],
        ] {
            let w = mean_weights(&angles);
            let sum: f64 = w.iter().map(|&x| f64::from(x)).sum();
            assert!(w.iter().all(|&x| x > 0.0), "{angles:?}: {w:?}");
            assert!((sum - 1.0).abs() < 1e-6, "{angles:?}: {sum}");
        }
    }
}
