//! Scenes the project generates: the furnace cube and the analytic form-factor pairs of
//! DESIGN.md §4, as scene descriptions (`lrr scene …` writes them as TOML).

use super::description::{BoxDesc, MaterialDesc, MeshHints, SceneDescription, SurfaceDesc};

fn grey(name: &str, rho: f64, radiance: f64) -> MaterialDesc {
    MaterialDesc {
        name: name.into(),
        reflectance: [rho; 3],
        radiance: [radiance; 3],
    }
}

fn empty(name: String) -> SceneDescription {
    SceneDescription {
        name: Some(name),
        scale: 1.0,
        mesh: MeshHints::default(),
        materials: Vec::new(),
        surfaces: Vec::new(),
        boxes: Vec::new(),
        includes: Vec::new(),
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

/// A dense mesh for the clustering path: an icosphere of `20·4^subdivisions` small triangles
/// (radius 0.25, floating at the centre of a closed unit room, y up) lit by a square light in
/// the ceiling. Its triangles are smaller than the elements and patches, so 2MF and 2MSC build
/// its patches by clustering ([`crate::mesh::cluster`]).
pub fn dense_sphere(subdivisions: u32) -> SceneDescription {
    let mut d = empty(format!("dense sphere subdivisions={subdivisions}"));
    d.materials.push(grey("wall", 0.7, 0.0));
    d.materials.push(MaterialDesc {
        name: "clay".into(),
        reflectance: [0.75, 0.45, 0.3],
        radiance: [0.0; 3],
    });
    d.materials.push(grey("light", 0.0, 10.0));
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
    });
    d.surfaces.push(SurfaceDesc {
        name: "light".into(),
        material: "light".into(),
        polygons: vec![quad(0.4, 0.6, 0.4, 0.6)],
    });
    let centre = [0.5, 0.4, 0.5];
    d.surfaces.push(SurfaceDesc {
        name: "sphere".into(),
        material: "clay".into(),
        polygons: icosphere(subdivisions.min(MAX_SPHERE_SUBDIVISIONS), centre, 0.25),
    });
    d.mesh = MeshHints {
        element_size: Some(0.125),
        patch_size: Some(0.25),
    };
    d
}

/// Triangles of an icosahedron subdivided `levels` times (edges halved, vertices pushed onto
/// the sphere), counter-clockwise seen from outside.
fn icosphere(levels: u32, centre: [f64; 3], radius: f64) -> Vec<Vec<[f64; 3]>> {
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
