//! `lrr scene building`: a generated two-floor house of nine rooms (the papers' patio-sized
//! scene: about 24 000 elements and 1 400 patches at its `[bake]` sizes), written as three
//! files: the geometry as glTF 2.0 (`.glb`, a node per room and per ceiling lamp), a scene
//! description that includes it with a light group per room, cameras and the `[bake]` sizes,
//! and an animation of the rooms' lights for `lrr relight`.
//!
//! [`plan`] holds the house as boxes in centimetres; [`solid`] finds the faces between solid
//! and room air (walls of real thickness, doorways, windows, a stair under a stairwell,
//! furniture; nothing outside is kept); this file names and colours them.

pub mod plan;
mod solid;

use std::collections::BTreeMap;

use super::description::{BakeDesc, CameraDesc, IncludeDesc, LightGroupDesc, SceneDescription};
use super::glb::{self, GlbMaterial, GlbNode};
use crate::error::Result;
use plan::{Kind, Room};
use solid::{Face, Grid, Rect};

/// Element size of the `[bake]` table, metres.
pub const ELEMENT_SIZE: f64 = 0.275;
/// Patch size of the `[bake]` table, metres.
pub const PATCH_SIZE: f64 = 1.55;

/// The three files of the scene.
#[derive(Debug, Clone)]
pub struct Building {
    /// The geometry (`.glb`).
    pub glb: Vec<u8>,
    /// The scene description, including the geometry by the name it was given.
    pub description: SceneDescription,
    /// The animation file of `lrr relight` (TOML text).
    pub animation: String,
}

/// Materials in file order: floor, ceiling, a wall colour per room, furniture, lamp.
fn materials(rooms: &[Room]) -> Vec<GlbMaterial> {
    let m = |name: &str, reflectance: [f64; 3]| GlbMaterial {
        name: name.into(),
        reflectance,
        radiance: [0.0; 3],
    };
    let mut out = vec![
        m("floor", [0.45, 0.32, 0.2]),
        m("ceiling", [0.8, 0.8, 0.78]),
    ];
    out.extend(rooms.iter().map(|r| m(&format!("wall-{}", r.name), r.wall)));
    out.push(m("wood", [0.5, 0.34, 0.2]));
    out.push(m("fabric", [0.3, 0.36, 0.55]));
    out.push(m("white", [0.75, 0.75, 0.75]));
    out.push(GlbMaterial {
        radiance: [6.0, 5.4, 4.5],
        ..m("lamp", [0.8, 0.8, 0.8])
    });
    out
}

/// A face's (node, material): lamps on their room's ceiling are nodes of their own, after the
/// rooms; everything else belongs to the room it faces.
fn label(
    face: Face,
    centre: [i64; 3],
    rooms: &[Room],
    materials: &[GlbMaterial],
) -> (usize, usize) {
    let index = |name: &str| {
        materials
            .iter()
            .position(|m| m.name == name)
            .expect("a material of the list")
    };
    let room = &rooms[face.room];
    let (up, down) = (
        face.axis == 1 && face.positive,
        face.axis == 1 && !face.positive,
    );
    let material = match face.kind {
        Kind::Structure if down => {
            let first = rooms[..face.room]
                .iter()
                .map(|r| r.lamps.len())
                .sum::<usize>();
            let on_ceiling = centre[1] == 2 * i64::from(room.air.max[1]);
            let lamp = room.lamps.iter().position(|l| {
                2 * i64::from(l[0]) < centre[0]
                    && centre[0] < 2 * i64::from(l[2])
                    && 2 * i64::from(l[1]) < centre[2]
                    && centre[2] < 2 * i64::from(l[3])
            });
            match lamp {
                Some(i) if on_ceiling => return (rooms.len() + first + i, index("lamp")),
                _ => index("ceiling"),
            }
        }
        Kind::Structure | Kind::Stairs if up => index("floor"),
        Kind::Structure | Kind::Stairs => 2 + face.room,
        Kind::Furniture(m) => index(m),
    };
    (face.room, material)
}

/// A rectangle's corners in metres, counter-clockwise around its normal.
fn polygon<L>(r: &Rect<L>) -> Vec<[f64; 3]> {
    let (u, v) = ((r.axis + 1) % 3, (r.axis + 2) % 3);
    let corner = |cu: i32, cv: i32| {
        let mut p = [f64::from(r.min[r.axis]) / 100.0; 3];
        (p[u], p[v]) = (f64::from(cu) / 100.0, f64::from(cv) / 100.0);
        p
    };
    let mut p = vec![
        corner(r.min[u], r.min[v]),
        corner(r.max[u], r.min[v]),
        corner(r.max[u], r.max[v]),
        corner(r.min[u], r.max[v]),
    ];
    if !r.positive {
        p.reverse();
    }
    p
}

/// The node names: the rooms, then their lamps (`ROOM.lamp`, or `ROOM.lamp.1`, … for several).
fn node_names(rooms: &[Room]) -> Vec<String> {
    let mut names: Vec<String> = rooms.iter().map(|r| r.name.to_string()).collect();
    for r in rooms {
        for i in 0..r.lamps.len() {
            names.push(match r.lamps.len() {
                1 => format!("{}.lamp", r.name),
                _ => format!("{}.lamp.{}", r.name, i + 1),
            });
        }
    }
    names
}

/// The house's nodes and materials.
pub fn geometry() -> (Vec<GlbNode>, Vec<GlbMaterial>) {
    let rooms = plan::rooms();
    let materials = materials(&rooms);
    let room_of = |name: &str| rooms.iter().position(|r| r.name == name).expect("a room");
    let openings: Vec<_> = plan::openings()
        .into_iter()
        .map(|(room, c)| (room_of(room), c))
        .collect();
    let air: Vec<_> = rooms.iter().map(|r| r.air).collect();
    let marks: Vec<_> = rooms
        .iter()
        .flat_map(|r| {
            let y = r.air.max[1];
            r.lamps.iter().map(move |l| plan::Cuboid {
                min: [l[0], y, l[1]],
                max: [l[2], y, l[3]],
            })
        })
        .collect();
    let grid = Grid::new(&plan::solids(), &openings, &air, &marks);
    let rects = grid.rectangles(|f, c| label(f, c, &rooms, &materials));
    let mut by: BTreeMap<(usize, usize), Vec<Vec<[f64; 3]>>> = BTreeMap::new();
    for r in &rects {
        by.entry(r.label).or_default().push(polygon(r));
    }
    let mut nodes: Vec<GlbNode> = node_names(&rooms)
        .into_iter()
        .map(|name| GlbNode {
            name,
            primitives: Vec::new(),
        })
        .collect();
    for ((node, material), polygons) in by {
        nodes[node].primitives.push((material, polygons));
    }
    (nodes, materials)
}

/// The scene, its geometry to be saved as `glb_name` beside the description.
pub fn building(glb_name: &str) -> Result<Building> {
    let (nodes, materials) = geometry();
    let glb = glb::write(&nodes, &materials, "lrr scene building")?;
    Ok(Building {
        glb,
        description: description(glb_name),
        animation: animation(),
    })
}

/// The description: the include, a light group per room, cameras, `[bake]`.
fn description(glb_name: &str) -> SceneDescription {
    let rooms = plan::rooms();
    let names = node_names(&rooms);
    let light_groups = rooms
        .iter()
        .map(|r| LightGroupDesc {
            name: r.name.into(),
            materials: Vec::new(),
            surfaces: names
                .iter()
                .filter(|n| n.starts_with(&format!("{}.lamp", r.name)))
                .cloned()
                .collect(),
        })
        .collect();
    let camera = |name: &str, eye, target, fov_y_deg| CameraDesc {
        name: name.into(),
        eye,
        target,
        up: [0.0, 1.0, 0.0],
        fov_y_deg,
    };
    SceneDescription {
        name: Some("building".into()),
        includes: vec![IncludeDesc {
            obj: None,
            gltf: Some(glb_name.into()),
        }],
        light_groups,
        cameras: vec![
            camera("living", [0.6, 1.5, 7.4], [6.0, 1.1, 2.2], 70.0),
            camera("hall", [8.2, 1.6, 4.5], [5.6, 2.0, 7.2], 75.0),
            camera("landing", [8.2, 4.6, 4.5], [5.2, 3.6, 7.4], 75.0),
        ],
        bake: BakeDesc {
            element_size: Some(ELEMENT_SIZE),
            patch_size: Some(PATCH_SIZE),
            ..BakeDesc::default()
        },
        ..SceneDescription::default()
    }
}

/// Keys of one group: (time, intensity, colour).
type Keys = &'static [(f64, f64, [f64; 3])];

/// The animation: 8 s at 12 frames/s; lights switch on and off, dim and change colour.
fn animation() -> String {
    const WARM: [f64; 3] = [1.0, 1.0, 1.0];
    let tracks: [(&str, Keys); 9] = [
        (
            "living",
            &[(0.0, 1.0, WARM), (3.0, 0.25, WARM), (6.0, 1.0, WARM)],
        ),
        (
            "kitchen",
            &[
                (1.9, 1.0, WARM),
                (2.0, 0.0, WARM),
                (4.9, 0.0, WARM),
                (5.0, 1.2, [0.55, 0.75, 1.0]),
            ],
        ),
        ("hall", &[(2.0, 1.0, WARM), (4.0, 1.0, [1.0, 0.45, 0.15])]),
        ("study", &[(0.9, 0.0, WARM), (1.0, 1.5, WARM)]),
        ("bedroom", &[(5.9, 0.0, WARM), (6.0, 1.0, [1.0, 0.6, 0.7])]),
        ("bath", &[(0.0, 0.0, WARM)]),
        ("studio", &[(0.0, 1.0, WARM), (8.0, 0.3, [0.6, 1.0, 0.6])]),
        ("landing", &[(0.0, 1.0, WARM)]),
        ("guest", &[(0.0, 0.0, WARM), (8.0, 1.0, [1.0, 0.85, 0.5])]),
    ];
    let mut text = String::from(
        "# The lights of scenes/building/building.toml over 8 s, for `lrr relight` (written by\n\
         # `lrr scene building`): the living room dims and comes back, the kitchen switches\n\
         # off and on again in blue, the hall turns orange, the study and the bedroom switch\n\
         # on, the studio fades to green, the guest room fades in; bath off, landing on;\n\
         # a torch is carried from the living room through the kitchen and hall to the study.\n\
         fps = 12.0\nduration = 8.0\n",
    );
    for (name, keys) in tracks {
        text += &format!("\n[[group]]\nname = \"{name}\"\nkeys = [\n");
        for (time, intensity, colour) in keys {
            let [r, g, b] = colour;
            text += &format!(
                "  {{ time = {time:?}, intensity = {intensity:?}, colour = [{r:?}, {g:?}, {b:?}] }},\n"
            );
        }
        text += "]\n";
    }
    // A torch carried at hand height (1.2 m) from the living room through the opening into
    // the kitchen, through its door into the hall and on into the study: a light that is not
    // a surface, lit every frame by the runtime's direct pass (README "Lights").
    const TORCH: [(f64, [f64; 3]); 7] = [
        (0.0, [2.0, 1.2, 4.0]),
        (2.0, [4.2, 1.2, 2.1]),
        (3.0, [5.5, 1.2, 2.1]),
        (4.5, [6.95, 1.2, 3.0]),
        (5.5, [6.95, 1.2, 5.0]),
        (6.5, [8.0, 1.2, 4.95]),
        (8.0, [10.0, 1.2, 6.0]),
    ];
    text += "\n# The torch: a point light (W/sr) carried along the ground floor.\n[[light]]\n\
             name = \"torch\"\nkind = \"point\"\nkeys = [\n";
    for (time, [x, y, z]) in TORCH {
        text += &format!(
            "  {{ time = {time:?}, position = [{x:?}, {y:?}, {z:?}], intensity = [30.0, 25.0, 17.0] }},\n"
        );
    }
    text += "]\n";
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_room_has_its_nodes_and_the_lamps_light_their_ceilings() {
        let (nodes, materials) = geometry();
        let names: Vec<&str> = nodes.iter().map(|n| n.name.as_str()).collect();
        assert_eq!(names.len(), 9 + 10);
        assert!(names.contains(&"living.lamp.2") && names.contains(&"guest.lamp"));
        let area = |polygons: &[Vec<[f64; 3]>]| -> f64 {
            polygons
                .iter()
                .map(|p| {
                    let d = |i: usize| [0, 1, 2].map(|a| p[i][a] - p[0][a]);
                    let (a, b) = (d(1), d(3));
                    let c = [
                        a[1] * b[2] - a[2] * b[1],
                        a[2] * b[0] - a[0] * b[2],
                        a[0] * b[1] - a[1] * b[0],
                    ];
                    (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt()
                })
                .sum()
        };
        for n in &nodes {
            assert!(!n.primitives.is_empty(), "{} has no faces", n.name);
            if n.name.contains(".lamp") {
                // One 60 × 60 cm lamp, or the kitchen's and studio's 120 × 60.
                assert_eq!(n.primitives.len(), 1);
                let (m, polygons) = &n.primitives[0];
                assert_eq!(materials[*m].name, "lamp");
                let a = area(polygons);
                let want = if n.name.starts_with("kitchen") || n.name.starts_with("studio") {
                    0.72
                } else {
                    0.36
                };
                assert!((a - want).abs() < 1e-9, "{}: {a}", n.name);
            } else {
                // A room's floor, ceiling and own wall colour.
                let used: Vec<&str> = n
                    .primitives
                    .iter()
                    .map(|(m, _)| materials[*m].name.as_str())
                    .collect();
                for want in ["floor", "ceiling", &format!("wall-{}", n.name)] {
                    assert!(used.contains(&want), "{}: {used:?}", n.name);
                }
            }
        }
    }
}
