//! Scenes the project generates: the furnace cube and the analytic form-factor pairs of
//! DESIGN.md §4, as scene descriptions (`lrr scene …` writes them as TOML).

use super::description::{BoxDesc, MaterialDesc, MeshHints, SceneDescription, SurfaceDesc};

fn grey(name: &str, rho: f64, radiance: f64) -> MaterialDesc {
    MaterialDesc {
        name: name.into(),
        reflectance: [rho; 3],
        radiance: [radiance; 3],
        ..Default::default()
    }
}

fn empty(name: String) -> SceneDescription {
    SceneDescription {
        name: Some(name),
        ..Default::default()
    }
}

/// A closed unit cube, inward-facing, uniform reflectance `rho` and emitted radiance
/// `radiance` everywhere: the exact radiosity is `π·radiance / (1 - rho)`.
pub fn furnace(rho: f64, radiance: f64) -> SceneDescription {
    let mut d = empty(format!("furnace rho={rho}"));
    d.materials.push(grey("wall", rho, radiance));
    d.boxes.push(BoxDesc {
        name: "cube".into(),
        material: "wall".into(),
        min: [0.0; 3],
        max: [1.0; 3],
        inward: true,
        omit: Vec::new(),
    });
    d.mesh = MeshHints {
        element_size: Some(0.125),
        patch_size: Some(0.25),
    };
    d
}

/// Two directly opposed parallel squares of side `side`, `distance` apart, facing each other.
/// Closed form: Hottel's crossed-strings family (DESIGN.md §4: 0.199825 at side/distance 1).
pub fn parallel_squares(side: f64, distance: f64) -> SceneDescription {
    let mut d = empty(format!("parallel squares side={side} distance={distance}"));
    d.materials.push(grey("grey", 0.5, 0.0));
    let s = side;
    d.surfaces.push(SurfaceDesc {
        name: "bottom".into(),
        material: "grey".into(),
        polygons: vec![vec![
            [0.0, 0.0, 0.0],
            [s, 0.0, 0.0],
            [s, s, 0.0],
            [0.0, s, 0.0],
        ]],
        ..Default::default()
    });
    d.surfaces.push(SurfaceDesc {
        name: "top".into(),
        material: "grey".into(),
        polygons: vec![vec![
            [0.0, 0.0, distance],
            [0.0, s, distance],
            [s, s, distance],
            [s, 0.0, distance],
        ]],
        ..Default::default()
    });
    d.mesh = MeshHints {
        element_size: Some(side / 10.0),
        patch_size: Some(side / 4.0),
    };
    d
}

/// Perpendicular rectangles sharing an edge of length `length` (along y): `base` lies in z = 0
/// with width `width` along x, `wall` stands in x = 0 with height `height` along z.
pub fn perpendicular(length: f64, width: f64, height: f64) -> SceneDescription {
    let mut d = empty(format!("perpendicular l={length} w={width} h={height}"));
    d.materials.push(grey("grey", 0.5, 0.0));
    let l = length;
    d.surfaces.push(SurfaceDesc {
        name: "base".into(),
        material: "grey".into(),
        polygons: vec![vec![
            [0.0, 0.0, 0.0],
            [width, 0.0, 0.0],
            [width, l, 0.0],
            [0.0, l, 0.0],
        ]],
        ..Default::default()
    });
    d.surfaces.push(SurfaceDesc {
        name: "wall".into(),
        material: "grey".into(),
        polygons: vec![vec![
            [0.0, 0.0, 0.0],
            [0.0, l, 0.0],
            [0.0, l, height],
            [0.0, 0.0, height],
        ]],
        ..Default::default()
    });
    let size = length.min(width).min(height);
    d.mesh = MeshHints {
        element_size: Some(size / 10.0),
        patch_size: Some(size / 4.0),
    };
    d
}

/// Largest icosphere subdivision level of [`dense_sphere`] (20·4⁶ = 81 920 triangles).
pub const MAX_SPHERE_SUBDIVISIONS: u32 = 6;

/// The closed unit room (y up) of the dense sphere and the showcase scenes: box `room` of
/// material `wall` without its top, the ceiling `ceiling` (`wall`) around a 0.2 × 0.2 square
/// `light` of material `light`. The caller adds the two materials (in its own order).
pub(crate) fn lit_room_surfaces(d: &mut SceneDescription) {
    d.boxes.push(BoxDesc {
        name: "room".into(),
        material: "wall".into(),
        min: [0.0; 3],
        max: [1.0; 3],
        inward: true,
        omit: vec!["+y".into()],
    });
    // The ceiling (y = 1, facing down) as four quads around the light's square.
    let quad = |x0: f64, x1: f64, z0: f64, z1: f64| {
        vec![[x0, 1.0, z0], [x1, 1.0, z0], [x1, 1.0, z1], [x0, 1.0, z1]]
    };
    d.surfaces.push(SurfaceDesc {
        name: "ceiling".into(),
        material: "wall".into(),
        polygons: vec![
            quad(0.0, 1.0, 0.0, 0.4),
            quad(0.0, 1.0, 0.6, 1.0),
            quad(0.0, 0.4, 0.4, 0.6),
            quad(0.6, 1.0, 0.4, 0.6),
        ],
        ..Default::default()
    });
    d.surfaces.push(SurfaceDesc {
        name: "light".into(),
        material: "light".into(),
        polygons: vec![quad(0.4, 0.6, 0.4, 0.6)],
        ..Default::default()
    });
}

/// A dense mesh for the clustering path: an icosphere of `20·4^subdivisions` small triangles
/// (radius 0.25, floating at the centre of a closed unit room, y up) lit by a square light in
/// the ceiling. Its triangles are smaller than the elements and patches, so 2MF and 2MSC build
/// its patches by clustering (`geometry::cluster`).
pub fn dense_sphere(subdivisions: u32) -> SceneDescription {
    let mut d = empty(format!("dense sphere subdivisions={subdivisions}"));
    d.materials.push(grey("wall", 0.7, 0.0));
    d.materials.push(MaterialDesc {
        name: "clay".into(),
        reflectance: [0.75, 0.45, 0.3],
        radiance: [0.0; 3],
        ..Default::default()
    });
    d.materials.push(grey("light", 0.0, 10.0));
    lit_room_surfaces(&mut d);
    let centre = [0.5, 0.4, 0.5];
    d.surfaces.push(
        SurfaceDesc {
            name: "sphere".into(),
            material: "clay".into(),
            polygons: icosphere(subdivisions.min(MAX_SPHERE_SUBDIVISIONS), centre, 0.25),
            ..Default::default()
        }
        .indexed(),
    );
    d.mesh = MeshHints {
        element_size: Some(0.125),
        patch_size: Some(0.25),
    };
    d
}

/// Triangles of an icosahedron subdivided `levels` times (edges halved, vertices pushed onto
/// the sphere), counter-clockwise seen from outside.
pub(crate) fn icosphere(levels: u32, centre: [f64; 3], radius: f64) -> Vec<Vec<[f64; 3]>> {
    use glam::DVec3;
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let v = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .map(|p| DVec3::from_array(p).normalize());
    const FACES: [[usize; 3]; 20] = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let mut tris: Vec<[DVec3; 3]> = FACES.iter().map(|f| f.map(|i| v[i])).collect();
    for _ in 0..levels {
        let mid = |a: DVec3, b: DVec3| ((a + b) * 0.5).normalize();
        tris = tris
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
                [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
            })
            .collect();
    }
    let c = DVec3::from_array(centre);
    tris.iter()
        .map(|&[a, b, d]| {
            // outward: the normal (b - a) × (d - a) points away from the centre
            let outward = (b - a).cross(d - a).dot(a + b + d) > 0.0;
            let tri = if outward { [a, b, d] } else { [a, d, b] };
            tri.iter().map(|p| (c + *p * radius).to_array()).collect()
        })
        .collect()
}

/// A cluttered room for visibility tests and benchmarks (`lrr scene cluttered`): a closed
/// 4 × 4 × 2.5 room lit by a ceiling lamp, with a `grid` × `grid` array of objects on the
/// floor, one per cell, chosen and placed by `seed`: boxes standing on the floor, upright
/// zero-thickness panels (two coincident faces back to back) turned to any angle, leaning
/// panels, shelves (a horizontal panel on a box), boxes with a box stacked on top. Heights are
/// multiples of 0.25, so many tops are coplanar, and every object stands on the floor: rays
/// graze coplanar faces, contact lines and panel edges everywhere.
pub fn cluttered(grid: usize, seed: u64) -> SceneDescription {
    let mut d = empty(format!("cluttered grid={grid} seed={seed}"));
    d.materials.push(grey("wall", 0.6, 0.0));
    d.materials.push(MaterialDesc {
        name: "clutter".into(),
        reflectance: [0.7, 0.5, 0.3],
        radiance: [0.0; 3],
        ..Default::default()
    });
    d.materials.push(grey("lamp", 0.5, 8.0));
    let (side, height) = (4.0, 2.5);
    d.boxes.push(BoxDesc {
        name: "room".into(),
        material: "wall".into(),
        min: [0.0; 3],
        max: [side, side, height],
        inward: true,
        omit: Vec::new(),
    });
    let z = height - 0.05;
    d.surfaces.push(SurfaceDesc {
        name: "lamp".into(),
        material: "lamp".into(),
        polygons: vec![vec![
            [1.6, 1.6, z],
            [1.6, 2.4, z],
            [2.4, 2.4, z],
            [2.4, 1.6, z],
        ]],
        ..Default::default()
    });
    let grid = grid.max(1);
    let cell = side / grid as f64;
    let mut state = seed;
    let mut next = || {
        state = crate::geometry::hash::mix(state);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    // Heights in multiples of 0.25 up to 1.5 (coplanar tops across the room).
    let step = |u: f64| 0.25 * (1.0 + (u * 6.0).floor().min(5.0));
    // A box standing on something: its bottom is never seen.
    let boxed = |d: &mut SceneDescription, name: String, min: [f64; 3], max: [f64; 3]| {
        d.boxes.push(BoxDesc {
            name,
            material: "clutter".into(),
            min,
            max,
            inward: false,
            omit: vec!["-z".into()],
        });
    };
    // Both faces of a zero-thickness panel, back to back.
    let panel = |d: &mut SceneDescription, name: String, quad: [[f64; 3]; 4]| {
        let mut back = quad;
        back.reverse();
        d.surfaces.push(SurfaceDesc {
            name,
            material: "clutter".into(),
            polygons: vec![quad.to_vec(), back.to_vec()],
            ..Default::default()
        });
    };
    for i in 0..grid {
        for j in 0..grid {
            let (x0, y0) = (i as f64 * cell, j as f64 * cell);
            let (cx, cy) = (x0 + 0.5 * cell, y0 + 0.5 * cell);
            let margin = 0.08 * cell;
            let name = format!("c{i}-{j}");
            let kind = (next() * 5.0) as u32;
            let h = step(next());
            match kind {
                0 => {
                    // A box standing on the floor.
                    let w = 0.3 * cell + 0.5 * cell * next();
                    let half = 0.5 * w.min(cell - 2.0 * margin);
                    boxed(
                        &mut d,
                        name,
                        [cx - half, cy - half, 0.0],
                        [cx + half, cy + half, h],
                    );
                }
                1 => {
                    // An upright panel turned by any angle about the vertical.
                    let a = std::f64::consts::PI * next();
                    let r = 0.5 * cell - margin;
                    let (dx, dy) = (r * a.cos(), r * a.sin());
                    panel(
                        &mut d,
                        name,
                        [
                            [cx - dx, cy - dy, 0.0],
                            [cx + dx, cy + dy, 0.0],
                            [cx + dx, cy + dy, h],
                            [cx - dx, cy - dy, h],
                        ],
                    );
                }
                2 => {
                    // A panel leaning over: bottom edge on the floor, top edge shifted.
                    let lean = (next() - 0.5) * (cell - 2.0 * margin);
                    let (ya, yb) = (y0 + margin, y0 + cell - margin);
                    let xb = cx - 0.5 * lean;
                    panel(
                        &mut d,
                        name,
                        [
                            [xb, ya, 0.0],
                            [xb, yb, 0.0],
                            [xb + lean, yb, h],
                            [xb + lean, ya, h],
                        ],
                    );
                }
                3 => {
                    // A shelf: a box whose top is a larger horizontal panel, overhanging.
                    let half = 0.25 * cell;
                    boxed(
                        &mut d,
                        format!("{name}-base"),
                        [cx - half, cy - half, 0.0],
                        [cx + half, cy + half, h],
                    );
                    d.boxes
                        .last_mut()
                        .expect("just pushed")
                        .omit
                        .push("+z".into());
                    let r = 0.5 * cell - margin;
                    panel(
                        &mut d,
                        format!("{name}-shelf"),
                        [
                            [cx - r, cy - r, h],
                            [cx + r, cy - r, h],
                            [cx + r, cy + r, h],
                            [cx - r, cy + r, h],
                        ],
                    );
                }
                _ => {
                    // Two boxes stacked, the upper one smaller and off centre.
                    let half = 0.5 * (cell - 2.0 * margin);
                    boxed(
                        &mut d,
                        format!("{name}-low"),
                        [cx - half, cy - half, 0.0],
                        [cx + half, cy + half, h],
                    );
                    let q = 0.5 * half;
                    let (ox, oy) = ((next() - 0.5) * q, (next() - 0.5) * q);
                    boxed(
                        &mut d,
                        format!("{name}-top"),
                        [cx + ox - q, cy + oy - q, h],
                        [cx + ox + q, cy + oy + q, h + 0.25],
                    );
                }
            }
        }
    }
    d.mesh = MeshHints {
        element_size: Some(0.25),
        patch_size: Some(0.8),
    };
    d
}

/// How [`triangulated`] writes each polygon as triangles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Triangulation {
    /// A fan from the first vertex: two triangles per quad (what exporters write).
    Pairs,
    /// A fan from the first vertex over rim points added on every edge not at the hub, at 0.1%,
    /// 50% and 99.9% of its length: slivers of aspect about 1000 at each corner.
    Fans,
    /// Each polygon cut into an `N × N` grid of cells (bilinear over a quad, barycentric over a
    /// triangle), each cell two triangles (one at a triangle's diagonal): `2 N²` triangles per
    /// quad, `N²` per triangle; the same surface at `N²` times the triangles.
    Grid(u32),
}

/// The same scene with every polygon (and every box face, as surfaces named like the box's)
/// written as triangles: the meshing of triangles against the quads they came from.
pub fn triangulated(d: &SceneDescription, how: Triangulation) -> SceneDescription {
    use glam::DVec3;
    let mut out = d.clone();
    out.name = Some(format!(
        "{} as triangles ({})",
        d.name.as_deref().unwrap_or("scene"),
        match how {
            Triangulation::Pairs => "pairs".to_string(),
            Triangulation::Fans => "fans with slivers".to_string(),
            Triangulation::Grid(g) => format!("{g} x {g} grids"),
        }
    ));
    let split = |polygon: &[[f64; 3]]| -> Vec<Vec<[f64; 3]>> {
        let v: Vec<DVec3> = polygon.iter().map(|p| DVec3::from_array(*p)).collect();
        let n = v.len();
        if n < 3 {
            return vec![polygon.to_vec()]; // degenerate: the import drops it with a warning
        }
        if let Triangulation::Grid(g) = how {
            return grid_triangles(&v, g.max(1));
        }
        let mut rim = vec![v[1]];
        for i in 1..n - 1 {
            if how == Triangulation::Fans {
                for t in [0.001, 0.5, 0.999] {
                    rim.push(v[i] + (v[i + 1] - v[i]) * t);
                }
            }
            rim.push(v[i + 1]);
        }
        rim.windows(2)
            .map(|w| vec![v[0].to_array(), w[0].to_array(), w[1].to_array()])
            .collect()
    };
    for s in &mut out.surfaces {
        let polygons = s.all_polygons().iter().flat_map(|p| split(p)).collect();
        *s = SurfaceDesc {
            name: std::mem::take(&mut s.name),
            material: std::mem::take(&mut s.material),
            polygons,
            ..Default::default()
        }
        .indexed();
    }
    for b in std::mem::take(&mut out.boxes) {
        let (lo, hi) = (DVec3::from_array(b.min), DVec3::from_array(b.max));
        for (face, v) in super::description::box_polygons(&b, lo, hi) {
            let quad: Vec<[f64; 3]> = v.iter().map(|p| p.to_array()).collect();
            out.surfaces.push(
                SurfaceDesc {
                    name: format!("{}.{face}", b.name),
                    material: b.material.clone(),
                    polygons: split(&quad),
                    ..Default::default()
                }
                .indexed(),
            );
        }
    }
    out
}

/// `v` (a triangle or a quad; other polygons as a fan of triangles) cut into a `g × g` grid,
/// as triangles counter-clockwise like `v`.
fn grid_triangles(v: &[glam::DVec3], g: u32) -> Vec<Vec<[f64; 3]>> {
    let g = g as usize;
    let t = |i: usize| i as f64 / g as f64;
    let mut out = Vec::new();
    match v.len() {
        4 => {
            let at = |i: usize, j: usize| {
                let (a, b) = (v[0].lerp(v[1], t(i)), v[3].lerp(v[2], t(i)));
                a.lerp(b, t(j)).to_array()
            };
            for j in 0..g {
                for i in 0..g {
                    let (p, q, r, s) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                    out.push(vec![p, q, r]);
                    out.push(vec![p, r, s]);
                }
            }
        }
        3 => {
            // Row j from v[0]: points v0 + (i (v1 - v0) + j (v2 - v0)) / g with i + j <= g.
            let at = |i: usize, j: usize| {
                (v[0] + (v[1] - v[0]) * t(i) + (v[2] - v[0]) * t(j)).to_array()
            };
            for j in 0..g {
                for i in 0..g - j {
                    out.push(vec![at(i, j), at(i + 1, j), at(i, j + 1)]);
                    if i + j + 1 < g {
                        out.push(vec![at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
                    }
                }
            }
        }
        _ => {
            for w in 1..v.len() - 1 {
                out.extend(grid_triangles(&[v[0], v[w], v[w + 1]], g as u32));
            }
        }
    }
    out
}

/// A room of the geometry exported assets are full of (`lrr scene messy`), in a closed
/// 4 × 4 × 2.5 room of quads lit by a ceiling lamp:
/// - a platform whose top is 40 strips of 2 needle triangles each (aspect 80 to 1);
/// - an L-shaped rug, a fan of needles from its inner corner, 1 mm above the floor;
/// - a round table: top and underside as fans of 64 triangles, on a box leg;
/// - a wall panel whose halves are 2 triangles and 4 quads (T-junctions on the shared edge);
/// - two boxes passing through each other, and one sunk 0.1 into the floor;
/// - a quad whose fourth vertex lies 20 m away and off its plane (needles, through the wall);
/// - a zero-area triangle and a duplicated face (dropped with warnings).
pub fn messy() -> SceneDescription {
    let mut d = empty("messy".into());
    d.materials.push(grey("wall", 0.6, 0.0));
    d.materials.push(MaterialDesc {
        name: "wood".into(),
        reflectance: [0.6, 0.45, 0.3],
        radiance: [0.0; 3],
        ..Default::default()
    });
    d.materials.push(grey("lamp", 0.5, 8.0));
    let boxed = |name: &str, material: &str, min: [f64; 3], max: [f64; 3], omit: &[&str]| BoxDesc {
        name: name.into(),
        material: material.into(),
        min,
        max,
        inward: false,
        omit: omit.iter().map(|s| s.to_string()).collect(),
    };
    d.boxes.push(BoxDesc {
        inward: true,
        ..boxed("room", "wall", [0.0; 3], [4.0, 4.0, 2.5], &[])
    });
    d.surfaces.push(SurfaceDesc {
        name: "lamp".into(),
        material: "lamp".into(),
        polygons: vec![vec![
            [1.6, 1.6, 2.45],
            [1.6, 2.4, 2.45],
            [2.4, 2.4, 2.45],
            [2.4, 1.6, 2.45],
        ]],
        ..Default::default()
    });
    // The platform: a box without a top, the top as strips of needle triangles.
    let (x0, x1, y0, y1, h) = (0.2, 2.2, 0.2, 1.2, 0.2);
    d.boxes.push(boxed(
        "platform",
        "wood",
        [x0, y0, 0.0],
        [x1, y1, h],
        &["-z", "+z"],
    ));
    let strips = 40;
    let mut top = Vec::new();
    for i in 0..strips {
        let (a, b) = (
            y0 + (y1 - y0) * i as f64 / strips as f64,
            y0 + (y1 - y0) * (i + 1) as f64 / strips as f64,
        );
        top.push(vec![[x0, a, h], [x1, a, h], [x1, b, h]]);
        top.push(vec![[x0, a, h], [x1, b, h], [x0, b, h]]);
    }
    d.surfaces.push(SurfaceDesc {
        name: "platform-top".into(),
        material: "wood".into(),
        polygons: top,
        ..Default::default()
    });
    // An L-shaped rug on the floor, 1 mm above it: a fan of needles from its inner corner
    // over points every 5 cm along its far edges (concave, no quad in it).
    let hub = [0.9, 2.7];
    let corners = [
        [0.9, 3.0],
        [0.3, 3.0],
        [0.3, 2.4],
        [1.8, 2.4],
        [1.8, 2.7],
        [0.9, 2.7],
    ];
    let mut rim: Vec<[f64; 2]> = vec![corners[0]];
    for w in corners.windows(2) {
        let (a, b) = (w[0], w[1]);
        let steps = (((b[0] - a[0]).hypot(b[1] - a[1]) / 0.05).round() as usize).max(1);
        for k in 1..=steps {
            let t = k as f64 / steps as f64;
            rim.push([a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t]);
        }
    }
    let z = 0.001;
    let mut rug = Vec::new();
    for w in rim.windows(2) {
        let (a, b) = (w[0], w[1]);
        let turn = (a[0] - hub[0]) * (b[1] - hub[1]) - (a[1] - hub[1]) * (b[0] - hub[0]);
        if turn.abs() < 1e-12 {
            continue; // along an edge through the hub
        }
        let (a, b) = if turn > 0.0 { (a, b) } else { (b, a) };
        rug.push(vec![[hub[0], hub[1], z], [a[0], a[1], z], [b[0], b[1], z]]);
    }
    d.surfaces.push(SurfaceDesc {
        name: "rug".into(),
        material: "wood".into(),
        polygons: rug,
        ..Default::default()
    });
    // The round table: fans of 64 triangles, on a leg.
    let (cx, cy, r, z) = (3.0, 3.0, 0.4, 0.7);
    let rim = |k: usize| {
        let a = std::f64::consts::TAU * k as f64 / 64.0;
        [cx + r * a.cos(), cy + r * a.sin()]
    };
    let (mut upper, mut lower) = (Vec::new(), Vec::new());
    for k in 0..64 {
        let (p, q) = (rim(k), rim(k + 1));
        upper.push(vec![[cx, cy, z], [p[0], p[1], z], [q[0], q[1], z]]);
        lower.push(vec![
            [cx, cy, z - 0.03],
            [q[0], q[1], z - 0.03],
            [p[0], p[1], z - 0.03],
        ]);
    }
    d.surfaces.push(SurfaceDesc {
        name: "table-top".into(),
        material: "wood".into(),
        polygons: upper,
        ..Default::default()
    });
    d.surfaces.push(SurfaceDesc {
        name: "table-underside".into(),
        material: "wood".into(),
        polygons: lower,
        ..Default::default()
    });
    d.boxes.push(boxed(
        "table-leg",
        "wood",
        [cx - 0.05, cy - 0.05, 0.0],
        [cx + 0.05, cy + 0.05, z - 0.03],
        &["-z", "+z"],
    ));
    // A panel in front of the +x wall, facing -x: triangles beside quads (T-junctions).
    let xw = 3.95;
    let at = |y: f64, z: f64| [xw, y, z];
    let mut panel = vec![
        vec![at(1.0, 0.5), at(0.5, 0.5), at(0.5, 1.5)],
        vec![at(1.0, 0.5), at(0.5, 1.5), at(1.0, 1.5)],
    ];
    for k in 0..4 {
        let (za, zb) = (0.5 + 0.25 * k as f64, 0.75 + 0.25 * k as f64);
        panel.push(vec![at(1.5, za), at(1.0, za), at(1.0, zb), at(1.5, zb)]);
    }
    d.surfaces.push(SurfaceDesc {
        name: "panel".into(),
        material: "wall".into(),
        polygons: panel,
        ..Default::default()
    });
    // Boxes passing through each other, and one sunk into the floor.
    d.boxes.push(boxed(
        "crate-a",
        "wood",
        [1.0, 2.4, 0.0],
        [1.6, 3.0, 0.6],
        &["-z"],
    ));
    d.boxes.push(boxed(
        "crate-b",
        "wood",
        [1.3, 2.7, 0.2],
        [1.9, 3.3, 0.9],
        &[],
    ));
    d.boxes.push(boxed(
        "sunk",
        "wood",
        [2.6, 0.4, -0.1],
        [3.2, 1.0, 0.3],
        &["-z"],
    ));
    // A quad whose fourth vertex lies 20 m away, off its plane: two needle triangles.
    d.surfaces.push(SurfaceDesc {
        name: "far-quad".into(),
        material: "wood".into(),
        polygons: vec![vec![
            [0.5, 3.2, 1.0],
            [1.0, 3.2, 1.0],
            [1.0, 3.7, 1.0],
            [0.7, 23.7, 1.3],
        ]],
        ..Default::default()
    });
    // Broken input: a zero-area triangle and a face written twice.
    d.surfaces.push(SurfaceDesc {
        name: "junk".into(),
        material: "wall".into(),
        polygons: vec![
            vec![[2.0, 2.0, 1.0], [2.5, 2.0, 1.0], [3.0, 2.0, 1.0]],
            vec![[2.0, 3.5, 1.2], [2.2, 3.5, 1.2], [2.2, 3.7, 1.2]],
            vec![[2.0, 3.5, 1.2], [2.2, 3.5, 1.2], [2.2, 3.7, 1.2]],
        ],
        ..Default::default()
    });
    d.mesh = MeshHints {
        element_size: Some(0.25),
        patch_size: Some(0.8),
    };
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid triangulation keeps the area and the side of every polygon, with `2 g²`
    /// triangles per quad and `g²` per triangle.
    #[test]
    fn grid_triangulation_keeps_area_and_side() {
        use crate::geometry::area_vector;
        use glam::DVec3;
        let quad = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(2.5, 1.0, 0.0),
            DVec3::new(0.0, 1.5, 0.0),
        ];
        let tri = [quad[0], quad[1], quad[2]];
        for g in [1usize, 3, 16] {
            for (v, count) in [(&quad[..], 2 * g * g), (&tri[..], g * g)] {
                let ts = grid_triangles(v, g as u32);
                assert_eq!(ts.len(), count);
                let whole = area_vector(v);
                let mut sum = DVec3::ZERO;
                for t in &ts {
                    let p: Vec<DVec3> = t.iter().map(|x| DVec3::from_array(*x)).collect();
                    let a = area_vector(&p);
                    assert!(a.dot(whole) > 0.0);
                    sum += a;
                }
                assert!((sum - whole).length() < 1e-12 * whole.length(), "{g}");
            }
        }
    }
}
