//! Planar regions: coplanar faces of one surface merged and meshed afresh, so that the element
//! count follows the area, never the input's triangulation (docs/MESHING.md, "Triangles").
//!
//! Faces are grouped by surface, material and plane (every vertex within [`PLANE_TOLERANCE`]
//! × the scene's extent of the group's plane, normals within 8°). A group is then meshed one of
//! two ways:
//!
//! - **as faces** ([`Root::Face`]): a lone quad, a lone face no larger than the element size
//!   (the triangles of curved surfaces), a lone well-shaped triangle (smallest angle ≥ 30°),
//!   a group of quads only (quads grid well), or a group
//!   whose union is one convex quad, or a triangle no larger than the element size (a quad
//!   written as two triangles or as a fan meshes exactly as the quad would). These go through
//!   imprinting and the subdivision hierarchy as before, except a face whose contacts would
//!   cut it into strips, which is meshed as a grid of its own (`subdivide::face_cut`).
//! - **as a grid** ([`Root::Grid`]): everything else with a triangle in it. A grid of cells of at
//!   most the element size, aligned with the group's longest edge and fitted to its bounding box,
//!   is laid over the plane; a cell the faces cover entirely is one (rectangular) element, a cell
//!   on the boundary gets the convex pieces `cell ∩ face` of the faces it meets. The count is
//!   at most `A / (c_u c_v)` full cells plus the cells the boundary crosses (about `P / c` for a
//!   perimeter `P`), whatever the input faces' shapes.

use rustc_hash::FxHashMap;

use glam::{DVec2, DVec3};

use super::element::{face_estimate, within};
use crate::geometry::Polygon;
use crate::scene::{Face, Scene};

/// Coplanarity tolerance, relative to the scene's extent (bounding-box diagonal).
pub(crate) const PLANE_TOLERANCE: f64 = 1e-6;
/// Normals of one region agree within this cosine (8°); the distance test does the real work.
const NORMAL_COSINE: f64 = 0.99;
/// A lone triangle whose smallest angle is at least this (degrees) keeps the 4-way midpoint
/// subdivision: its elements are similar to it, and it has at most `8 / sin 30° · A / h²`
/// of them (the two triangles of a non-planar quad, such as the Cornell box's red wall).
const WELL_SHAPED: f64 = 30.0;
/// Pieces below this fraction of their cell's area are dropped (their area is counted).
const MIN_PIECE_FRACTION: f64 = 1e-12;

/// A root of the fine mesh, in order of its first face.
#[derive(Debug, Clone)]
pub(crate) enum Root {
    /// A face (an input face, or a group merged into one convex polygon) for imprinting and
    /// the subdivision hierarchy; the index is its first input face.
    Face(Polygon, usize),
    /// A group meshed as a clipped grid.
    Grid(Grid),
}

/// A group of coplanar faces meshed as a grid, with the frame of its plane.
#[derive(Debug, Clone)]
pub(crate) struct Grid {
    /// Input faces, in scene order (the first names the elements' face).
    pub faces: Vec<usize>,
    /// The region when it is one polygon other than its face's (a face root meshed as a grid,
    /// [`Grid::of_polygon`]); `None`: the faces themselves.
    own: Option<Polygon>,
    origin: DVec3,
    u: DVec3,
    v: DVec3,
    /// The group's unit normal (every element gets it exactly).
    pub normal: DVec3,
    lo: DVec2,
    hi: DVec2,
}

/// What planning found: groups, merges and remeshed faces.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PlanCounts {
    /// Groups of several faces merged into one convex face (e.g. a quad written as triangles).
    pub merged_groups: usize,
    /// Input faces in those groups.
    pub merged_faces: usize,
    /// Groups meshed as a clipped grid.
    pub grid_groups: usize,
    /// Input faces in those groups.
    pub grid_faces: usize,
}

/// The scene's faces grouped into planar regions and each region's meshing decided.
/// `leaf_count` gives the elements the subdivision hierarchy makes of a polygon.
pub(crate) fn plan(
    scene: &Scene,
    element_size: f64,
    leaf_count: &dyn Fn(&Polygon) -> f64,
) -> (Vec<Root>, PlanCounts) {
    let tolerance = PLANE_TOLERANCE * scene.extent().max(f64::MIN_POSITIVE);
    let mut counts = PlanCounts::default();
    let mut roots = Vec::new();
    for group in plane_groups(&scene.faces, tolerance) {
        let faces: Vec<&Face> = group.iter().map(|&f| &scene.faces[f]).collect();
        let p = &faces[0].polygon;
        let lone = group.len() == 1
            && (p.count == 4 || within(p.size(), element_size) || min_angle(p) >= WELL_SHAPED);
        if lone || faces.iter().all(|f| f.polygon.count == 4) {
            roots.extend(group.iter().map(|&f| Root::Face(scene.faces[f].polygon, f)));
            continue;
        }
        let fits = |p: &Polygon| {
            p.count == 4 || within(p.size(), element_size) || min_angle(p) >= WELL_SHAPED
        };
        let polygons: Vec<Polygon> = faces.iter().map(|f| f.polygon).collect();
        if let Some(merged) = merge_convex(&polygons, tolerance)
            && fits(&merged)
        {
            if group.len() > 1 {
                counts.merged_groups += 1;
                counts.merged_faces += group.len();
            }
            roots.push(Root::Face(merged, group[0]));
            continue;
        }
        if group.len() <= MAX_PAIRWISE {
            let parts = merge_pairwise(&polygons, tolerance);
            // Kept when they subdivide into no more than `2 (A/h² + P/h)` elements, the grid's
            // bound (thin strips would not: each is subdivided along its length).
            let h = element_size;
            let kept = parts.iter().all(|(p, _)| fits(p)) && {
                let polys: Vec<Polygon> = parts.iter().map(|(p, _)| *p).collect();
                let perimeter = boundary_length(&polys, tolerance);
                let area: f64 = parts.iter().map(|(p, _)| p.area()).sum();
                let bound = 2.0 * (area / (h * h) + perimeter / h);
                let mut subdivided = 0.0;
                for (p, _) in &parts {
                    let e = face_estimate(p, h);
                    subdivided += if e <= bound { leaf_count(p) } else { e };
                }
                subdivided <= bound
            };
            if kept {
                counts.merged_groups += 1;
                counts.merged_faces += group.len();
                roots.extend(parts.into_iter().map(|(p, i)| Root::Face(p, group[i])));
                continue;
            }
        }
        counts.grid_groups += 1;
        counts.grid_faces += group.len();
        roots.push(Root::Grid(Grid::new(&scene.faces, group)));
    }
    (roots, counts)
}

/// The faces occlusion rays are tested against: each planar group whose union is one convex
/// polygon (a quad written as a grid of triangles, a fan) as that polygon, every other face as
/// it is. The same surfaces, in fewer faces: a Cornell box whose quads are cut into 512
/// triangles each traces against its quads (`None`: nothing merged, use the scene's faces).
pub(crate) fn occluder_faces(scene: &Scene) -> Option<Vec<Face>> {
    let tolerance = PLANE_TOLERANCE * scene.extent().max(f64::MIN_POSITIVE);
    let groups = plane_groups(&scene.faces, tolerance);
    // The groups that merge, with their polygons; the faces are copied only when one does (a
    // tessellated sphere has none, and copying its faces cost as much as the merging).
    let merged: Vec<(usize, Polygon)> = (groups.iter().enumerate())
        .filter(|(_, group)| group.len() > 1)
        .filter_map(|(g, group)| {
            let polygons: Vec<Polygon> = group.iter().map(|&f| scene.faces[f].polygon).collect();
            merge_convex(&polygons, tolerance).map(|p| (g, p))
        })
        .collect();
    if merged.is_empty() {
        return None;
    }
    let mut out = Vec::with_capacity(scene.faces.len());
    let mut next = merged.into_iter().peekable();
    for (g, group) in groups.iter().enumerate() {
        match next.next_if(|(m, _)| *m == g) {
            Some((_, polygon)) => out.push(Face {
                polygon,
                ..scene.faces[group[0]].clone()
            }),
            None => out.extend(group.iter().map(|&f| scene.faces[f].clone())),
        }
    }
    Some(out)
}

/// Faces grouped by (surface, material, plane), groups in order of their first face.
fn plane_groups(faces: &[Face], tolerance: f64) -> Vec<Vec<usize>> {
    type Key = (usize, usize, [i64; 4]);
    let quantum = 1e3 * tolerance;
    let key = |f: &Face| -> Key {
        let n = f.polygon.normal;
        let d = n.dot(f.polygon.vertices[0]);
        (
            f.surface,
            f.material,
            [
                (n.x * 50.0).round() as i64,
                (n.y * 50.0).round() as i64,
                (n.z * 50.0).round() as i64,
                (d / quantum).round() as i64,
            ],
        )
    };
    let mut buckets: FxHashMap<Key, Vec<usize>> = FxHashMap::default();
    // Which keys may have a bucket: one bit per key's hash, never a false negative. Most of a
    // face's 81 neighbouring keys have none (on a tessellated sphere nearly all), and the map
    // holds about 70 bytes a face where these bits are 4 to 8: a look-up whose bit is clear is
    // skipped, and the groups are the same. The bit's hash is linear in the key's numbers
    // before a multiplicative mix, so a face's 81 neighbours are its own sum plus one of 81
    // offsets (hashing each neighbouring key whole was half of this function's time on an
    // 81 920-triangle sphere).
    let bits = (faces.len() * 32).next_power_of_two().max(64);
    let shift = 64 - bits.trailing_zeros();
    let mut occupied = vec![0u64; bits / 64];
    const P: [u64; 6] = [
        0x9e37_79b9_7f4a_7c15,
        0xc2b2_ae3d_27d4_eb4f,
        0x1656_67b1_9e37_79f9,
        0x85eb_ca77_c2b2_ae63,
        0x27d4_eb2f_1656_67c5,
        0xd6e8_feb8_6659_fd93,
    ];
    let linear = |x: [i64; 6]| {
        (x.iter().zip(P)).fold(0u64, |h, (&x, p)| {
            h.wrapping_add((x as u64).wrapping_mul(p))
        })
    };
    let sum = |&(s, m, q): &Key| linear([s as i64, m as i64, q[0], q[1], q[2], q[3]]);
    let bit = |sum: u64| (sum.wrapping_mul(0x2545_f491_4f6c_dd1d) >> shift) as usize;
    // The 81 neighbouring keys' steps and offsets, in the order they are searched (the first
    // number's step slowest).
    let d: [[i64; 4]; 81] = std::array::from_fn(|i| {
        let i = i as i64;
        [i / 27 - 1, i / 9 % 3 - 1, i / 3 % 3 - 1, i % 3 - 1]
    });
    let offsets: [u64; 81] =
        std::array::from_fn(|i| linear([0, 0, d[i][0], d[i][1], d[i][2], d[i][3]]));
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (i, f) in faces.iter().enumerate() {
        let key = key(f);
        let own = sum(&key);
        let (s, m, q) = key;
        let mut found = None;
        'search: for (offset, d) in offsets.iter().zip(&d) {
            let b = bit(own.wrapping_add(*offset));
            if occupied[b / 64] & (1 << (b % 64)) == 0 {
                continue;
            }
            let k = (s, m, [q[0] + d[0], q[1] + d[1], q[2] + d[2], q[3] + d[3]]);
            for &g in buckets.get(&k).into_iter().flatten() {
                let first = &faces[groups[g][0]].polygon;
                if coplanar(first, &f.polygon, tolerance) {
                    found = Some(g);
                    break 'search;
                }
            }
        }
        match found {
            Some(g) => groups[g].push(i),
            None => {
                let b = bit(own);
                occupied[b / 64] |= 1 << (b % 64);
                buckets.entry(key).or_default().push(groups.len());
                groups.push(vec![i]);
            }
        }
    }
    groups
}

fn coplanar(a: &Polygon, b: &Polygon, tolerance: f64) -> bool {
    a.normal.dot(b.normal) >= NORMAL_COSINE
        && b.vertices().iter().all(|v| a.height(*v).abs() <= tolerance)
}

/// Largest group whose faces are merged pair by pair when the whole does not merge.
const MAX_PAIRWISE: usize = 256;

/// Faces merged two at a time while a pair's union is one convex polygon of 3 or 4 corners
/// (a ring of quads written as triangles becomes its quads again): the polygons and the index
/// of the first face of each.
fn merge_pairwise(polygons: &[Polygon], tolerance: f64) -> Vec<(Polygon, usize)> {
    let mut parts: Vec<Option<(Polygon, usize)>> = polygons
        .iter()
        .enumerate()
        .map(|(i, p)| Some((*p, i)))
        .collect();
    let touch = |a: &Polygon, b: &Polygon| {
        a.vertices()
            .iter()
            .filter(|x| {
                b.vertices()
                    .iter()
                    .any(|y| (**x - *y).length() <= tolerance)
            })
            .count()
            >= 2
    };
    let mut changed = true;
    while changed {
        changed = false;
        for i in 0..parts.len() {
            for j in i + 1..parts.len() {
                let (Some((a, ia)), Some((b, _))) = (parts[i], parts[j]) else {
                    continue;
                };
                if !touch(&a, &b) {
                    continue;
                }
                if let Some(m) = merge_convex(&[a, b], tolerance) {
                    parts[i] = Some((m, ia));
                    parts[j] = None;
                    changed = true;
                }
            }
        }
    }
    parts.into_iter().flatten().collect()
}

/// The union of the faces as one convex polygon of 3 or 4 corners, when it is one: shared
/// edges cancel, what is left must be one loop whose corners (collinear vertices removed) are
/// 3 or 4, convex, and whose area is the faces' total (no overlaps).
fn merge_convex(faces: &[Polygon], tolerance: f64) -> Option<Polygon> {
    let mut ids: FxHashMap<[i64; 3], usize> = FxHashMap::default();
    let mut points: Vec<DVec3> = Vec::new();
    let mut id = |p: DVec3| -> usize {
        let q = (p / tolerance).round();
        let q = [q.x as i64, q.y as i64, q.z as i64];
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(&i) = ids.get(&[q[0] + dx, q[1] + dy, q[2] + dz])
                        && (points[i] - p).length() <= tolerance
                    {
                        return i;
                    }
                }
            }
        }
        ids.insert(q, points.len());
        points.push(p);
        points.len() - 1
    };
    let mut edges: FxHashMap<(usize, usize), i32> = FxHashMap::default();
    let mut order: Vec<(usize, usize)> = Vec::new();
    for f in faces {
        let v = f.vertices();
        for i in 0..v.len() {
            let (a, b) = (id(v[i]), id(v[(i + 1) % v.len()]));
            if a == b {
                continue;
            }
            if let Some(c) = edges.get_mut(&(b, a))
                && *c > 0
            {
                *c -= 1;
                continue;
            }
            *edges.entry((a, b)).or_insert(0) += 1;
            order.push((a, b));
        }
    }
    let mut next: FxHashMap<usize, usize> = FxHashMap::default();
    let mut boundary = 0;
    for &(a, b) in &order {
        let c = edges.get_mut(&(a, b)).expect("recorded");
        if *c == 0 {
            continue;
        }
        if *c > 1 || next.insert(a, b).is_some() {
            return None;
        }
        *c = 0;
        boundary += 1;
    }
    let start = *next.keys().min()?;
    let mut lp = vec![start];
    let mut at = next[&start];
    while at != start {
        if lp.len() > boundary {
            return None;
        }
        lp.push(at);
        at = *next.get(&at)?;
    }
    if lp.len() != boundary {
        return None; // several loops: holes or separate pieces
    }
    let mut corners: Vec<DVec3> = lp.iter().map(|&i| points[i]).collect();
    loop {
        let m = corners.len();
        let flat = (0..m).find(|&i| {
            let (a, b, c) = (corners[(i + m - 1) % m], corners[i], corners[(i + 1) % m]);
            let along = (c - a).normalize_or_zero();
            let off = (b - a) - along * (b - a).dot(along);
            off.length() <= tolerance && (b - a).dot(along) > 0.0 && (c - b).dot(along) > 0.0
        });
        match flat {
            Some(i) if m > 3 => {
                corners.remove(i);
            }
            _ => break,
        }
    }
    let normal = faces[0].normal;
    let m = corners.len();
    let convex = (0..m).all(|i| {
        let (a, b, c) = (corners[i], corners[(i + 1) % m], corners[(i + 2) % m]);
        (b - a).cross(c - b).dot(normal) > 0.0
    });
    let mut polygon = Polygon::new(&corners)?;
    let total: f64 = faces.iter().map(|f| f.area()).sum();
    if !convex || (polygon.area() - total).abs() > 1e-9 * total {
        return None;
    }
    polygon.normal = normal;
    Some(polygon)
}

impl Grid {
    fn new(all: &[Face], faces: Vec<usize>) -> Self {
        Self::over(all, faces, None)
    }

    /// The grid over one polygon: a face root (the face `f` itself, or the region merged
    /// into one convex polygon that `f` names) whose contacts cut it into slivers
    /// (`subdivide::fine`).
    pub(crate) fn of_polygon(all: &[Face], polygon: Polygon, f: usize) -> Self {
        Self::over(all, vec![f], Some(polygon))
    }

    fn over(all: &[Face], faces: Vec<usize>, own: Option<Polygon>) -> Self {
        let mut grid = Self {
            faces,
            own,
            origin: DVec3::ZERO,
            u: DVec3::ZERO,
            v: DVec3::ZERO,
            normal: DVec3::ZERO,
            lo: DVec2::splat(f64::INFINITY),
            hi: DVec2::splat(f64::NEG_INFINITY),
        };
        let polygons = grid.polygons(all);
        // One polygon keeps its own normal exactly, as its subdivided pieces would.
        let normal = match &grid.own {
            Some(p) => p.normal,
            None => polygons
                .iter()
                .map(|p| p.normal * p.area())
                .sum::<DVec3>()
                .normalize(),
        };
        // Along the longest edge: a strip or a needle is then one row of cells.
        let mut best = (0.0, DVec3::ZERO);
        for p in &polygons {
            let v = p.vertices();
            for i in 0..v.len() {
                let e = v[(i + 1) % v.len()] - v[i];
                let e = e - normal * e.dot(normal);
                if e.length() > best.0 {
                    best = (e.length(), e);
                }
            }
        }
        let origin = polygons[0].vertices[0];
        drop(polygons);
        grid.normal = normal;
        grid.u = best.1.normalize();
        grid.v = normal.cross(grid.u);
        grid.origin = origin;
        let (mut lo, mut hi) = (grid.lo, grid.hi);
        for p in grid.polygons(all) {
            for x in p.vertices() {
                let q = grid.to_plane(*x);
                (lo, hi) = (lo.min(q), hi.max(q));
            }
        }
        (grid.lo, grid.hi) = (lo, hi);
        grid
    }

    /// The polygons the grid covers: its own, or its faces'.
    fn polygons<'a>(&'a self, all: &'a [Face]) -> Vec<&'a Polygon> {
        match &self.own {
            Some(p) => vec![p],
            None => self.faces.iter().map(|&f| &all[f].polygon).collect(),
        }
    }

    fn to_plane(&self, p: DVec3) -> DVec2 {
        let d = p - self.origin;
        DVec2::new(d.dot(self.u), d.dot(self.v))
    }

    fn to_space(&self, q: DVec2) -> DVec3 {
        self.origin + self.u * q.x + self.v * q.y
    }

    /// Cells along u and v, and the cell sides: the bounding box divided evenly into cells of
    /// at most the element size.
    fn cells(&self, element_size: f64) -> ([usize; 2], DVec2) {
        let extent = self.hi - self.lo;
        let count = |e: f64| ((e / element_size) * (1.0 - 1e-12)).ceil().max(1.0);
        let (nu, nv) = (count(extent.x), count(extent.y));
        let n = [nu.min(1e15) as usize, nv.min(1e15) as usize];
        (n, DVec2::new(extent.x / nu, extent.y / nv))
    }

    /// An upper bound on the elements, without clipping to cells: the (face, cell) pairs met
    /// row by row, plus 2 for each cell a face's edge crosses (a piece of a boundary cell with
    /// more than 4 corners is split into 2 or 3). Stops past `cap`.
    pub(crate) fn estimate(&self, all: &[Face], element_size: f64, cap: f64) -> f64 {
        let (n, c) = self.cells(element_size);
        let mut total = 0.0;
        for polygon in self.polygons(all) {
            let poly: Vec<DVec2> = polygon
                .vertices()
                .iter()
                .map(|p| self.to_plane(*p))
                .collect();
            let mut pairs = 0.0;
            for_rows(&poly, self.lo, n, c, &mut |_, _, i0, i1| {
                pairs += (i1 - i0 + 1) as f64;
                total + pairs <= cap
            });
            let crossed: f64 = (0..poly.len())
                .map(|i| {
                    let d = (poly[(i + 1) % poly.len()] - poly[i]).abs();
                    d.x / c.x + d.y / c.y + 2.0
                })
                .sum();
            total += pairs + 2.0 * crossed.min(pairs);
            if total > cap {
                break;
            }
        }
        total
    }

    /// The elements of the grid, row by row, cell by cell: polygons with the group's normal,
    /// and the area of pieces dropped as too small to be elements.
    pub(crate) fn elements(&self, all: &[Face], element_size: f64) -> (Vec<Polygon>, f64) {
        let (n, c) = self.cells(element_size);
        let mut pieces: Vec<(usize, usize, Vec<DVec2>)> = Vec::new();
        for polygon in self.polygons(all) {
            let poly: Vec<DVec2> = polygon
                .vertices()
                .iter()
                .map(|p| self.to_plane(*p))
                .collect();
            for_rows(&poly, self.lo, n, c, &mut |j, row, i0, i1| {
                for i in i0..=i1 {
                    let x0 = self.lo.x + i as f64 * c.x;
                    let x1 = if i + 1 == n[0] { self.hi.x } else { x0 + c.x };
                    let piece = clip(&clip(row, 0, x0, true), 0, x1, false);
                    if piece.len() >= 3 {
                        pieces.push((j, i, piece));
                    }
                }
                true
            });
        }
        pieces.sort_by_key(|p| (p.0, p.1)); // stable: faces in order within a cell
        let cell_area = c.x * c.y;
        let mut out = Vec::new();
        let mut dropped = 0.0;
        let mut start = 0;
        while start < pieces.len() {
            let (j, i) = (pieces[start].0, pieces[start].1);
            let end = start + pieces[start..].partition_point(|p| (p.0, p.1) == (j, i));
            let cell = &pieces[start..end];
            let covered: f64 = cell.iter().map(|p| signed_area(&p.2)).sum();
            if covered >= cell_area * (1.0 - 1e-9) {
                let (x0, y0) = (self.lo.x + i as f64 * c.x, self.lo.y + j as f64 * c.y);
                let x1 = if i + 1 == n[0] { self.hi.x } else { x0 + c.x };
                let y1 = if j + 1 == n[1] { self.hi.y } else { y0 + c.y };
                let rect = [
                    DVec2::new(x0, y0),
                    DVec2::new(x1, y0),
                    DVec2::new(x1, y1),
                    DVec2::new(x0, y1),
                ];
                self.emit(&rect, &mut out);
            } else {
                let eps = 1e-9 * c.x.max(c.y);
                let mut kept: Vec<Vec<DVec2>> = Vec::new();
                for (_, _, piece) in cell {
                    let a = signed_area(piece);
                    let clean = clean(piece, eps);
                    if a < MIN_PIECE_FRACTION * cell_area || clean.len() < 3 {
                        dropped += a.max(0.0);
                        continue;
                    }
                    kept.push(clean);
                }
                // The pieces of one cell merged while two share an edge and their union is
                // convex: a boundary cell is then one piece per convex part of cell ∩ region,
                // however many faces meet in it.
                let mut merged = true;
                while merged {
                    merged = false;
                    'pairs: for i in 0..kept.len() {
                        for j in i + 1..kept.len() {
                            if let Some(u) = union_convex(&kept[i], &kept[j], eps) {
                                kept[i] = u;
                                kept.swap_remove(j);
                                merged = true;
                                break 'pairs;
                            }
                        }
                    }
                }
                for clean in kept {
                    // A fan of quads (0, i, i+1, i+2) and a last triangle: convex pieces.
                    let mut k = 1;
                    while k + 2 < clean.len() {
                        self.emit(&[clean[0], clean[k], clean[k + 1], clean[k + 2]], &mut out);
                        k += 2;
                    }
                    if k + 1 < clean.len() {
                        self.emit(&[clean[0], clean[k], clean[k + 1]], &mut out);
                    }
                }
            }
            start = end;
        }
        (out, dropped)
    }

    fn emit(&self, q: &[DVec2], out: &mut Vec<Polygon>) {
        let v: Vec<DVec3> = q.iter().map(|p| self.to_space(*p)).collect();
        if let Some(mut p) = Polygon::new(&v) {
            p.normal = self.normal;
            out.push(p);
        }
    }

    /// The rectangle of the group's bounding box in its plane, with its normal: the plane (and
    /// the size its tolerances scale with) other faces' contacts are found on.
    pub(crate) fn plane_polygon(&self) -> Polygon {
        let (lo, hi) = (self.lo, self.hi);
        let corners = [
            DVec2::new(lo.x, lo.y),
            DVec2::new(hi.x, lo.y),
            DVec2::new(hi.x, hi.y),
            DVec2::new(lo.x, hi.y),
        ];
        let v: Vec<DVec3> = corners.iter().map(|q| self.to_space(*q)).collect();
        let mut p = Polygon::new(&v).expect("a group has an area");
        p.normal = self.normal;
        p
    }

    /// Lower and upper corners of the group's bounding box in space (for contact searches).
    pub(crate) fn bounds(&self, all: &[Face]) -> (DVec3, DVec3) {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for polygon in self.polygons(all) {
            for p in polygon.vertices() {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
        (lo, hi)
    }
}

/// What [`for_rows`] calls for each row: (row, piece in the row, first cell, last cell).
type RowVisit<'a> = &'a mut dyn FnMut(usize, &[DVec2], usize, usize) -> bool;

/// Calls `visit(row, piece of the polygon in the row, first cell, last cell)` for every row of
/// cells the (convex, plane) polygon meets; `visit` returns false to stop.
fn for_rows(poly: &[DVec2], lo: DVec2, n: [usize; 2], c: DVec2, visit: RowVisit<'_>) {
    let (mut vmin, mut vmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in poly {
        vmin = vmin.min(p.y);
        vmax = vmax.max(p.y);
    }
    let index = |x: f64, cell: f64, count: usize| -> usize {
        (((x / cell).floor()).max(0.0) as usize).min(count - 1)
    };
    let (j0, j1) = (index(vmin - lo.y, c.y, n[1]), index(vmax - lo.y, c.y, n[1]));
    for j in j0..=j1 {
        let y0 = lo.y + j as f64 * c.y;
        let y1 = if j + 1 == n[1] {
            f64::INFINITY
        } else {
            y0 + c.y
        };
        let y0 = if j == 0 { f64::NEG_INFINITY } else { y0 };
        let row = clip(&clip(poly, 1, y0, true), 1, y1, false);
        if row.len() < 3 {
            continue;
        }
        let (mut umin, mut umax) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in &row {
            umin = umin.min(p.x);
            umax = umax.max(p.x);
        }
        let (i0, i1) = (index(umin - lo.x, c.x, n[0]), index(umax - lo.x, c.x, n[0]));
        if !visit(j, &row, i0, i1) {
            return;
        }
    }
}

/// The part of a convex polygon with coordinate `axis` above (`keep_above`) or below `at`.
fn clip(poly: &[DVec2], axis: usize, at: f64, keep_above: bool) -> Vec<DVec2> {
    if !at.is_finite() {
        return poly.to_vec();
    }
    let side = |p: &DVec2| {
        let x = if axis == 0 { p.x } else { p.y };
        if keep_above { x - at } else { at - x }
    };
    let mut out = Vec::with_capacity(poly.len() + 2);
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        let (da, db) = (side(&a), side(&b));
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            let t = da / (da - db);
            let mut p = a + (b - a) * t;
            if axis == 0 {
                p.x = at;
            } else {
                p.y = at;
            }
            out.push(p);
        }
    }
    out
}

/// The union of two convex counter-clockwise polygons that share an edge (opposite ways,
/// within `eps`), when it is convex.
fn union_convex(a: &[DVec2], b: &[DVec2], eps: f64) -> Option<Vec<DVec2>> {
    let close = |p: DVec2, q: DVec2| (p - q).length() <= eps;
    let (n, m) = (a.len(), b.len());
    for i in 0..n {
        let (p, q) = (a[i], a[(i + 1) % n]);
        for j in 0..m {
            if !(close(b[j], q) && close(b[(j + 1) % m], p)) {
                continue;
            }
            // a from q round to p, then b from p round to q (skipping the shared corners).
            let mut u: Vec<DVec2> = (0..n).map(|k| a[(i + 1 + k) % n]).collect();
            u.extend((2..m).map(|k| b[(j + k) % m]));
            let u = clean(&u, eps);
            let l = u.len();
            let convex = l >= 3
                && (0..l).all(|k| {
                    let (x, y, z) = (u[k], u[(k + 1) % l], u[(k + 2) % l]);
                    (y - x).perp_dot(z - y) >= -eps * (z - x).length()
                });
            return convex.then_some(u);
        }
    }
    None
}

fn signed_area(p: &[DVec2]) -> f64 {
    let mut s = 0.0;
    for i in 0..p.len() {
        let (a, b) = (p[i], p[(i + 1) % p.len()]);
        s += a.x * b.y - a.y * b.x;
    }
    0.5 * s
}

/// Drops repeated corners (closer than `eps`) and straight ones.
fn clean(p: &[DVec2], eps: f64) -> Vec<DVec2> {
    let mut v: Vec<DVec2> = Vec::with_capacity(p.len());
    for q in p {
        if v.last().is_none_or(|l| (*l - *q).length() > eps) {
            v.push(*q);
        }
    }
    while v.len() > 1 && (v[0] - v[v.len() - 1]).length() <= eps {
        v.pop();
    }
    let mut changed = true;
    while changed && v.len() > 3 {
        changed = false;
        let m = v.len();
        for i in 0..m {
            let (a, b, c) = (v[(i + m - 1) % m], v[i], v[(i + 1) % m]);
            if (b - a).perp_dot(c - b).abs() <= eps * (c - a).length() {
                v.remove(i);
                changed = true;
                break;
            }
        }
    }
    v
}

/// Length of the polygons' edges that no other polygon shares (reversed, within `tolerance`):
/// the perimeter of their union when they meet edge to edge.
fn boundary_length(polygons: &[Polygon], tolerance: f64) -> f64 {
    let edges: Vec<(DVec3, DVec3)> = polygons
        .iter()
        .flat_map(|p| {
            let v = p.vertices();
            (0..v.len()).map(move |i| (v[i], v[(i + 1) % v.len()]))
        })
        .collect();
    let close = |a: DVec3, b: DVec3| (a - b).length() <= tolerance;
    edges
        .iter()
        .filter(|(a, b)| !edges.iter().any(|(c, d)| close(*a, *d) && close(*b, *c)))
        .map(|(a, b)| (*b - *a).length())
        .sum()
}

/// The smallest interior angle of a convex polygon, in degrees.
pub(crate) fn min_angle(p: &Polygon) -> f64 {
    let v = p.vertices();
    let m = v.len();
    (0..m)
        .map(|i| {
            let (a, b) = (v[(i + m - 1) % m] - v[i], v[(i + 1) % m] - v[i]);
            a.angle_between(b).to_degrees()
        })
        .fold(180.0, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn face(v: &[[f64; 3]]) -> Face {
        let v: Vec<DVec3> = v.iter().map(|p| DVec3::from_array(*p)).collect();
        Face {
            polygon: Polygon::new(&v).unwrap(),
            material: 0,
            surface: 0,
            uv: [None, None],
        }
    }

    #[test]
    fn two_triangles_merge_into_their_quad() {
        let a = face(&[[0., 0., 0.], [2., 0., 0.], [2., 1., 0.]]);
        let b = face(&[[0., 0., 0.], [2., 1., 0.], [0., 1., 0.]]);
        let q = merge_convex(&[a.polygon, b.polygon], 1e-9).unwrap();
        assert_eq!(q.count, 4);
        assert!((q.area() - 2.0).abs() < 1e-12);
    }

    #[test]
    fn a_fan_with_points_on_the_edges_merges_into_its_quad() {
        // Fan from (0,0) over the far edges, which carry extra collinear points.
        let hub = [0., 0., 0.];
        let rim = [
            [1., 0., 0.],
            [1., 0.3, 0.],
            [1., 0.31, 0.],
            [1., 1., 0.],
            [0.5, 1., 0.],
            [0., 1., 0.],
        ];
        let faces: Vec<Face> = rim.windows(2).map(|w| face(&[hub, w[0], w[1]])).collect();
        let refs: Vec<Polygon> = faces.iter().map(|f| f.polygon).collect();
        let q = merge_convex(&refs, 1e-9).unwrap();
        assert_eq!(q.count, 4);
    }

    #[test]
    fn a_ring_does_not_merge() {
        // An L of two squares' worth of triangles: concave, not one convex face.
        let faces = [
            face(&[[0., 0., 0.], [2., 0., 0.], [2., 1., 0.]]),
            face(&[[0., 0., 0.], [2., 1., 0.], [0., 1., 0.]]),
            face(&[[0., 1., 0.], [1., 1., 0.], [1., 2., 0.]]),
            face(&[[0., 1., 0.], [1., 2., 0.], [0., 2., 0.]]),
        ];
        let refs: Vec<Polygon> = faces.iter().map(|f| f.polygon).collect();
        assert!(merge_convex(&refs, 1e-9).is_none());
        // Pair by pair they are the two rectangles again.
        let parts = merge_pairwise(&refs, 1e-9);
        assert_eq!(parts.len(), 2);
        assert!(parts.iter().all(|(p, _)| p.count == 4));
    }

    #[test]
    fn clipping_keeps_area() {
        let tri = [DVec2::new(0., 0.), DVec2::new(3., 0.), DVec2::new(0., 2.)];
        let left = clip(&tri, 0, 1.0, false);
        let right = clip(&tri, 0, 1.0, true);
        assert!((signed_area(&left) + signed_area(&right) - 3.0).abs() < 1e-12);
    }
}
