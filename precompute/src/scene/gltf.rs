//! glTF 2.0 import (`.gltf` and `.glb`): the gltf crate parses and validates the JSON; the GLB
//! container, buffers, images and accessors are read here, every range checked, so that bad
//! input is an error naming the part (mesh, primitive, accessor by index and name), never a
//! panic. docs/SCENES.md lists what maps to what.
//!
//! - Geometry: the nodes of the default scene (else scene 0, else every root node), each
//!   mesh under its node's world transform (matrix or TRS; a mirroring transform keeps the
//!   front side by reversing the winding). Primitives of mode TRIANGLES, TRIANGLE_STRIP and
//!   TRIANGLE_FAN, indexed or not, become triangles through `Scene::add_polygon` (front:
//!   counter-clockwise, as in glTF); points and lines are skipped with a warning. A surface per
//!   node (its name, else its mesh's, else `node N`), `surface/material` when its mesh uses
//!   several materials.
//! - Materials: `c` = baseColorFactor × the linear average of the baseColor texture over its
//!   texels (the material's mean), `m` = metallic, `r` = roughness,
//!   `t` = KHR_materials_transmission. Diffuse reflectance `ρ = c·(1−m)·(1−t) + c·m·r` (a
//!   rough metal scatters almost diffusely), mirror `c·m·(1−r)` (a smooth metal is a mirror),
//!   transmission filter `c·(1−m)·t`, ior from KHR_materials_ior (glTF's default 1.5 for
//!   transmissive materials). ρ at or above [`MAX_REFLECTANCE`] is clamped with a warning.
//!   Emission: emissiveFactor × KHR_materials_emissive_strength × the emissive texture's average
//!   is the radiance `L`; the exitance is `π·L` (as OBJ's `Ke`).
//! - Textures: a baseColor texture varies ρ over the surface: each face keeps its triangle's
//!   `TEXCOORD_0`/`TEXCOORD_1` as an affine map of its plane (`texture::UvMap`), and each
//!   element's ρ is the texture's mean over its area times the same factors
//!   (`Scene::reflectance_over`); primitives without the coordinate set take the material's
//!   mean, with a warning. `TEXCOORD_1` is kept for lightmaps whatever the material.
//! - Cameras (perspective) and KHR_lights_punctual point lights, placed by their nodes.
//! - Extensions: required ones other than [`UNDERSTOOD`] are refused by name; used ones not
//!   understood are warned about by name.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use base64::Engine;
use glam::{DMat4, DQuat, DVec3};
use gltf::json;

use super::model::{Camera, DirectLight, Material, Optics, PointLight, Scene, clamp_reflectance};
use super::texture::{self, Budget, Texture, TextureBinding, UvMap, UvTransform, Wrap};
use crate::error::{Error, Result};

/// The extensions this importer reads (everything else is refused when required, warned about
/// when used).
pub const UNDERSTOOD: [&str; 6] = [
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_transmission",
    "KHR_mesh_quantization",
    "KHR_texture_transform",
];

/// Largest diffuse reflectance kept as is; above it a material is clamped (with a warning),
/// since a reflectance of 1 makes a closed scene's radiosity system singular.
pub const MAX_REFLECTANCE: f64 = super::model::MAX_TEXTURED_REFLECTANCE;

/// Reflectance of primitives without a material (with a warning; OBJ uses the same).
const DEFAULT_REFLECTANCE: f64 = 0.5;

/// Loads a `.gltf` or `.glb` file; external buffers and images must lie in its folder. Each
/// image is planned before it is decoded against 80% of the available memory
/// (`LRR_MEMORY_LIMIT` sets what is available; [`crate::scene::load_within`] takes a limit).
pub fn load(path: &Path) -> Result<Scene> {
    load_within(
        path,
        Budget {
            planned: 0,
            max_memory: None,
        },
    )
    .map(|(scene, _)| scene)
}

/// [`load`], each image planned before it is decoded beside `budget`; answers the bytes
/// planned in all.
pub(crate) fn load_within(path: &Path, budget: Budget) -> Result<(Scene, u128)> {
    let origin = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let base = path.parent().unwrap_or(Path::new("."));
    let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("scene");
    import_within(&bytes, (base, name, &origin), budget)
}

/// Imports glTF or GLB bytes; `base` is the folder relative URIs are resolved in (and must stay
/// in), `name` the scene name, `origin` the file name for messages. Images are planned as in
/// [`load`].
pub fn import(bytes: &[u8], base: &Path, name: &str, origin: &str) -> Result<Scene> {
    let budget = Budget {
        planned: 0,
        max_memory: None,
    };
    import_within(bytes, (base, name, origin), budget).map(|(scene, _)| scene)
}

/// [`import`] within `budget` (see [`load_within`]).
fn import_within(
    bytes: &[u8],
    (base, name, origin): (&Path, &str, &str),
    budget: Budget,
) -> Result<(Scene, u128)> {
    let err = |msg: String| Error::scene(origin, msg);
    let (json_bytes, blob) = if bytes.starts_with(b"glTF") {
        split_glb(bytes).map_err(|m| err(format!("malformed GLB: {m}")))?
    } else {
        (bytes, None)
    };
    let mut root: json::Root = json::deserialize::from_slice(json_bytes)
        .map_err(|e| err(format!("cannot parse the glTF JSON: {e}")))?;
    let mut scene = Scene::new(name);
    check_extensions(&root, origin, &mut scene.warnings)?;
    // Honoured here (the attribute readers take its integer types), unknown to the gltf
    // crate's validation, which refuses a required extension it does not know.
    root.extensions_required
        .retain(|e| e != "KHR_mesh_quantization");
    check_position_references(&root, origin)?;
    let doc = gltf::Document::from_json(root)
        .map_err(|e| err(format!("the glTF does not validate: {e}")))?;
    let mut importer = Importer {
        doc: &doc,
        origin,
        base,
        blob,
        buffers: HashMap::new(),
        materials: HashMap::new(),
        textures: HashMap::new(),
        budget,
        scene,
    };
    importer.buffers_checked()?;
    let roots = importer.roots()?;
    let mut stack: Vec<(usize, DMat4)> = roots
        .into_iter()
        .rev()
        .map(|n| (n, DMat4::IDENTITY))
        .collect();
    let mut seen = vec![false; doc.nodes().len()];
    while let Some((index, parent)) = stack.pop() {
        if std::mem::replace(&mut seen[index], true) {
            return Err(err(format!(
                "node {index} is reached twice: the node hierarchy must be a tree (no node may \
                 have two parents or be its own ancestor)"
            )));
        }
        let node = doc.nodes().nth(index).expect("validated node index");
        let world = parent * importer.local_transform(&node)?;
        importer.node(&node, &world)?;
        for child in node.children().collect::<Vec<_>>().into_iter().rev() {
            stack.push((child.index(), world));
        }
    }
    Ok((importer.scene, importer.budget.planned))
}

/// The JSON chunk and the optional BIN chunk of a GLB container.
fn split_glb(bytes: &[u8]) -> std::result::Result<(&[u8], Option<&[u8]>), String> {
    let word = |at: usize| -> Option<u32> {
        Some(u32::from_le_bytes(bytes.get(at..at + 4)?.try_into().ok()?))
    };
    let (Some(version), Some(length)) = (word(4), word(8)) else {
        return Err(format!(
            "{} bytes is shorter than the 12-byte header",
            bytes.len()
        ));
    };
    if version != 2 {
        return Err(format!(
            "container version {version}; only version 2 (glTF 2.0) is read"
        ));
    }
    let length = length as usize;
    if length < 20 || length > bytes.len() {
        return Err(format!(
            "the header declares {length} bytes but the file holds {} (truncated or damaged)",
            bytes.len()
        ));
    }
    let bytes = &bytes[..length];
    let mut at = 12;
    let mut chunks = Vec::new();
    while at < length {
        let (Some(len), Some(kind)) = (
            bytes
                .get(at..at + 4)
                .map(|b| u32::from_le_bytes(b.try_into().unwrap())),
            bytes.get(at + 4..at + 8),
        ) else {
            return Err(format!("chunk header at byte {at} runs past the end"));
        };
        let start = at + 8;
        let end = start
            .checked_add(len as usize)
            .filter(|&e| e <= length)
            .ok_or_else(|| {
                format!(
                    "chunk at byte {at} declares {len} bytes but only {} remain (truncated)",
                    length - start.min(length)
                )
            })?;
        chunks.push((kind, &bytes[start..end], at));
        at = end.next_multiple_of(4);
    }
    match chunks.as_slice() {
        [(b"JSON", json, _), rest @ ..] => {
            let bin = match rest {
                [] => None,
                [(b"BIN\0", bin, _), ..] => Some(*bin),
                [(kind, _, at), ..] => {
                    return Err(format!(
                        "the chunk at byte {at} has type {:?}; the second chunk must be BIN",
                        String::from_utf8_lossy(kind)
                    ));
                }
            };
            Ok((json, bin))
        }
        _ => Err("the first chunk must be the JSON chunk".into()),
    }
}

/// Refuses required extensions this importer cannot honour, warns about used ones it ignores.
fn check_extensions(root: &json::Root, origin: &str, warnings: &mut Vec<String>) -> Result<()> {
    for ext in &root.extensions_required {
        if !UNDERSTOOD.contains(&ext.as_str()) {
            let what = match ext.as_str() {
                "KHR_draco_mesh_compression" => " (Draco-compressed meshes)",
                "EXT_meshopt_compression" => " (meshoptimizer-compressed buffers)",
                "KHR_texture_basisu" => " (Basis Universal textures)",
                _ => "",
            };
            return Err(Error::scene(
                origin,
                format!(
                    "the file requires the extension {ext}{what}, which lrr does not support; \
                     export without it (lrr reads {})",
                    UNDERSTOOD.join(", ")
                ),
            ));
        }
    }
    for ext in &root.extensions_used {
        if !UNDERSTOOD.contains(&ext.as_str()) {
            warnings.push(format!(
                "{origin}: extension {ext} is used but not supported; its data is ignored"
            ));
        }
    }
    Ok(())
}

/// Checks what the gltf crate's validation indexes without a bounds check (1.4.1 panics on a
/// POSITION attribute naming a missing accessor; found by this importer's tests).
fn check_position_references(root: &json::Root, origin: &str) -> Result<()> {
    let position = json::validation::Checked::Valid(json::mesh::Semantic::Positions);
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            if let Some(a) = primitive.attributes.get(&position)
                && a.value() >= root.accessors.len()
            {
                return Err(Error::scene(
                    origin,
                    format!(
                        "{} primitive {p}: POSITION refers to accessor {}, but the file has {} \
                         accessors",
                        named("mesh", m, mesh.name.as_deref()),
                        a.value(),
                        root.accessors.len()
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// The state of one import.
struct Importer<'a> {
    doc: &'a gltf::Document,
    origin: &'a str,
    base: &'a Path,
    blob: Option<&'a [u8]>,
    /// Loaded buffers by index (each at least its declared length).
    buffers: HashMap<usize, Vec<u8>>,
    /// glTF material index (None: the default material) → scene material.
    materials: HashMap<Option<usize>, usize>,
    /// glTF texture index → `Scene::textures`.
    textures: HashMap<usize, usize>,
    /// What the import may use; each image is planned before it is decoded.
    budget: Budget,
    scene: Scene,
}

/// "mesh 2 'chair'" and the like.
fn named(kind: &str, index: usize, name: Option<&str>) -> String {
    match name {
        Some(n) => format!("{kind} {index} '{n}'"),
        None => format!("{kind} {index}"),
    }
}

impl<'a> Importer<'a> {
    fn err(&self, msg: impl Into<String>) -> Error {
        Error::scene(self.origin, msg)
    }

    /// Loads every buffer and checks it holds its declared length.
    fn buffers_checked(&mut self) -> Result<()> {
        for buffer in self.doc.buffers() {
            let what = named("buffer", buffer.index(), buffer.name());
            let data = match buffer.source() {
                gltf::buffer::Source::Bin => match self.blob {
                    Some(b) => b.to_vec(),
                    None => {
                        return Err(self.err(format!(
                            "{what} refers to the GLB binary chunk, but the file has none \
                             (a .gltf buffer needs a 'uri')"
                        )));
                    }
                },
                gltf::buffer::Source::Uri(uri) => self.uri_bytes(uri, &what)?,
            };
            if data.len() < buffer.length() {
                return Err(self.err(format!(
                    "{what} declares {} bytes but its data holds {} (truncated or wrong byteLength)",
                    buffer.length(),
                    data.len()
                )));
            }
            self.buffers.insert(buffer.index(), data);
        }
        Ok(())
    }

    /// The bytes of a data URI or of a file in the scene's folder.
    fn uri_bytes(&self, uri: &str, what: &str) -> Result<Vec<u8>> {
        if let Some(rest) = uri.strip_prefix("data:") {
            let Some((_, payload)) = rest.split_once(";base64,") else {
                return Err(self.err(format!("{what}: only base64 data URIs are supported")));
            };
            return base64::engine::general_purpose::STANDARD
                .decode(payload)
                .map_err(|e| self.err(format!("{what}: bad base64 in its data URI: {e}")));
        }
        let path = self.local_path(uri, what)?;
        std::fs::read(&path).map_err(|e| {
            self.err(format!(
                "{what}: cannot read '{}': {e}; external files must sit next to the glTF",
                path.display()
            ))
        })
    }

    /// A relative URI resolved in the scene folder; refused when it leaves the folder.
    fn local_path(&self, uri: &str, what: &str) -> Result<PathBuf> {
        let decoded = percent_decode(uri)
            .ok_or_else(|| self.err(format!("{what}: URI '{uri}' has a bad %-escape")))?;
        let relative = Path::new(&decoded);
        let outside = uri.contains("://")
            || relative.is_absolute()
            || relative.components().any(|c| {
                !matches!(
                    c,
                    std::path::Component::Normal(_) | std::path::Component::CurDir
                )
            });
        if outside {
            return Err(self.err(format!(
                "{what}: URI '{uri}' points outside the scene's folder; lrr reads only relative \
                 paths inside it (or data: URIs, or the GLB binary chunk)"
            )));
        }
        let path = self.base.join(relative);
        // A link inside the folder may still lead out of it.
        if let (Ok(folder), Ok(real)) = (self.base.canonicalize(), path.canonicalize())
            && !real.starts_with(&folder)
        {
            return Err(self.err(format!(
                "{what}: '{uri}' resolves to '{}', outside the scene's folder",
                real.display()
            )));
        }
        Ok(path)
    }

    /// The nodes to start from: the default scene's, scene 0's, or every root node.
    fn roots(&self) -> Result<Vec<usize>> {
        if let Some(s) = self
            .doc
            .default_scene()
            .or_else(|| self.doc.scenes().next())
        {
            return Ok(s.nodes().map(|n| n.index()).collect());
        }
        let mut child = vec![false; self.doc.nodes().len()];
        for n in self.doc.nodes() {
            for c in n.children() {
                child[c.index()] = true;
            }
        }
        Ok((0..child.len()).filter(|&i| !child[i]).collect())
    }

    /// A node's local transform, checked finite (a rotation is normalised; zero is refused).
    fn local_transform(&self, node: &gltf::Node) -> Result<DMat4> {
        let what = named("node", node.index(), node.name());
        let m = match node.transform() {
            gltf::scene::Transform::Matrix { matrix } => {
                DMat4::from_cols_array_2d(&matrix.map(|c| c.map(f64::from)))
            }
            gltf::scene::Transform::Decomposed {
                translation,
                rotation,
                scale,
            } => {
                let q = DQuat::from_array(rotation.map(f64::from));
                let len = q.length();
                if !(len.is_finite() && len > 0.0) {
                    return Err(self.err(format!(
                        "{what}: rotation {rotation:?} is not a usable quaternion"
                    )));
                }
                DMat4::from_scale_rotation_translation(
                    DVec3::from_array(scale.map(f64::from)),
                    q / len,
                    DVec3::from_array(translation.map(f64::from)),
                )
            }
        };
        if !m.is_finite() {
            return Err(self.err(format!(
                "{what}: its transform holds a non-finite number (NaN or infinity)"
            )));
        }
        Ok(m)
    }

    /// Imports what a node holds under its world transform.
    fn node(&mut self, node: &gltf::Node, world: &DMat4) -> Result<()> {
        if !world.is_finite() {
            return Err(self.err(format!(
                "{}: its world transform overflows (not finite)",
                named("node", node.index(), node.name())
            )));
        }
        if let Some(mesh) = node.mesh() {
            self.mesh(node, &mesh, world)?;
        }
        if let Some(camera) = node.camera() {
            self.camera(node, &camera, world);
        }
        if let Some(light) = node.light() {
            self.light(node, &light, world);
        }
        Ok(())
    }

    fn mesh(&mut self, node: &gltf::Node, mesh: &gltf::Mesh, world: &DMat4) -> Result<()> {
        let mesh_name = named("mesh", mesh.index(), mesh.name());
        let base_surface = node
            .name()
            .or(mesh.name())
            .map(str::to_string)
            .unwrap_or_else(|| format!("node {}", node.index()));
        if node.skin().is_some() {
            self.scene.warnings.push(format!(
                "{}: {mesh_name} is skinned; imported in its bind pose",
                self.origin
            ));
        }
        let mut distinct: Vec<Option<usize>> = Vec::new();
        for p in mesh.primitives() {
            if !distinct.contains(&p.material().index()) {
                distinct.push(p.material().index());
            }
        }
        let mirrored = world.determinant() < 0.0;
        for primitive in mesh.primitives() {
            let what = format!("{mesh_name} primitive {}", primitive.index());
            use gltf::mesh::Mode;
            let mode = primitive.mode();
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                self.scene.warnings.push(format!(
                    "{}: {what} is made of {mode:?}, not triangles; skipped",
                    self.origin
                ));
                continue;
            }
            if primitive.morph_targets().next().is_some() {
                self.scene.warnings.push(format!(
                    "{}: {what} has morph targets; imported without them",
                    self.origin
                ));
            }
            let material = self.material(&primitive.material())?;
            let surface_name = if distinct.len() > 1 {
                format!("{base_surface}/{}", self.scene.materials[material].name)
            } else {
                base_surface.clone()
            };
            let surface = self.scene.surface(&surface_name);
            let Some(positions) = primitive.get(&gltf::Semantic::Positions) else {
                return Err(self.err(format!("{what} has no POSITION attribute")));
            };
            let positions = self.read_positions(&positions, &what)?;
            let indices: Vec<u32> = match primitive.indices() {
                Some(a) => self.read_indices(&a, &what, positions.len())?,
                None => {
                    let n = u32::try_from(positions.len())
                        .map_err(|_| self.err(format!("{what}: more than 2³² vertices")))?;
                    (0..n).collect()
                }
            };
            let world_positions: Vec<DVec3> = positions
                .iter()
                .map(|p| world.transform_point3(*p))
                .collect();
            let sets = self.texcoord_sets(&primitive, &what, positions.len(), material)?;
            let triangles = triangles(mode, &indices);
            for (t, tri) in triangles.into_iter().enumerate() {
                let mut v = tri.map(|i| world_positions[i as usize]);
                let uv = sets.each_ref().map(|set| {
                    let set = set.as_ref()?;
                    UvMap::from_triangle(v, tri.map(|i| set[i as usize]))
                });
                if mirrored {
                    v.swap(1, 2);
                }
                let location = format!("{}: {what} triangle {t}", self.origin);
                self.scene
                    .add_polygon_uv(&v, material, surface, uv, &location)?;
            }
        }
        Ok(())
    }

    /// The texture coordinates a primitive needs, where present: `TEXCOORD_1` (lightmaps) and
    /// the set its material's base colour texture names (other sets are not read, so a
    /// malformed set nothing uses cannot refuse the file); a material whose texture names a
    /// set the primitive lacks gets a warning (its mean is used).
    fn texcoord_sets(
        &mut self,
        primitive: &gltf::Primitive,
        what: &str,
        vertices: usize,
        material: usize,
    ) -> Result<[Option<Vec<[f64; 2]>>; 2]> {
        let texture_set = self.scene.materials[material].texture.map(|t| t.set);
        let mut sets = [None, None];
        for (set, slot) in sets.iter_mut().enumerate() {
            if set != 1 && texture_set != Some(set) {
                continue;
            }
            if let Some(a) = primitive.get(&gltf::Semantic::TexCoords(set as u32)) {
                // Unnormalised integers (KHR_mesh_quantization) are scaled back by a texture's
                // transform; nothing scales lightmap coordinates back, so a set 1 of them that
                // no texture reads is left out (the bake then generates the charts).
                let integers = a.data_type() != gltf::accessor::DataType::F32 && !a.normalized();
                if set == 1 && integers && texture_set != Some(1) {
                    self.scene.warnings.push(format!(
                        "{}: {what}: TEXCOORD_1 holds unnormalised integers, which nothing \
                         scales back to lightmap coordinates; left out",
                        self.origin
                    ));
                    continue;
                }
                *slot = Some(self.read_texcoords(&a, what, set, vertices)?);
            }
        }
        if let Some(t) = &self.scene.materials[material].texture
            && sets[t.set].is_none()
        {
            self.scene.warnings.push(format!(
                "{}: {what} has no TEXCOORD_{} for its material's baseColor texture; the \
                 texture's mean over the image is used",
                self.origin, t.set
            ));
        }
        Ok(sets)
    }

    fn camera(&mut self, node: &gltf::Node, camera: &gltf::Camera, world: &DMat4) {
        let json = &self.doc.as_json().cameras[camera.index()];
        let name = camera
            .name()
            .or(node.name())
            .map(str::to_string)
            .unwrap_or_else(|| format!("camera {}", camera.index()));
        let Some(p) = json.perspective.as_ref().filter(|_| {
            json.type_ == json::validation::Checked::Valid(json::camera::Type::Perspective)
        }) else {
            self.scene.warnings.push(format!(
                "{}: camera '{name}' is orthographic; only perspective cameras are imported",
                self.origin
            ));
            return;
        };
        let fov = f64::from(p.yfov).to_degrees();
        let eye = world.transform_point3(DVec3::ZERO);
        let forward = world.transform_vector3(DVec3::NEG_Z).normalize_or_zero();
        let up = world.transform_vector3(DVec3::Y).normalize_or_zero();
        if !(fov.is_finite() && fov > 0.0 && fov < 180.0)
            || forward == DVec3::ZERO
            || up == DVec3::ZERO
        {
            self.scene.warnings.push(format!(
                "{}: camera '{name}' has a degenerate view (yfov {} rad or a collapsed \
                 transform); skipped",
                self.origin, p.yfov
            ));
            return;
        }
        self.scene.cameras.push(Camera {
            name,
            eye: eye.to_array(),
            target: (eye + forward).to_array(),
            up: up.to_array(),
            fov_y_deg: fov,
        });
    }

    fn light(
        &mut self,
        node: &gltf::Node,
        light: &gltf::khr_lights_punctual::Light,
        world: &DMat4,
    ) {
        let name = light
            .name()
            .or(node.name())
            .map(str::to_string)
            .unwrap_or_else(|| format!("light {}", light.index()));
        use gltf::khr_lights_punctual::Kind;
        // Colour × intensity per channel (candela read as W/sr, lux as W/m²).
        let strength = |light: &gltf::khr_lights_punctual::Light| {
            light
                .color()
                .map(|c| f64::from(c) * f64::from(light.intensity()))
        };
        match light.kind() {
            Kind::Point => {
                let intensity = light
                    .color()
                    .map(|c| f64::from(c) * f64::from(light.intensity()));
                if intensity.iter().any(|i| !(i.is_finite() && *i >= 0.0)) {
                    self.scene.warnings.push(format!(
                        "{}: point light '{name}' has intensity {intensity:?}; skipped",
                        self.origin
                    ));
                    return;
                }
                self.scene.point_lights.push(PointLight {
                    name,
                    position: world.transform_point3(DVec3::ZERO).to_array(),
                    intensity,
                    group: None,
                });
            }
            Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => {
                let strength = strength(light);
                let (inner, outer) = (f64::from(inner_cone_angle), f64::from(outer_cone_angle));
                let cones = inner >= 0.0 && inner <= outer && outer <= std::f64::consts::FRAC_PI_2;
                if strength.iter().any(|i| !(i.is_finite() && *i >= 0.0)) || !cones {
                    self.scene.warnings.push(format!(
                        "{}: spot light '{name}' has intensity {strength:?} and cone angles \
                         {inner} and {outer} rad (need 0 <= inner <= outer <= pi/2); skipped",
                        self.origin
                    ));
                    return;
                }
                let Some(direction) = self.forward(world, &name) else {
                    return;
                };
                self.scene.direct_lights.push(DirectLight {
                    name,
                    kind: lrr_formats::DirectLightKind::Spot,
                    position: world.transform_point3(DVec3::ZERO).to_array(),
                    direction,
                    strength,
                    extra: [inner, outer, 0.0],
                });
            }
            Kind::Directional => {
                let strength = strength(light);
                if strength.iter().any(|i| !(i.is_finite() && *i >= 0.0)) {
                    self.scene.warnings.push(format!(
                        "{}: directional light '{name}' has irradiance {strength:?}; skipped",
                        self.origin
                    ));
                    return;
                }
                let Some(direction) = self.forward(world, &name) else {
                    return;
                };
                self.scene.direct_lights.push(DirectLight {
                    name,
                    kind: lrr_formats::DirectLightKind::Directional,
                    position: [0.0; 3],
                    direction,
                    strength,
                    extra: [0.0; 3],
                });
            }
        }
    }

    /// Where a light node points: its local −z in the world, or `None` (with a warning) when
    /// the transform flattens it.
    fn forward(&mut self, world: &DMat4, name: &str) -> Option<[f64; 3]> {
        let d = world.transform_vector3(DVec3::NEG_Z);
        if d.length() > 0.0 && d.is_finite() {
            return Some(d.normalize().to_array());
        }
        self.scene.warnings.push(format!(
            "{}: light '{name}': its node's transform has no direction; skipped",
            self.origin
        ));
        None
    }

    /// The scene material of a glTF material (made on first use).
    fn material(&mut self, m: &gltf::Material) -> Result<usize> {
        if let Some(&id) = self.materials.get(&m.index()) {
            return Ok(id);
        }
        let Some(index) = m.index() else {
            self.scene.warnings.push(format!(
                "{}: primitives without a material use grey reflectance {DEFAULT_REFLECTANCE}",
                self.origin
            ));
            let id = self.scene.add_material(
                Material {
                    name: "default".into(),
                    reflectance: [DEFAULT_REFLECTANCE; 3],
                    emission: [0.0; 3],
                    optics: Optics::default(),
                    texture: None,
                },
                self.origin,
            )?;
            self.materials.insert(None, id);
            return Ok(id);
        };
        let what = named("material", index, m.name());
        let name = m
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| format!("material {index}"));
        let pbr = m.pbr_metallic_roughness();
        let factor = pbr.base_color_factor();
        let factor: [f64; 3] = [0, 1, 2].map(|i| f64::from(factor[i]));
        let mut c = factor;
        let mut base_texture = None;
        if let Some(info) = pbr.base_color_texture() {
            // KHR_texture_transform: an affine map of the coordinates, and maybe another set.
            let moved = info.texture_transform();
            let set = moved
                .as_ref()
                .and_then(|t| t.tex_coord())
                .unwrap_or(info.tex_coord()) as usize;
            let transform = moved.map_or(UvTransform::IDENTITY, |t| {
                let f = |v: [f32; 2]| v.map(f64::from);
                UvTransform::khr(f(t.offset()), f64::from(t.rotation()), f(t.scale()))
            });
            if transform.0.iter().flatten().any(|x| !x.is_finite()) {
                return Err(self.err(format!(
                    "{what}: its baseColor texture's KHR_texture_transform is not finite \
                     ({:?})",
                    transform.0
                )));
            }
            let avg = if set < 2 {
                self.texture(&info.texture(), &what).map(|texture| {
                    base_texture = Some((texture, set, transform));
                    self.scene.textures[texture].average()
                })
            } else {
                self.scene.warnings.push(format!(
                    "{}: {what}: its baseColor texture uses TEXCOORD_{set}; lrr reads sets 0 and \
                     1, so the texture's mean over the image is used",
                    self.origin
                ));
                self.decode(&info.texture(), &what, false)
                    .map(|t| t.average())
            };
            match avg {
                Ok(avg) => c = [0, 1, 2].map(|i| c[i] * avg[i]),
                Err(e) => self.texture_left_out(e, "baseColorFactor")?,
            }
        }
        let clamp01 = |x: f32| f64::from(x).clamp(0.0, 1.0);
        let metal = clamp01(pbr.metallic_factor());
        let rough = clamp01(pbr.roughness_factor());
        let trans = m
            .transmission()
            .map(|t| clamp01(t.transmission_factor()))
            .unwrap_or(0.0);
        for (label, tex) in [
            (
                "metallicRoughness",
                pbr.metallic_roughness_texture().is_some(),
            ),
            (
                "transmission",
                m.transmission()
                    .and_then(|t| t.transmission_texture())
                    .is_some(),
            ),
        ] {
            if tex {
                self.scene.warnings.push(format!(
                    "{}: {what}: its {label} texture is ignored (the factor is used)",
                    self.origin
                ));
            }
        }
        let diffuse_share = (1.0 - metal) * (1.0 - trans) + metal * rough;
        let reflectance = clamp_reflectance(
            c.map(|c| c * diffuse_share),
            &format!("{}: {what}", self.origin),
            &mut self.scene.warnings,
        );
        let texture = base_texture.map(|(texture, set, transform)| TextureBinding {
            texture,
            set,
            scale: factor.map(|f| f * diffuse_share),
            transform,
        });
        let strength = m.emissive_strength().map(f64::from).unwrap_or(1.0);
        let mut radiance = m.emissive_factor().map(|e| f64::from(e) * strength);
        if let Some(info) = m.emissive_texture()
            && radiance.iter().any(|r| *r != 0.0)
        {
            // Emission is per material: only the mean is kept, not the image.
            match self.decode(&info.texture(), &what, false) {
                Ok(t) => {
                    let avg = t.average();
                    radiance = [0, 1, 2].map(|i| radiance[i] * avg[i]);
                }
                Err(e) => self.texture_left_out(e, "emissiveFactor")?,
            }
        }
        let transmission = c.map(|c| c * (1.0 - metal) * trans);
        let ior = match m.ior() {
            Some(i) => f64::from(i),
            None if trans > 0.0 => 1.5,
            None => 1.0,
        };
        let optics = Optics {
            mirror: c.map(|c| (c * metal * (1.0 - rough)).min(1.0)),
            transmission: transmission.map(|t| t.min(1.0)),
            ior: if ior.is_finite() && ior >= 1.0 {
                ior
            } else {
                1.0
            },
            ..Optics::default()
        };
        if m.double_sided() {
            self.scene.warnings.push(format!(
                "{}: {what} is double-sided; lrr imports the front side only (counter-clockwise)",
                self.origin
            ));
        }
        let material = Material {
            name,
            reflectance,
            emission: radiance.map(|l| l * std::f64::consts::PI),
            optics,
            texture,
        };
        let id = self
            .scene
            .add_material(material, &format!("{}: {what}", self.origin))?;
        self.materials.insert(Some(index), id);
        Ok(id)
    }

    /// Warns that a texture that could not be read or decoded (`e` says which and why) is left
    /// out, the material's `factor` standing alone: a lighting bake needs the texture's colour,
    /// not its presence, and a scene with one missing image still bakes. An image too large
    /// for the memory (`Error::Limits`) is refused instead: leaving it out would bake other
    /// colours than the file's without being asked to.
    fn texture_left_out(&mut self, e: Error, factor: &str) -> Result<()> {
        if let Error::Limits(_) = e {
            return Err(e);
        }
        self.scene.warnings.push(format!(
            "{e}; the texture is left out and the material's {factor} used alone (put the \
             image next to the glTF, or convert it to PNG or JPEG)"
        ));
        Ok(())
    }

    /// A base colour texture in `Scene::textures` (decoded once per glTF texture).
    fn texture(&mut self, texture: &gltf::Texture, user: &str) -> Result<usize> {
        if let Some(&id) = self.textures.get(&texture.index()) {
            return Ok(id);
        }
        let decoded = self.decode(texture, user, true)?;
        self.scene.textures.push(decoded);
        let id = self.scene.textures.len() - 1;
        self.textures.insert(texture.index(), id);
        Ok(id)
    }

    /// A texture's image decoded, with its sampler's wrap modes; planned first, and counted
    /// as kept when it is (not when only its mean is wanted).
    fn decode(&mut self, texture: &gltf::Texture, user: &str, kept: bool) -> Result<Texture> {
        let index = texture.source().index();
        let image = &self.doc.as_json().images[index];
        let what = format!("{user}: image {index}");
        let encoded: Vec<u8> = match (&image.buffer_view, &image.uri) {
            (Some(view), _) => {
                let view = self
                    .doc
                    .views()
                    .nth(view.value())
                    .expect("validated view index");
                self.view_bytes(&view, &what)?.to_vec()
            }
            (None, Some(uri)) => self.uri_bytes(uri, &what)?,
            (None, None) => {
                return Err(self.err(format!("{what} has neither a bufferView nor a uri")));
            }
        };
        let wrap = |mode: gltf::texture::WrappingMode| match mode {
            gltf::texture::WrappingMode::ClampToEdge => Wrap::Clamp,
            gltf::texture::WrappingMode::MirroredRepeat => Wrap::Mirror,
            gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        };
        let image_name = format!("{}: {what}", self.origin);
        self.budget.room_for(&encoded, &image_name, kept)?;
        let sampler = texture.sampler();
        let name = image
            .name
            .clone()
            .unwrap_or_else(|| format!("image {index}"));
        texture::decode(
            &encoded,
            name,
            [wrap(sampler.wrap_s()), wrap(sampler.wrap_t())],
        )
        .map_err(|e| self.err(format!("{what}{e}")))
    }

    /// The bytes of a buffer view, checked against its buffer.
    fn view_bytes(&self, view: &gltf::buffer::View, what: &str) -> Result<&[u8]> {
        let buffer = &self.buffers[&view.buffer().index()];
        let declared = view.buffer().length();
        view.offset()
            .checked_add(view.length())
            .filter(|&end| end <= declared)
            .map(|end| &buffer[view.offset()..end])
            .ok_or_else(|| {
                self.err(format!(
                    "{what}: bufferView {} (bytes {}..+{}) runs past the end of buffer {} ({} bytes)",
                    view.index(),
                    view.offset(),
                    view.length(),
                    view.buffer().index(),
                    declared
                ))
            })
    }

    /// The raw elements of an accessor, `count` × `size` bytes packed (sparse values applied).
    fn elements(&self, a: &gltf::Accessor, what: &str, size: usize) -> Result<Vec<u8>> {
        let view = a.view().ok_or_else(|| {
            self.err(format!(
                "{what}: it has no bufferView (all zeros); lrr needs real vertex data"
            ))
        })?;
        let data = self.view_bytes(&view, what)?;
        let stride = view.stride().unwrap_or(size);
        if stride < size {
            return Err(self.err(format!(
                "{what}: byteStride {stride} is smaller than an element ({size} bytes)"
            )));
        }
        let count = a.count();
        let end = if count == 0 {
            Some(a.offset())
        } else {
            (count - 1)
                .checked_mul(stride)
                .and_then(|x| x.checked_add(a.offset()))
                .and_then(|x| x.checked_add(size))
        };
        if end.is_none_or(|e| e > data.len()) {
            return Err(self.err(format!(
                "{what}: {count} elements of {size} bytes (stride {stride}, offset {}) do not \
                 fit in bufferView {} of {} bytes",
                a.offset(),
                view.index(),
                data.len()
            )));
        }
        let mut out = Vec::with_capacity(count * size);
        for i in 0..count {
            let at = a.offset() + i * stride;
            out.extend_from_slice(&data[at..at + size]);
        }
        if let Some(sparse) = a.sparse() {
            let n = sparse.count();
            let iv = sparse.indices().view();
            let ibytes = self.view_bytes(&iv, what)?;
            let isize = match sparse.indices().index_type() {
                gltf::accessor::sparse::IndexType::U8 => 1,
                gltf::accessor::sparse::IndexType::U16 => 2,
                gltf::accessor::sparse::IndexType::U32 => 4,
            };
            let vv = sparse.values().view();
            let vbytes = self.view_bytes(&vv, what)?;
            let fits = |bytes: &[u8], offset: usize, each: usize| {
                n.checked_mul(each)
                    .and_then(|x| x.checked_add(offset))
                    .is_some_and(|e| e <= bytes.len())
            };
            if !fits(ibytes, sparse.indices().offset(), isize)
                || !fits(vbytes, sparse.values().offset(), size)
            {
                return Err(self.err(format!(
                    "{what}: its {n} sparse indices or values do not fit in their bufferViews"
                )));
            }
            for k in 0..n {
                let at = sparse.indices().offset() + k * isize;
                let mut word = [0u8; 4];
                word[..isize].copy_from_slice(&ibytes[at..at + isize]);
                let target = u32::from_le_bytes(word) as usize;
                let Some(slot) = out.get_mut(target * size..(target + 1) * size) else {
                    return Err(self.err(format!(
                        "{what}: sparse index {target} is out of range ({count} elements)"
                    )));
                };
                let v = sparse.values().offset() + k * size;
                slot.copy_from_slice(&vbytes[v..v + size]);
            }
        }
        Ok(out)
    }

    fn read_positions(&self, a: &gltf::Accessor, primitive: &str) -> Result<Vec<DVec3>> {
        let what = format!(
            "{primitive}: POSITION {}",
            named("accessor", a.index(), a.name())
        );
        let values: Vec<[f64; 3]> = self.vectors(a, &what, "positions", None)?;
        (values.into_iter().enumerate())
            .map(|(i, v)| {
                let p = DVec3::from_array(v);
                if p.is_finite() {
                    Ok(p)
                } else {
                    Err(self.err(format!("{what}: position {i} is {p}, not finite")))
                }
            })
            .collect()
    }

    /// A `TEXCOORD_n` accessor: VEC2 of FLOAT, or of (normalized or not) BYTE, UNSIGNED_BYTE,
    /// SHORT or UNSIGNED_SHORT (core glTF allows the normalized unsigned ones,
    /// `KHR_mesh_quantization` the others), one per vertex, finite.
    fn read_texcoords(
        &self,
        a: &gltf::Accessor,
        primitive: &str,
        set: usize,
        vertices: usize,
    ) -> Result<Vec<[f64; 2]>> {
        let what = format!(
            "{primitive}: TEXCOORD_{set} {}",
            named("accessor", a.index(), a.name())
        );
        let values: Vec<[f64; 2]> =
            self.vectors(a, &what, "texture coordinates", Some(vertices))?;
        (values.into_iter().enumerate())
            .map(|(i, uv)| {
                if uv.iter().all(|x| x.is_finite()) {
                    Ok(uv)
                } else {
                    Err(self.err(format!("{what}: coordinate {i} is {uv:?}, not finite")))
                }
            })
            .collect()
    }

    /// The `N`-vectors of a vertex attribute (`kind` names it in errors): VEC`N` of FLOAT or of
    /// an 8- or 16-bit integer ([`component`]), `count` of them when given.
    fn vectors<const N: usize>(
        &self,
        a: &gltf::Accessor,
        what: &str,
        kind: &str,
        count: Option<usize>,
    ) -> Result<Vec<[f64; N]>> {
        let size = match (a.dimensions().multiplicity(), component_size(a.data_type())) {
            (m, Some(size)) if m == N => size,
            _ => {
                return Err(self.err(format!(
                    "{what} is {:?} of {:?}; {kind} must be VEC{N} of FLOAT, or of BYTE, \
                     UNSIGNED_BYTE, SHORT or UNSIGNED_SHORT (KHR_mesh_quantization)",
                    a.dimensions(),
                    a.data_type()
                )));
            }
        };
        if let Some(vertices) = count.filter(|&c| c != a.count()) {
            return Err(self.err(format!(
                "{what} has {} elements for {vertices} positions; every attribute needs one per \
                 vertex",
                a.count()
            )));
        }
        let (ty, normalized) = (a.data_type(), a.normalized());
        let raw = self.elements(a, what, N * size)?;
        Ok(raw
            .chunks_exact(N * size)
            .map(|e| {
                std::array::from_fn(|k| component(&e[k * size..(k + 1) * size], ty, normalized))
            })
            .collect())
    }

    fn read_indices(
        &self,
        a: &gltf::Accessor,
        primitive: &str,
        vertices: usize,
    ) -> Result<Vec<u32>> {
        let what = format!(
            "{primitive}: indices {}",
            named("accessor", a.index(), a.name())
        );
        use gltf::accessor::DataType;
        let size = match (a.dimensions(), a.data_type()) {
            (gltf::accessor::Dimensions::Scalar, DataType::U8) => 1,
            (gltf::accessor::Dimensions::Scalar, DataType::U16) => 2,
            (gltf::accessor::Dimensions::Scalar, DataType::U32) => 4,
            (d, t) => {
                return Err(self.err(format!(
                    "{what} is {d:?} of {t:?}; indices must be SCALAR of UNSIGNED_BYTE, \
                     UNSIGNED_SHORT or UNSIGNED_INT"
                )));
            }
        };
        let raw = self.elements(a, &what, size)?;
        raw.chunks_exact(size)
            .enumerate()
            .map(|(i, e)| {
                let mut word = [0u8; 4];
                word[..size].copy_from_slice(e);
                let v = u32::from_le_bytes(word);
                if (v as usize) < vertices {
                    Ok(v)
                } else {
                    Err(self.err(format!(
                        "{what}: index {i} is {v}, out of range for {vertices} vertices"
                    )))
                }
            })
            .collect()
    }
}

/// Bytes of one component of a vertex attribute lrr reads (FLOAT, and the integer types of
/// `KHR_mesh_quantization`); None for UNSIGNED_INT, which no attribute may use.
fn component_size(ty: gltf::accessor::DataType) -> Option<usize> {
    use gltf::accessor::DataType;
    match ty {
        DataType::F32 => Some(4),
        DataType::I16 | DataType::U16 => Some(2),
        DataType::I8 | DataType::U8 => Some(1),
        DataType::U32 => None,
    }
}

/// One component (little-endian `bytes`, [`component_size`] long): a FLOAT as it is; an
/// integer as its value, or normalized as glTF defines it (unsigned `c / (2ᵇ − 1)`, signed
/// `max(c / (2ᵇ⁻¹ − 1), −1)`).
fn component(bytes: &[u8], ty: gltf::accessor::DataType, normalized: bool) -> f64 {
    use gltf::accessor::DataType;
    let (value, scale) = match ty {
        DataType::F32 => return f64::from(f32::from_le_bytes(bytes.try_into().unwrap())),
        DataType::I8 => (f64::from(bytes[0] as i8), 127.0),
        DataType::U8 => (f64::from(bytes[0]), 255.0),
        DataType::I16 => (f64::from(i16::from_le_bytes([bytes[0], bytes[1]])), 32767.0),
        DataType::U16 => (f64::from(u16::from_le_bytes([bytes[0], bytes[1]])), 65535.0),
        DataType::U32 => (
            f64::from(u32::from_le_bytes(bytes.try_into().unwrap())),
            1.0,
        ),
    };
    if normalized {
        (value / scale).max(-1.0)
    } else {
        value
    }
}

/// The triangles of a primitive's index list, counter-clockwise as glTF defines them.
fn triangles(mode: gltf::mesh::Mode, idx: &[u32]) -> Vec<[u32; 3]> {
    use gltf::mesh::Mode;
    match mode {
        Mode::Triangles => idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
        Mode::TriangleStrip => (0..idx.len().saturating_sub(2))
            .map(|i| {
                if i % 2 == 0 {
                    [idx[i], idx[i + 1], idx[i + 2]]
                } else {
                    [idx[i + 1], idx[i], idx[i + 2]]
                }
            })
            .collect(),
        Mode::TriangleFan => (1..idx.len().saturating_sub(1))
            .map(|i| [idx[i], idx[i + 1], idx[0]])
            .collect(),
        _ => Vec::new(),
    }
}

/// `%XX` escapes of a URI decoded; None on a bad escape or non-UTF-8 result.
fn percent_decode(uri: &str) -> Option<String> {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = std::str::from_utf8(b.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}
