//! What the bake stores for display (format 1.2, [`lrr_formats::Display`]): the display
//! geometry, the material of every element, the scene's point lights (each following the
//! light group of its emitter) and cameras, the BVH over the display triangles (`bvh`), and
//! the lightmap coordinates of every display face corner (format 1.3) with the atlas they
//! address (1.6): the scene's own (`TEXCOORD_1`) when every face has them, else charts of
//! coplanar faces packed here ([`charts`], [`atlas`]).
//!
//! Built once the fine mesh exists, before the form factors, so that a bad point light or
//! camera is refused before hours of work; `write::Skeleton` carries the result into the file
//! (and a sharded bake's parts into the merged file) unchanged.

pub mod atlas;
mod bvh;
pub mod charts;

use lrr_formats::{
    Bvh, Camera, Display, Faces, Geometry, LightmapAtlas, LightmapSource, LightmapUv, Material,
    Materials, PointLight,
};

use crate::error::{Error, Result};
use crate::geometry::Polygon;
use crate::mesh::Element;
use crate::patches::Mesh;
use crate::progress::Progress;
use crate::scene::{Optics, Scene};

/// The display sections of a bake of `scene` meshed as `mesh` (the smooth weights from
/// `mesh::smooth`). Errors
/// name the scene and the light, camera or material at fault.
/// With a sky, its transfer per element is projected here through `occluder` (section
/// SKY_TRANSFER; `lights::sky_transfer`).
pub fn build(
    scene: &Scene,
    mesh: &Mesh,
    occluder: Option<&dyn crate::visibility::Occluder>,
    progress: &Progress,
    max_memory: Option<u64>,
) -> Result<Display> {
    let materials = materials(scene, mesh)?;
    let point_lights = point_lights(scene, mesh)?;
    let direct_lights = direct_lights(scene)?;
    let cameras = cameras(scene)?;
    let shown = Shown::of(mesh);
    // Both follow the display faces: the elements, or the input's faces where small ones were
    // grouped into elements.
    let advice = "use a larger --element-size or simplify the model (fewer triangles), or \
                  raise --max-memory";
    let bytes = bvh::build_bytes(shown.geometry.triangles().count());
    let what = format!("the display BVH ({} faces)", shown.faces.len());
    crate::memory::check_with(bytes, max_memory, &what, advice)?;
    progress.estimate("bvh", bytes);
    let stage = progress.stage("bvh", 0);
    let bvh = bvh::build(&shown.geometry);
    stage.finish();
    let bytes = crate::mesh::smooth::build_bytes(shown.faces.len());
    let what = format!("building the smooth weights ({} faces)", shown.faces.len());
    crate::memory::check_with(bytes, max_memory, &what, advice)?;
    progress.estimate("smooth", bytes);
    let stage = progress.stage("smooth", 0);
    let refs: Vec<&Element> = shown.faces.iter().collect();
    let mut smooth = crate::mesh::smooth::weights(scene, &refs, mesh.contacts.as_deref());
    if shown.grouped {
        smooth = crate::mesh::smooth::per_element(&smooth, &shown.element);
    }
    stage.finish();
    if scene.bake.lightmap != Some(false) {
        let bytes = lightmap_bytes(shown.faces.len());
        let what = format!("the lightmap's charts ({} faces)", shown.faces.len());
        let advice = "use --no-lightmap, a larger --element-size or simplify the model (fewer \
                      triangles), or raise --max-memory";
        crate::memory::check_with(bytes, max_memory, &what, advice)?;
        progress.estimate("lightmap", bytes);
    }
    let stage = progress.stage("lightmap", 0);
    let lightmap = match scene.bake.lightmap {
        Some(false) => None,
        _ => Some(lightmap(scene, &shown)?),
    };
    stage.finish();
    let sky_transfer = scene
        .direct_lights
        .iter()
        .any(|l| l.kind.is_sky())
        .then(|| {
            let stage = progress.stage("sky", 0);
            let polygons: Vec<Vec<&Polygon>> = (0..mesh.n())
                .map(|s| mesh.element_at(s).lit().collect())
                .collect();
            let t = crate::lights::sky_transfer(&polygons, occluder, scene.extent());
            stage.finish();
            t
        });
    Ok(Display {
        sky_transfer,
        smooth: Some(smooth),
        materials: Some(materials),
        point_lights,
        direct_lights,
        cameras,
        bvh: Some(bvh),
        lightmap,
        faces: shown.grouped.then_some(Faces {
            element: shown.element,
            geometry: shown.geometry,
        }),
    })
}

/// Bytes the lightmap stage may hold a display face at its peak, from its structures: the
/// charts' face adjacency (a vector per face and its entries, about 64 bytes), the pair
/// search's cell entries (two 32-byte entries a face), the charts' face lists and the packer's
/// rectangles, and the coordinates it answers (32 bytes a face). Measured (the stage's rise
/// over what was resident when it began, peak reset at its start): 40 bytes a face on a
/// tessellated sphere of 82 417 faces, nothing measurable on the Cornell box and the living
/// room, where it reuses what the smooth weights freed.
const LIGHTMAP_BYTES_PER_FACE: u128 = 256;

/// What the lightmap stage (generated charts and packing, or the scene's own coordinates)
/// may hold over `faces` display faces.
fn lightmap_bytes(faces: usize) -> u128 {
    faces as u128 * LIGHTMAP_BYTES_PER_FACE
}

/// What is drawn, in file order: each element's own polygon, or the faces of a dense mesh's
/// element ([`Element::shown`]; then the file holds them as section FACES).
struct Shown {
    /// One element per face (`parts` empty), as the smooth weights take them.
    faces: Vec<Element>,
    /// The file position each face shows.
    element: Vec<u32>,
    /// The faces in f32.
    geometry: Geometry,
    /// Whether any element is drawn as other polygons than its own.
    grouped: bool,
}

impl Shown {
    fn of(mesh: &Mesh) -> Self {
        let elements = (0..mesh.n()).map(|s| mesh.element_at(s));
        let (faces, element, grouped) = crate::mesh::shown_faces(elements);
        let geometry = polygons(faces.iter().map(|e| &e.polygon), faces.len());
        Self {
            faces,
            element,
            geometry,
            grouped,
        }
    }
}

/// The BVH a bake stores over `geometry`'s display triangles (section BVH), built as
/// [`build`] builds it; `lrr bench render` traces the tree users get.
pub fn bvh(geometry: &Geometry) -> Bvh {
    bvh::build(geometry)
}

/// The side of a generated atlas when no texel density is set; larger (doubling) when the
/// charts do not fit at their smallest.
pub const DEFAULT_LIGHTMAP_SIDE: usize = 1024;

/// Texels dilated around the charts when no padding is set (bilinear filtering needs 1).
pub const DEFAULT_LIGHTMAP_PADDING: u32 = 2;

/// The lightmap coordinates of every corner of the display faces (section LIGHTMAP) and their
/// atlas (ATLAS): the scene's `TEXCOORD_1` when every face has them (`scene::load` warns when
/// only some do), in a [`DEFAULT_LIGHTMAP_SIDE`]² atlas; else charts of coplanar connected
/// faces packed at `[bake] lightmap_texel_density` (`--lightmap-texel-density`), or at the
/// largest density that fits [`DEFAULT_LIGHTMAP_SIDE`]² texels.
fn lightmap(scene: &Scene, shown: &Shown) -> Result<LightmapUv> {
    let padding = scene
        .bake
        .lightmap_padding
        .unwrap_or(DEFAULT_LIGHTMAP_PADDING);
    if let Some(uv) = scene_lightmap(scene, &shown.faces) {
        let side = DEFAULT_LIGHTMAP_SIDE as u32;
        return Ok(LightmapUv {
            uv,
            atlas: Some(LightmapAtlas {
                width: side,
                height: side,
                padding,
                source: LightmapSource::Scene,
                density: 0.0,
            }),
        });
    }
    generated_lightmap(&shown.geometry, scene.bake.lightmap_texel_density, padding)
}

/// Charts of `geometry`'s faces packed at `density` texels per unit, or (None) into the
/// smallest of [`DEFAULT_LIGHTMAP_SIDE`]², twice that, … that holds them; their coordinates at
/// every face corner and the atlas.
pub fn generated_lightmap(
    geometry: &Geometry,
    density: Option<f64>,
    padding: u32,
) -> Result<LightmapUv> {
    let charts = charts::charts(geometry);
    let pad = padding as usize;
    let layout = match density {
        Some(t) => atlas::pack(&charts, atlas::Sizing::Density(t), pad).map_err(|e| {
            Error::Settings(format!(
                "the lightmap (--lightmap-texel-density, [bake] lightmap_texel_density): {e}"
            ))
        })?,
        None => {
            let mut side = DEFAULT_LIGHTMAP_SIDE;
            loop {
                match atlas::pack(&charts, atlas::Sizing::Size(side), pad) {
                    Ok(layout) => break layout,
                    Err(_) if side < atlas::MAX_SIZE => side *= 2,
                    Err(e) => {
                        return Err(Error::Settings(format!(
                            "the lightmap: {e}; set a smaller --lightmap-padding"
                        )));
                    }
                }
            }
        }
    };
    Ok(LightmapUv {
        uv: chart_uvs(geometry, &charts, &layout),
        atlas: Some(LightmapAtlas {
            width: layout.width as u32,
            height: layout.height as u32,
            padding,
            source: LightmapSource::Generated,
            density: layout.density,
        }),
    })
}

/// The atlas coordinates of every corner of `geometry`'s faces laid out as `charts` in
/// `layout` (a triangle's fourth zero).
pub fn chart_uvs(
    geometry: &Geometry,
    charts: &[charts::Chart],
    layout: &atlas::Layout,
) -> Vec<f32> {
    let mut uv = vec![0.0f32; 8 * geometry.vertex_count.len()];
    for (c, chart) in charts.iter().enumerate() {
        for &s in &chart.faces {
            let s = s as usize;
            for (k, p) in charts::corners(geometry, s).iter().enumerate() {
                let [u, v] = layout.uv(c, chart.flatten(*p));
                uv[8 * s + 2 * k] = u;
                uv[8 * s + 2 * k + 1] = v;
            }
        }
    }
    uv
}

/// The scene's lightmap coordinates (`TEXCOORD_1`) at every corner of the display `faces`;
/// None unless every face has them.
fn scene_lightmap(scene: &Scene, faces: &[Element]) -> Option<Vec<f32>> {
    let mut uv = Vec::with_capacity(8 * faces.len());
    for e in faces {
        let map = scene.faces[e.face as usize].uv[1].as_ref()?;
        for (i, v) in e.polygon.vertices.iter().enumerate() {
            let [a, b] = if i < e.polygon.count {
                map.at(*v)
            } else {
                [0.0; 2]
            };
            uv.extend([a as f32, b as f32]);
        }
    }
    Some(uv)
}

/// The fine mesh's elements in file order and f32 (section GEOMETRY): a dense mesh's element
/// as its proxy.
pub(crate) fn geometry(mesh: &Mesh) -> Geometry {
    polygons((0..mesh.n()).map(|s| &mesh.element_at(s).polygon), mesh.n())
}

/// `count` polygons in f32, as GEOMETRY and FACES store them.
fn polygons<'a>(all: impl Iterator<Item = &'a Polygon>, count: usize) -> Geometry {
    let mut geometry = Geometry {
        vertex_count: Vec::with_capacity(count),
        vertices: Vec::with_capacity(count * 12),
        normals: Vec::with_capacity(count * 3),
    };
    for p in all {
        geometry.vertex_count.push(p.count as u8);
        // Triangles leave their fourth slot zero (Polygon keeps unused slots zeroed).
        for v in &p.vertices {
            geometry
                .vertices
                .extend([v.x as f32, v.y as f32, v.z as f32]);
        }
        geometry
            .normals
            .extend([p.normal.x as f32, p.normal.y as f32, p.normal.z as f32]);
    }
    geometry
}

fn f32s(v: [f64; 3]) -> [f32; 3] {
    v.map(|x| x as f32)
}

/// Every scene material (diffuse ρ and optics) and the material of each file position.
fn materials(scene: &Scene, mesh: &Mesh) -> Result<Materials> {
    let mut materials = Vec::with_capacity(scene.materials.len());
    for m in &scene.materials {
        let Optics {
            specular,
            shininess,
            mirror,
            transmission,
            ior,
        } = m.optics;
        let material = Material {
            name: m.name.clone(),
            diffuse: f32s(m.reflectance),
            specular: f32s(specular),
            shininess: shininess as f32,
            mirror: f32s(mirror),
            transmission: f32s(transmission),
            ior: ior as f32,
        };
        material
            .check()
            .map_err(|e| Error::scene(&scene.name, e.message))?;
        materials.push(material);
    }
    let element_material = (0..mesh.n())
        .map(|s| scene.faces[mesh.element_at(s).face as usize].material as u32)
        .collect();
    Ok(Materials {
        materials,
        element_material,
    })
}

/// The light group index of each surface: `write::Skeleton::add_light_groups` makes one group
/// per surface with an emitting element, in surface order.
fn light_groups(scene: &Scene, mesh: &Mesh) -> Vec<Option<u32>> {
    let mut emits = vec![false; scene.surfaces.len()];
    for e in &mesh.elements {
        let material = &scene.materials[scene.faces[e.face as usize].material];
        if material.emission.iter().any(|&x| x > 0.0) {
            emits[e.surface as usize] = true;
        }
    }
    let mut next = 0;
    emits
        .iter()
        .map(|&emits| {
            emits.then(|| {
                next += 1;
                next - 1
            })
        })
        .collect()
}

/// The scene's spot and directional lights and sky, as the file stores them (checked: the error
/// names the light and the field).
fn direct_lights(scene: &Scene) -> Result<Vec<lrr_formats::DirectLight>> {
    let mut lights = Vec::with_capacity(scene.direct_lights.len());
    for l in &scene.direct_lights {
        let light = lrr_formats::DirectLight {
            name: l.name.clone(),
            kind: l.kind,
            position: f32s(l.position),
            direction: f32s(l.direction),
            strength: f32s(l.strength),
            extra: f32s(l.extra),
        };
        light
            .check_values()
            .map_err(|e| Error::scene(&scene.name, format!("light {}", e.message)))?;
        lights.push(light);
    }
    Ok(lights)
}

/// The scene's point lights, each with the index of its group: a group name is an emitting
/// surface's (its own group), or an emitting material's used by exactly one emitting surface.
fn point_lights(scene: &Scene, mesh: &Mesh) -> Result<Vec<PointLight>> {
    let groups = light_groups(scene, mesh);
    let emitters: Vec<&str> = scene
        .surfaces
        .iter()
        .zip(&groups)
        .filter(|(_, g)| g.is_some())
        .map(|(s, _)| s.as_str())
        .collect();
    let mut lights = Vec::with_capacity(scene.point_lights.len());
    for light in &scene.point_lights {
        let fail = |problem: String| {
            Error::scene(
                &scene.name,
                format!("point light '{}': {problem}", light.name),
            )
        };
        let group = match &light.group {
            None => PointLight::FIXED,
            Some(name) => group_of(scene, mesh, &groups, name).map_err(|problem| {
                fail(format!(
                    "{problem}; the light groups are the emitting surfaces: {}",
                    if emitters.is_empty() {
                        "none (the scene emits nothing)".to_string()
                    } else {
                        emitters.join(", ")
                    }
                ))
            })?,
        };
        let point = PointLight {
            name: light.name.clone(),
            position: f32s(light.position),
            intensity: f32s(light.intensity),
            group,
        };
        point
            .check_values()
            .map_err(|e| Error::scene(&scene.name, e.message))?;
        lights.push(point);
    }
    Ok(lights)
}

/// The group a point light names (see [`point_lights`]), or why there is none.
fn group_of(
    scene: &Scene,
    mesh: &Mesh,
    groups: &[Option<u32>],
    name: &str,
) -> std::result::Result<u32, String> {
    if let Some(s) = scene.surfaces.iter().position(|s| s == name) {
        return groups[s]
            .ok_or_else(|| format!("its group '{name}' is a surface that emits nothing"));
    }
    let Some(m) = scene.materials.iter().position(|m| m.name == name) else {
        return Err(format!(
            "its group '{name}' is no surface or material of the scene"
        ));
    };
    let mut surfaces: Vec<u32> = mesh
        .elements
        .iter()
        .filter(|e| scene.faces[e.face as usize].material == m)
        .map(|e| e.surface)
        .filter(|&s| groups[s as usize].is_some())
        .collect();
    surfaces.sort_unstable();
    surfaces.dedup();
    match surfaces[..] {
        [s] => Ok(groups[s as usize].unwrap_or(PointLight::FIXED)),
        [] => Err(format!(
            "its group '{name}' is a material that no emitting surface uses"
        )),
        _ => Err(format!(
            "its group '{name}' is a material of several emitting surfaces ({}): name one \
             surface",
            surfaces
                .iter()
                .map(|&s| scene.surfaces[s as usize].as_str())
                .collect::<Vec<_>>()
                .join(", ")
        )),
    }
}

/// The scene's cameras.
fn cameras(scene: &Scene) -> Result<Vec<Camera>> {
    let mut cameras: Vec<Camera> = Vec::with_capacity(scene.cameras.len());
    for c in &scene.cameras {
        let camera = Camera {
            name: c.name.clone(),
            eye: f32s(c.eye),
            target: f32s(c.target),
            up: f32s(c.up),
            fov_y_deg: c.fov_y_deg as f32,
        };
        camera
            .check()
            .map_err(|e| Error::scene(&scene.name, e.message))?;
        if cameras.iter().any(|other| other.name == camera.name) {
            return Err(Error::scene(
                &scene.name,
                format!("two cameras are named '{}': names must be unique", c.name),
            ));
        }
        cameras.push(camera);
    }
    Ok(cameras)
}
