//! Scenes for the ray tracer (`lrr scene cornell-glass | box-sphere | uneven | dense`): glass
//! and a mirror, a series of growing triangle counts, objects spread very unevenly (the
//! uniform grid's weak case) and a dense mesh of more than 10⁵ triangles. Each has a default
//! camera, so `lrr render` has one.

use super::description::{
    BakeDesc, BoxDesc, CameraDesc, MaterialDesc, MeshHints, PointLightDesc, SceneDescription,
    SurfaceDesc,
};
use super::procedural;
use crate::error::{Error, Result};

/// The shipped Cornell box description (scenes/cornell-box/cornell-box.toml).
const CORNELL: &str = include_str!("../../../scenes/cornell-box/cornell-box.toml");

/// Most sphere triangles `box-sphere --triangles` makes (a description of about 200 MB).
pub const MAX_SPHERE_TRIANGLES: usize = 2_000_000;

/// The sphere triangles of the `dense` scene.
pub const DENSE_TRIANGLES: usize = 100_000;

fn material(name: &str, rho: f64) -> MaterialDesc {
    MaterialDesc {
        name: name.into(),
        reflectance: [rho; 3],
        ..Default::default()
    }
}

fn camera(eye: [f64; 3], target: [f64; 3], fov_y_deg: f64) -> CameraDesc {
    CameraDesc {
        name: "default".into(),
        eye,
        target,
        up: [0.0, 1.0, 0.0],
        fov_y_deg,
    }
}

/// The Cornell box with its short block made of glass (transmission 0.95, index 1.5, Fresnel
/// reflection), a mirror of reflectance 0.9 on the green wall, the classic camera, and a point
/// light at the lamp that follows its light group (intensity `Ke · area`, for highlights).
pub fn cornell_glass() -> SceneDescription {
    let mut d = SceneDescription::parse(CORNELL, "scenes/cornell-box/cornell-box.toml")
        .expect("the shipped Cornell box description parses");
    d.name = Some("cornell-glass".into());
    d.materials.push(MaterialDesc {
        specular: Some([0.5; 3]),
        shininess: Some(200.0),
        mirror: Some([1.0; 3]),
        transmission: Some([0.95; 3]),
        ior: Some(1.5),
        ..material("glass", 0.05)
    });
    d.materials.push(MaterialDesc {
        specular: Some([0.3; 3]),
        shininess: Some(500.0),
        mirror: Some([0.9; 3]),
        ..material("mirror", 0.05)
    });
    for s in d.surfaces.iter_mut().filter(|s| s.name == "short-block") {
        s.material = "glass".into();
    }
    // 1 mm in front of the green wall (x = 0), facing +x.
    d.surfaces.push(SurfaceDesc {
        name: "mirror".into(),
        material: "mirror".into(),
        polygons: vec![vec![
            [1.0, 100.0, 150.0],
            [1.0, 450.0, 150.0],
            [1.0, 450.0, 450.0],
            [1.0, 100.0, 450.0],
        ]],
        ..Default::default()
    });
    // The camera is the bundled box's own ('front', the Cornell data page's).
    let area = 130.0 * 105.0;
    d.point_lights.push(PointLightDesc {
        name: "lamp".into(),
        position: [278.0, 540.0, 279.5],
        intensity: Some([17.0 * area, 12.0 * area, 4.0 * area]),
        colour: None,
        power: None,
        group: Some("light".into()),
    });
    d
}

/// A closed unit room (y up) lit by a square light in the ceiling, like `dense_sphere`'s.
fn lit_room(d: &mut SceneDescription) {
    d.materials.push(material("wall", 0.7));
    d.materials.push(MaterialDesc {
        radiance: [10.0; 3],
        ..material("light", 0.0)
    });
    procedural::lit_room_surfaces(d);
}

/// Frequency `m` of the geodesic sphere with about `triangles` triangles: `20 m²` of them.
pub fn sphere_frequency(triangles: usize) -> usize {
    ((triangles as f64 / 20.0).sqrt().round() as usize).max(1)
}

/// Triangles of a geodesic sphere of frequency `m`: every face of an icosahedron cut into `m²`
/// triangles, vertices pushed onto the sphere (well shaped, no two coplanar), counter-clockwise
/// seen from outside: `20 m²` of them.
fn geodesic_sphere(m: usize, centre: [f64; 3], radius: f64) -> Vec<Vec<[f64; 3]>> {
    use glam::DVec3;
    let faces = super::procedural::icosphere(0, [0.0; 3], 1.0);
    let c = DVec3::from_array(centre);
    let mut tris = Vec::with_capacity(20 * m * m);
    for f in faces {
        let [a, b, e] = [f[0], f[1], f[2]].map(DVec3::from_array);
        let point = |i: usize, j: usize| {
            let p = a + (b - a) * (i as f64 / m as f64) + (e - a) * (j as f64 / m as f64);
            (c + p.normalize() * radius).to_array()
        };
        for i in 0..m {
            for j in 0..m - i {
                tris.push(vec![point(i, j), point(i + 1, j), point(i, j + 1)]);
                if i + j + 1 < m {
                    tris.push(vec![point(i + 1, j), point(i + 1, j + 1), point(i, j + 1)]);
                }
            }
        }
    }
    tris
}

/// The "box and sphere" series: a block and a geodesic sphere of about `triangles` triangles in the
/// lit unit room, camera inside the room. The sphere's triangles are smaller than the elements
/// for large counts, so its patches are built by clustering.
pub fn box_sphere(triangles: usize) -> Result<SceneDescription> {
    if triangles == 0 || triangles > MAX_SPHERE_TRIANGLES {
        return Err(Error::Settings(format!(
            "--triangles {triangles}: use 1 to {MAX_SPHERE_TRIANGLES} sphere triangles"
        )));
    }
    let m = sphere_frequency(triangles);
    let count = 20 * m * m;
    let mut d = SceneDescription {
        name: Some(format!("box-sphere triangles={count}")),
        ..Default::default()
    };
    lit_room(&mut d);
    d.materials.push(MaterialDesc {
        reflectance: [0.75, 0.45, 0.3],
        specular: Some([0.4; 3]),
        shininess: Some(60.0),
        ..material("clay", 0.0)
    });
    d.boxes.push(BoxDesc {
        name: "block".into(),
        material: "wall".into(),
        min: [0.12, 0.0, 0.45],
        max: [0.42, 0.45, 0.75],
        inward: false,
        omit: vec!["-y".into()],
    });
    d.surfaces.push(
        SurfaceDesc {
            name: "sphere".into(),
            material: "clay".into(),
            polygons: geodesic_sphere(m, [0.66, 0.23, 0.42], 0.2),
            ..Default::default()
        }
        .indexed(),
    );
    d.mesh = MeshHints {
        element_size: Some(0.125),
        patch_size: Some(0.25),
    };
    d.cameras
        .push(camera([0.5, 0.5, 0.98], [0.5, 0.3, 0.0], 60.0));
    Ok(d)
}

/// The dense scene: `box_sphere` with [`DENSE_TRIANGLES`] sphere triangles (100 820), and bake
/// settings that bake it in minutes: 2 samples per pair and patches of 0.35 (README, Scenes).
pub fn dense() -> SceneDescription {
    let mut d = box_sphere(DENSE_TRIANGLES).expect("in range");
    d.name = Some("dense".into());
    d.bake = BakeDesc {
        samples: Some(2),
        patch_size: Some(0.35),
        ..Default::default()
    };
    d.mesh.patch_size = None;
    d
}

/// Objects spread very unevenly, the uniform grid's weak case ("a teapot in a stadium"): a
/// 100 × 20 × 100 hall lit from its ceiling, three large blocks far apart, and a cluster of
/// 256 small boxes (2 to 10 cm) inside one 1 × 1 square of the floor, all one surface. The
/// camera looks at the cluster.
pub fn uneven() -> SceneDescription {
    let mut d = SceneDescription {
        name: Some("uneven".into()),
        ..Default::default()
    };
    d.materials.push(material("wall", 0.6));
    d.materials.push(MaterialDesc {
        reflectance: [0.7, 0.5, 0.3],
        ..material("clutter", 0.0)
    });
    d.materials.push(MaterialDesc {
        radiance: [5.0; 3],
        ..material("lamp", 0.5)
    });
    let (side, height) = (100.0, 20.0);
    d.boxes.push(BoxDesc {
        name: "hall".into(),
        material: "wall".into(),
        min: [0.0; 3],
        max: [side, height, side],
        inward: true,
        omit: Vec::new(),
    });
    let y = height - 0.5;
    d.surfaces.push(SurfaceDesc {
        name: "lamp".into(),
        material: "lamp".into(),
        polygons: vec![vec![
            [40.0, y, 40.0],
            [60.0, y, 40.0],
            [60.0, y, 60.0],
            [40.0, y, 60.0],
        ]],
        ..Default::default()
    });
    for (i, (x, z)) in [(80.0, 15.0), (15.0, 80.0), (75.0, 75.0)]
        .into_iter()
        .enumerate()
    {
        d.boxes.push(BoxDesc {
            name: format!("block-{i}"),
            material: "clutter".into(),
            min: [x, 0.0, z],
            max: [x + 10.0, 8.0 + 2.0 * i as f64, z + 10.0],
            inward: false,
            omit: vec!["-y".into()],
        });
    }
    // 16 × 16 boxes in [10, 11]², sizes and heights from a fixed hash sequence.
    let mut state = 0x5EED_u64;
    let mut next = || {
        state = crate::geometry::hash::mix(state);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut polygons = Vec::new();
    for i in 0..16 {
        for j in 0..16 {
            let size = 0.02 + 0.03 * next();
            let h = 0.02 + 0.08 * next();
            let (x0, z0) = (
                10.0 + i as f64 / 16.0 + 0.005,
                10.0 + j as f64 / 16.0 + 0.005,
            );
            polygons.extend(block_faces([x0, 0.0, z0], [x0 + size, h, z0 + size]));
        }
    }
    d.surfaces.push(SurfaceDesc {
        name: "cluster".into(),
        material: "clutter".into(),
        polygons,
        ..Default::default()
    });
    d.cameras
        .push(camera([10.5, 0.6, 12.0], [10.5, 0.0, 10.5], 45.0));
    d
}

/// The five faces of a block standing on the floor (all but the bottom), outward.
fn block_faces(lo: [f64; 3], hi: [f64; 3]) -> Vec<Vec<[f64; 3]>> {
    let [x0, y0, z0] = lo;
    let [x1, y1, z1] = hi;
    vec![
        vec![[x0, y1, z0], [x0, y1, z1], [x1, y1, z1], [x1, y1, z0]], // +y
        vec![[x0, y0, z0], [x0, y0, z1], [x0, y1, z1], [x0, y1, z0]], // -x
        vec![[x1, y0, z0], [x1, y1, z0], [x1, y1, z1], [x1, y0, z1]], // +x
        vec![[x0, y0, z0], [x0, y1, z0], [x1, y1, z0], [x1, y0, z0]], // -z
        vec![[x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]], // +z
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn outward(polygon: &[[f64; 3]], centre: [f64; 3]) -> bool {
        let p = polygon
            .iter()
            .map(|v| glam::DVec3::from_array(*v))
            .collect::<Vec<_>>();
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        let mid = p.iter().copied().sum::<glam::DVec3>() / p.len() as f64;
        n.dot(mid - glam::DVec3::from_array(centre)) > 0.0
    }

    #[test]
    fn spheres_and_blocks_face_outward() {
        for m in [1, 2, 7] {
            let tris = geodesic_sphere(m, [1.0, 2.0, 3.0], 0.5);
            assert_eq!(tris.len(), 20 * m * m);
            assert!(tris.iter().all(|t| outward(t, [1.0, 2.0, 3.0])));
        }
        let faces = block_faces([0.0; 3], [1.0, 2.0, 1.0]);
        assert!(faces.iter().all(|f| outward(f, [0.5, 1.0, 0.5])));
        assert_eq!(sphere_frequency(DENSE_TRIANGLES), 71);
    }

    #[test]
    fn every_scene_builds_with_a_camera() {
        let base = Path::new(".");
        for (d, faces) in [
            (cornell_glass(), 20),
            (box_sphere(1000).unwrap(), 980),
            (uneven(), 1280),
            (box_sphere(20_000).unwrap(), 20_000),
        ] {
            let name = d.name.clone().unwrap();
            let scene = d.build(&name, base).unwrap();
            assert_eq!(scene.cameras.len(), 1, "{name}");
            assert!(
                scene.faces.len() >= faces,
                "{name}: {} faces",
                scene.faces.len()
            );
            assert!(
                scene.warnings.iter().all(|w| !w.contains("dropped")),
                "{name}: {:?}",
                scene.warnings
            );
            // The TOML reads back to the same description.
            let text = d.to_toml();
            assert_eq!(SceneDescription::parse(&text, &name).unwrap(), d, "{name}");
        }
        let glass = cornell_glass().build("cornell-glass", base).unwrap();
        let m = glass.materials.iter().find(|m| m.name == "glass").unwrap();
        assert_eq!((m.optics.transmission, m.optics.ior), ([0.95; 3], 1.5));
        assert_eq!(glass.point_lights[0].group.as_deref(), Some("light"));
        assert!(box_sphere(0).is_err() && box_sphere(MAX_SPHERE_TRIANGLES + 1).is_err());
    }
}
