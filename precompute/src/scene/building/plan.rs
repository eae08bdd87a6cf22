//! The building's plan as data, in whole centimetres (y up; x east, z north): a 12 × 8 m
//! footprint, two floors of 2.8 m rooms on 20 cm slabs, exterior walls of 25 cm and interior
//! walls of 12 cm, doorways of 90 × 210 cm (a 1.8 m opening from the living room to the kitchen), windows with 90 cm sills, a straight stair of 15
//! steps in the hall under a stairwell with a parapet, furniture blocks, and one or two
//! 60 cm ceiling lamps per room. [`super::solid`] turns it into the boundary faces.

/// What a solid is made of (its faces' materials, [`super::material_of`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Slabs, walls and the parapet: floors (+y), ceilings (−y), the room's wall colour.
    Structure,
    /// The stair: treads are floor, risers and the side the hall's walls.
    Stairs,
    /// A furniture block of this material.
    Furniture(&'static str),
}

/// An axis-aligned box `[min, max)` in centimetres.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cuboid {
    /// Lower corner.
    pub min: [i32; 3],
    /// Upper corner (exclusive).
    pub max: [i32; 3],
}

const fn b(x0: i32, y0: i32, z0: i32, x1: i32, y1: i32, z1: i32) -> Cuboid {
    Cuboid {
        min: [x0, y0, z0],
        max: [x1, y1, z1],
    }
}

/// A room: its air (a box), wall colour and ceiling lamps (x0, z0, x1, z1 on the ceiling).
#[derive(Debug, Clone)]
pub struct Room {
    /// Name: of its node, its wall material (`wall-NAME`) and its light group.
    pub name: &'static str,
    /// The room's air, floor to ceiling.
    pub air: Cuboid,
    /// Wall reflectance.
    pub wall: [f64; 3],
    /// Ceiling lamps as `[x0, z0, x1, z1]`.
    pub lamps: Vec<[i32; 4]>,
}

/// Floor tops: the ground floor at 0, the upper floor at 300 (rooms 280 high).
pub const LEVELS: [i32; 2] = [0, 300];
/// Room height.
pub const HEIGHT: i32 = 280;

/// The rooms, ground floor first.
pub fn rooms() -> Vec<Room> {
    let room = |name, [x0, z0, x1, z1]: [i32; 4], level: usize, wall, lamps: &[[i32; 4]]| Room {
        name,
        air: b(x0, LEVELS[level], z0, x1, LEVELS[level] + HEIGHT, z1),
        wall,
        lamps: lamps.to_vec(),
    };
    vec![
        room(
            "living",
            [25, 25, 494, 775],
            0,
            [0.75, 0.68, 0.55],
            &[[230, 170, 290, 230], [230, 530, 290, 590]],
        ),
        room(
            "kitchen",
            [506, 25, 1175, 394],
            0,
            [0.55, 0.7, 0.5],
            &[[780, 180, 900, 240]],
        ),
        room(
            "hall",
            [506, 406, 844, 775],
            0,
            [0.72, 0.72, 0.72],
            &[[645, 500, 705, 560]],
        ),
        room(
            "study",
            [856, 406, 1175, 775],
            0,
            [0.45, 0.55, 0.75],
            &[[985, 560, 1045, 620]],
        ),
        room(
            "bedroom",
            [25, 25, 494, 344],
            1,
            [0.78, 0.58, 0.58],
            &[[230, 155, 290, 215]],
        ),
        room(
            "bath",
            [25, 356, 494, 775],
            1,
            [0.5, 0.72, 0.75],
            &[[230, 535, 290, 595]],
        ),
        room(
            "studio",
            [506, 25, 1175, 394],
            1,
            [0.78, 0.72, 0.42],
            &[[780, 180, 900, 240]],
        ),
        room(
            "landing",
            [506, 406, 844, 775],
            1,
            [0.7, 0.7, 0.66],
            &[[645, 480, 705, 540]],
        ),
        room(
            "guest",
            [856, 406, 1175, 775],
            1,
            [0.62, 0.56, 0.75],
            &[[985, 560, 1045, 620]],
        ),
    ]
}

/// The solids: structure first (it wins where solids overlap), then the stair, then
/// furniture.
pub fn solids() -> Vec<(Kind, Cuboid)> {
    let mut s: Vec<(Kind, Cuboid)> = Vec::new();
    let mut structure = |c: Cuboid| s.push((Kind::Structure, c));
    // Slabs: ground, between the floors, roof.
    structure(b(0, -20, 0, 1200, 0, 800));
    structure(b(0, 280, 0, 1200, 300, 800));
    structure(b(0, 580, 0, 1200, 600, 800));
    // Exterior walls, full height.
    structure(b(0, -20, 0, 25, 600, 800));
    structure(b(1175, -20, 0, 1200, 600, 800));
    structure(b(0, -20, 0, 1200, 600, 25));
    structure(b(0, -20, 775, 1200, 600, 800));
    // Interior walls of both floors: west | east, kitchen | hall, hall | study.
    for y in LEVELS {
        structure(b(494, y, 25, 506, y + HEIGHT, 775));
        structure(b(506, y, 394, 1175, y + HEIGHT, 406));
        structure(b(844, y, 406, 856, y + HEIGHT, 775));
    }
    // Upstairs, the bedroom | bath wall, and the parapet along the stairwell.
    structure(b(25, 300, 344, 494, 580, 356));
    structure(b(546, 300, 665, 844, 400, 675));
    // The stair along the hall's north wall, rising westward in 15 steps of 20 × 21 cm; the
    // top step reaches the west wall and the upper floor.
    for i in 0..15 {
        let x0 = if i == 14 { 506 } else { 840 - 21 * (i + 1) };
        s.push((Kind::Stairs, b(x0, 0, 675, 840 - 21 * i, 20 * (i + 1), 775)));
    }
    let mut furniture = |m: &'static str, c: Cuboid| s.push((Kind::Furniture(m), c));
    // Ground floor: sofa, coffee table and shelf; counter and table; desk and bookcase.
    furniture("fabric", b(60, 0, 300, 150, 80, 520));
    furniture("wood", b(220, 0, 360, 310, 40, 460));
    furniture("wood", b(360, 0, 25, 480, 200, 65));
    furniture("white", b(1115, 0, 25, 1175, 90, 260));
    furniture("wood", b(750, 0, 150, 900, 75, 250));
    furniture("wood", b(900, 0, 705, 1060, 75, 775));
    furniture("wood", b(1135, 0, 420, 1175, 220, 490));
    // Upper floor: bed and wardrobe; tub and cabinet; desk and sofa; bed and chest.
    furniture("fabric", b(100, 300, 25, 260, 350, 225));
    furniture("wood", b(434, 300, 60, 494, 500, 200));
    furniture("white", b(25, 300, 580, 100, 355, 775));
    furniture("white", b(444, 300, 600, 494, 385, 700));
    furniture("wood", b(1095, 300, 100, 1175, 375, 300));
    furniture("fabric", b(506, 300, 60, 586, 380, 260));
    furniture("fabric", b(1015, 300, 600, 1175, 350, 775));
    furniture("wood", b(870, 300, 705, 950, 380, 775));
    s
}

/// Openings carved out of the structure, each with the room whose wall colour its reveals
/// take: doorways, windows, an outside door and the stairwell.
pub fn openings() -> Vec<(&'static str, Cuboid)> {
    let door_x = |room, x: i32, z0: i32, y: i32| (room, b(x, y, z0, x + 12, y + 210, z0 + 90));
    let door_z = |room, z: i32, x0: i32, y: i32| (room, b(x0, y, z, x0 + 90, y + 210, z + 12));
    let window = |room, axis: usize, side: i32, from: i32, to: i32, y: i32| {
        let (lo, hi) = (side, side + 25);
        let c = match axis {
            0 => b(lo, y + 90, from, hi, y + 210, to),
            _ => b(from, y + 90, lo, to, y + 210, hi),
        };
        (room, c)
    };
    vec![
        // Ground floor: a 1.8 m opening living | kitchen; doorways living | hall, kitchen |
        // hall, hall | study.
        ("living", b(494, 0, 120, 506, 210, 300)),
        door_x("living", 494, 450, 0),
        door_z("hall", 394, 650, 0),
        door_x("hall", 844, 450, 0),
        // Upper floor: bedroom | studio, bath | landing, landing | studio, landing | guest,
        // bedroom | bath.
        door_x("bedroom", 494, 150, 300),
        door_x("bath", 494, 450, 300),
        door_z("landing", 394, 650, 300),
        door_x("landing", 844, 450, 300),
        door_z("bedroom", 344, 300, 300),
        // The kitchen's outside door (east).
        ("kitchen", b(1175, 0, 280, 1200, 210, 370)),
        // Windows: x = 0 and x = 1175 walls (axis 0), z = 0 and z = 775 walls (axis 2).
        window("living", 0, 0, 200, 360, 0),
        window("living", 0, 0, 500, 660, 0),
        window("living", 2, 0, 150, 330, 0),
        window("kitchen", 2, 0, 700, 860, 0),
        window("kitchen", 2, 0, 950, 1100, 0),
        window("kitchen", 0, 1175, 100, 240, 0),
        window("study", 2, 775, 950, 1100, 0),
        window("study", 0, 1175, 500, 650, 0),
        window("bedroom", 2, 0, 150, 330, 300),
        window("bedroom", 0, 0, 100, 260, 300),
        window("bath", 0, 0, 550, 650, 300),
        window("landing", 2, 775, 600, 780, 300),
        window("studio", 2, 0, 600, 800, 300),
        window("studio", 2, 0, 900, 1100, 300),
        window("studio", 0, 1175, 120, 280, 300),
        window("guest", 2, 775, 950, 1100, 300),
        window("guest", 0, 1175, 500, 650, 300),
        // The stairwell through the slab between the floors, above steps 0 to 13.
        ("hall", b(546, 280, 675, 844, 300, 775)),
    ]
}
