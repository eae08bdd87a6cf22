//! A small file whose elements are drawn through display faces (section FACES, format 1.4), for
//! the tests of every reader of display geometry: what is drawn, traced, smoothed and exported
//! must follow the faces, not GEOMETRY.
//!
//! The strip `[0, 2] × [0, 1]` in `z = 0`, facing `+z`, is two unit cells, each cut along its
//! diagonal `y - y0 = x - x0` into a lower triangle (below the diagonal) and an upper one. Element
//! 0 (file position 0, original id 1) is drawn as the two lower triangles, element 1 (file
//! position 1, original id 0) as the two upper ones, faces interleaved:
//!
//! | face | triangle | element (file position) |
//! |-----:|----------|------------------------:|
//! | 0 | `(0,0) (1,0) (1,1)` | 0 |
//! | 1 | `(0,0) (1,1) (0,1)` | 1 |
//! | 2 | `(1,0) (2,0) (2,1)` | 0 |
//! | 3 | `(1,0) (2,1) (1,1)` | 1 |
//!
//! GEOMETRY holds planar proxies that do *not* cover the same points: element 0 the quad
//! `[0, 2] × [0, 0.5]`, element 1 the quad `[0, 2] × [0.5, 1]`; a reader that draws GEOMETRY, or
//! takes a face for its element, gets another answer at most points. One patch, `F_k = 0`, so
//! the radiosity is the emission: element 0 emits [`EMISSION`]`[0]`, element 1 `[1]`. SMOOTH on
//! the faces' corners (a corner's value is the mean of the elements with a face there), a BVH
//! over the faces' 4 triangles, one diffuse material, a camera `"top"` looking down at the strip.

use lrr_formats::{
    Camera, Display, Faces, Geometry, LightmapAtlas, LightmapSource, LightmapUv, Material,
    Materials, OperatorData, OperatorFile, Precision, Smooth, StoredMatrix,
};

/// The emitted exitance of elements 0 and 1 (file positions).
pub const EMISSION: [[f32; 3]; 2] = [[1.0, 0.5, 0.25], [0.0, 0.25, 2.0]];

/// File position -> original id.
pub const ORDER: [u32; 2] = [1, 0];

/// The file position of the element drawn at `(x, y)` of the strip (its face's element).
pub fn element_at(x: f32, y: f32) -> usize {
    let x0 = x.floor().clamp(0.0, 1.0);
    usize::from(y > x - x0)
}

/// The face at `(x, y)` of the strip.
pub fn face_at(x: f32, y: f32) -> usize {
    let x0 = x.floor().clamp(0.0, 1.0);
    2 * x0 as usize + element_at(x, y)
}

/// The file described in the module docs (valid: `OperatorFile::validate` passes).
pub fn interleaved() -> OperatorFile {
    let quad = |y0: f32, y1: f32| [0.0, y0, 0.0, 2.0, y0, 0.0, 2.0, y1, 0.0, 0.0, y1, 0.0];
    let geometry = Geometry {
        vertex_count: vec![4, 4],
        vertices: [quad(0.0, 0.5), quad(0.5, 1.0)].concat(),
        normals: [0.0, 0.0, 1.0].repeat(2),
    };
    let triangles: [[[f32; 2]; 3]; 4] = [
        [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]],
        [[0.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
        [[1.0, 0.0], [2.0, 0.0], [2.0, 1.0]],
        [[1.0, 0.0], [2.0, 1.0], [1.0, 1.0]],
    ];
    let mut faces = Faces {
        element: vec![0, 1, 0, 1],
        geometry: Geometry::default(),
    };
    for t in triangles {
        faces.geometry.vertex_count.push(3);
        for [x, y] in t {
            faces.geometry.vertices.extend([x, y, 0.0]);
        }
        faces.geometry.vertices.extend([0.0; 3]);
        faces.geometry.normals.extend([0.0, 0.0, 1.0]);
    }
    let smooth = smooth_by_position(&faces.geometry, &|f| faces.element[f]);
    let bvh = super::bvh::build(&faces.geometry);
    let file = OperatorFile {
        metadata_json: r#"{"generator":"lrr_runtime::testkit::faces"}"#.into(),
        n: 2,
        k: 1,
        channels: 3,
        precision: Precision::F32,
        order: ORDER.to_vec(),
        index: vec![0, 2],
        weights: vec![0.5, 0.5],
        operator: OperatorData::Factored {
            fk: StoredMatrix::F32(vec![0.0; 2]),
            cores: vec![1.0; 3],
        },
        reflectance: vec![0.5; 6],
        emission: EMISSION.concat(),
        geometry,
        lights: Vec::new(),
        display: Display {
            smooth: Some(smooth),
            materials: Some(Materials {
                materials: vec![Material::diffuse("strip", [0.5; 3])],
                element_material: vec![0, 0],
            }),
            cameras: vec![Camera {
                name: "top".into(),
                eye: [1.0, 0.5, 2.0],
                target: [1.0, 0.5, 0.0],
                up: [0.0, 1.0, 0.0],
                fov_y_deg: 60.0,
            }],
            bvh: Some(bvh),
            faces: Some(faces),
            ..Display::default()
        },
    };
    debug_assert!(file.validate().is_ok());
    file
}

/// [`interleaved`] with lightmap coordinates `uv(x, y)` at every face corner (section
/// LIGHTMAP) over a `width × height` atlas dilated `padding` rings (ATLAS, the scene's own).
pub fn lightmapped(
    uv: impl Fn(f32, f32) -> [f32; 2],
    width: u32,
    height: u32,
    padding: u32,
) -> OperatorFile {
    let mut file = interleaved();
    let g = file.faces().geometry.clone();
    let mut coords = vec![0.0; 8 * g.len()];
    for f in 0..g.len() {
        for c in 0..usize::from(g.vertex_count[f]) {
            let [x, y, _] = g.vertex(f, c);
            coords[8 * f + 2 * c..8 * f + 2 * c + 2].copy_from_slice(&uv(x, y));
        }
    }
    file.display.lightmap = Some(scene_atlas(coords, width, height, padding));
    debug_assert!(file.validate().is_ok());
    file
}

/// Smooth weights joining every corner of `g` at one position (to 1/1024): the mean of the
/// elements (each once, `element(polygon)`) with a corner there. The tests' stand-in for the
/// bake's weights, on GEOMETRY or on display faces.
pub fn smooth_by_position(g: &Geometry, element: &dyn Fn(usize) -> u32) -> Smooth {
    let mut keys: std::collections::HashMap<[i64; 3], usize> = Default::default();
    let mut members: Vec<Vec<u32>> = Vec::new();
    let mut corners = vec![Smooth::NONE; 4 * g.len()];
    for f in 0..g.len() {
        for i in 0..usize::from(g.vertex_count[f]) {
            let key = g
                .vertex(f, i)
                .map(|x| (f64::from(x) * 1024.0).round() as i64);
            let v = *keys.entry(key).or_insert_with(|| {
                members.push(Vec::new());
                members.len() - 1
            });
            if !members[v].contains(&element(f)) {
                members[v].push(element(f));
            }
            corners[4 * f + i] = v as u32;
        }
    }
    let mut s = Smooth {
        corners,
        offsets: vec![0],
        ..Smooth::default()
    };
    for m in members {
        s.weights.extend(m.iter().map(|_| 1.0 / m.len() as f32));
        s.positions.extend(m);
        s.offsets.push(s.positions.len() as u32);
    }
    s
}

/// A synthetic file (`synthetic::file(n, k, 3, F32, Factored, seed)`: a grid of unit squares,
/// one element each) drawn through display faces (each square two triangles), with SMOOTH by
/// position and lightmap coordinates that spread the grid over a `width × height` atlas
/// dilated `padding` rings, a texel's margin on each side. Dense grids put many elements under
/// each texel run: the lightmap fill's test of many smooth vertices per tile.
pub fn lightmapped_grid(
    n: usize,
    k: usize,
    width: u32,
    height: u32,
    padding: u32,
    seed: u64,
) -> OperatorFile {
    let mut file =
        super::synthetic::file(n, k, 3, Precision::F32, lrr_formats::Layout::Factored, seed)
            .expect("valid sizes");
    let g = file.geometry.clone();
    let cells = (n as f64).sqrt().ceil() as f32;
    let rows = n.div_ceil(cells as usize) as f32;
    let mut faces = Faces::default();
    let mut coords = Vec::new();
    let margin = padding as f32 + 1.0;
    let (w, h) = (width as f32, height as f32);
    for e in 0..n {
        for t in [[0, 1, 2], [0, 2, 3]] {
            faces.element.push(e as u32);
            faces.geometry.vertex_count.push(3);
            for c in t {
                let [x, y, z] = g.vertex(e, c);
                faces.geometry.vertices.extend([x, y, z]);
                coords.extend([
                    (margin + x / cells * (w - 2.0 * margin)) / w,
                    (margin + y / rows * (h - 2.0 * margin)) / h,
                ]);
            }
            faces.geometry.vertices.extend([0.0; 3]);
            coords.extend([0.0; 2]);
            faces.geometry.normals.extend([0.0, 0.0, 1.0]);
        }
    }
    file.display.smooth = Some(smooth_by_position(&faces.geometry, &|f| faces.element[f]));
    file.display.bvh = Some(super::bvh::build(&faces.geometry));
    file.display.faces = Some(faces);
    file.display.lightmap = Some(scene_atlas(coords, width, height, padding));
    file.validate().expect("a valid file");
    file
}

/// Lightmap coordinates `uv` (8 per face) over the scene's own `width × height` atlas.
fn scene_atlas(uv: Vec<f32>, width: u32, height: u32, padding: u32) -> LightmapUv {
    LightmapUv {
        uv,
        atlas: Some(LightmapAtlas {
            width,
            height,
            padding,
            source: LightmapSource::Scene,
            density: 0.0,
        }),
    }
}
