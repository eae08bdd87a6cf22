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
