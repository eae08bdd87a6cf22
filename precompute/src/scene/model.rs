//! The scene model: materials, faces (planar convex polygons of 3 or 4 vertices, one-sided)
//! and named surfaces, built face by face by the importers.

use rustc_hash::FxHashMap;

use glam::DVec3;

use super::polygon;
use super::texture::{self, Texture, TextureBinding, UvMap, UvTransform};
use crate::error::{Error, Result};
use crate::geometry::Polygon;

/// A Lambertian material. `emission` is emitted *exitance* `E = π · Ke` (Ke: MTL radiance).
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// Material name (from the MTL or the description).
    pub name: String,
    /// RGB reflectance ρ (Kd), each in [0, 1).
    pub reflectance: [f64; 3],
    /// RGB emitted exitance `E = π·Ke` (W/m² style).
    pub emission: [f64; 3],
    /// What a ray tracer adds beyond the diffuse term (none for the radiosity itself).
    pub optics: Optics,
    /// A base colour texture: the reflectance then varies over the surface (each element
    /// takes the texture's mean over its area); `reflectance` is the mean over the image.
    pub texture: Option<TextureBinding>,
}

/// The non-diffuse part of a material, for the ray tracer (MTL `Ks`/`Ns`/`illum`/`Ni`/`Tf`/`d`,
/// glTF metallic and transmission, description overrides). Default: purely diffuse.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Optics {
    /// Phong highlight colour `Ks`, each in [0, 1].
    pub specular: [f64; 3],
    /// Phong exponent `Ns`, >= 0.
    pub shininess: f64,
    /// Perfect-mirror reflectance, each in [0, 1].
    pub mirror: [f64; 3],
    /// Transmission filter (glass), each in [0, 1].
    pub transmission: [f64; 3],
    /// Index of refraction, >= 1.
    pub ior: f64,
}

impl Default for Optics {
    fn default() -> Self {
        Self {
            specular: [0.0; 3],
            shininess: 0.0,
            mirror: [0.0; 3],
            transmission: [0.0; 3],
            ior: 1.0,
        }
    }
}

/// A point light of the scene (description, glTF `KHR_lights_punctual`): highlights and shadow
/// rays in the ray tracer only.
#[derive(Debug, Clone, PartialEq)]
pub struct PointLight {
    /// Name.
    pub name: String,
    /// Position in scene units.
    pub position: [f64; 3],
    /// Radiant intensity per channel.
    pub intensity: [f64; 3],
    /// The light group (a material or surface name of an emitter) whose intensity it follows.
    pub group: Option<String>,
}

/// A light that is neither a surface nor a point light (description, glTF
/// `KHR_lights_punctual`): a spot, a directional light or the sky. The runtime's direct pass
/// lights the elements with it every frame (DESIGN.md §9); the fields mean what
/// `lrr_formats::DirectLight`'s table says for its kind (scene units, f64 here).
#[derive(Debug, Clone, PartialEq)]
pub struct DirectLight {
    /// Name.
    pub name: String,
    /// Spot, directional, uniform or gradient sky.
    pub kind: lrr_formats::DirectLightKind,
    /// Spot: position.
    pub position: [f64; 3],
    /// Spot: where it points; directional: where its light travels; gradient sky: up.
    pub direction: [f64; 3],
    /// Spot: W/sr on the axis; directional: W/m² facing it; sky: (zenith) radiance.
    pub strength: [f64; 3],
    /// Spot: `[inner, outer, 0]` half-angles in radians; gradient sky: horizon radiance.
    pub extra: [f64; 3],
}

/// A pinhole camera of the scene (description, glTF).
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    /// Name.
    pub name: String,
    /// Eye position.
    pub eye: [f64; 3],
    /// Point looked at.
    pub target: [f64; 3],
    /// Up direction.
    pub up: [f64; 3],
    /// Vertical field of view in degrees.
    pub fov_y_deg: f64,
}

impl Material {
    /// Checks the reflectance is in [0, 1) and the emission is finite and non-negative.
    pub(crate) fn validate(&self, location: &str) -> Result<()> {
        for (c, &r) in self.reflectance.iter().enumerate() {
            if !r.is_finite() || r < 0.0 {
                return Err(Error::scene(
                    location,
                    format!(
                        "material '{}': reflectance channel {c} is {r}; reflectance must be in [0, 1)",
                        self.name
                    ),
                ));
            }
            if r >= 1.0 {
                return Err(Error::scene(
                    location,
                    format!(
                        "material '{}': reflectance channel {c} is {r}; a reflectance of 1 or more \
                         never lets light decay (the radiosity system of a closed scene is singular); \
                         use a value below 1, e.g. 0.999",
                        self.name
                    ),
                ));
            }
        }
        for (c, &e) in self.emission.iter().enumerate() {
            if !e.is_finite() || e < 0.0 {
                return Err(Error::scene(
                    location,
                    format!(
                        "material '{}': emission channel {c} is {e}; emission must be finite and >= 0",
                        self.name
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// Largest reflectance an element takes from a texture (a reflectance of 1 makes a closed
/// scene's radiosity system singular); the glTF and OBJ importers clamp whole materials
/// likewise ([`clamp_reflectance`]).
pub const MAX_TEXTURED_REFLECTANCE: f64 = 0.99;

/// `rho` with each channel at most [`MAX_TEXTURED_REFLECTANCE`], and a warning naming `what`
/// (where the value comes from) when it was over.
pub(crate) fn clamp_reflectance(rho: [f64; 3], what: &str, warnings: &mut Vec<String>) -> [f64; 3] {
    if rho.iter().all(|&r| r <= MAX_TEXTURED_REFLECTANCE) {
        return rho;
    }
    warnings.push(format!(
        "{what}: diffuse reflectance {rho:.3?} clamped to {MAX_TEXTURED_REFLECTANCE} (a \
         reflectance of 1 never lets light decay)"
    ));
    rho.map(|r| r.min(MAX_TEXTURED_REFLECTANCE))
}

/// One planar convex face of the scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Face {
    /// The face's planar convex polygon, in scene units.
    pub polygon: Polygon,
    /// Index into `Scene::materials`.
    pub material: usize,
    /// Index into `Scene::surfaces`.
    pub surface: usize,
    /// Texture coordinates of the face's plane, per set (`TEXCOORD_0`, `TEXCOORD_1`), where
    /// the import had them.
    pub uv: [Option<UvMap>; 2],
}

/// Mesh sizes a scene description may suggest (absolute lengths in scene units).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SizeHints {
    /// Suggested longest edge of a fine element (scene units).
    pub element_size: Option<f64>,
    /// Suggested longest edge of a coarse patch (scene units).
    pub patch_size: Option<f64>,
}

/// Bake settings a scene description's `[bake]` table asks for (explicit command-line flags win
/// over them). Checked when the description is built: `method` is `2mf` or `2msc`, `precision`
/// `f32` or `f16`, `layout` `factored` or `plain`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BakeDefaults {
    /// Patch method: `2mf` or `2msc`.
    pub method: Option<String>,
    /// 2MSC threshold.
    pub threshold: Option<f64>,
    /// 2MSC smallest patch area (scene units², after `scale`).
    pub min_patch_area: Option<f64>,
    /// Quadrature points per element-patch pair.
    pub samples: Option<u32>,
    /// Stored precision: `f32` or `f16`.
    pub precision: Option<String>,
    /// Operator layout: `factored` or `plain`.
    pub layout: Option<String>,
    /// Operator file to write (resolved against the description's folder).
    pub output: Option<std::path::PathBuf>,
    /// Texels per scene unit of the lightmap charts the bake packs (after `scale`); `None`:
    /// the largest density that fits the default atlas.
    pub lightmap_texel_density: Option<f64>,
    /// Rings of texels dilated around the lightmap's charts.
    pub lightmap_padding: Option<u32>,
    /// `false`: no lightmap coordinates in the file (a file for evaluation only, smaller by
    /// 32 bytes per display face).
    pub lightmap: Option<bool>,
}

/// What the import repaired, counted (the warnings name each case).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Repairs {
    /// Faces (or pieces of split polygons) with no area, dropped.
    pub degenerate: usize,
    /// Faces duplicating another (same vertices, same side), dropped.
    pub duplicates: usize,
    /// Polygons not planar within 1e-6 of their longest edge, split into triangles.
    pub non_planar: usize,
    /// Largest distance of a vertex of such a polygon from its mean plane, relative to the
    /// polygon's longest edge.
    pub max_deviation: f64,
}

impl Repairs {
    pub(crate) fn add(&mut self, other: &Repairs) {
        self.degenerate += other.degenerate;
        self.duplicates += other.duplicates;
        self.non_planar += other.non_planar;
        self.max_deviation = self.max_deviation.max(other.max_deviation);
    }
}

/// An imported scene: materials, named surfaces and their planar convex faces.
#[derive(Debug, Clone, Default)]
pub struct Scene {
    /// Scene name (file metadata).
    pub name: String,
    /// Materials, indexed by `Face::material`.
    pub materials: Vec<Material>,
    /// Surface names (OBJ objects/groups, description surfaces and box faces), indexed by `Face::surface`.
    pub surfaces: Vec<String>,
    /// The faces the mesher subdivides.
    pub faces: Vec<Face>,
    /// Non-fatal problems found while importing (each names file and line).
    pub warnings: Vec<String>,
    /// Mesh sizes the scene description suggests (explicit flags win over them).
    pub hints: SizeHints,
    /// Counts of the import's repairs (each also has a warning).
    pub repairs: Repairs,
    /// Point lights for the ray tracer.
    pub point_lights: Vec<PointLight>,
    /// Spot and directional lights and the sky.
    pub direct_lights: Vec<DirectLight>,
    /// Cameras.
    pub cameras: Vec<Camera>,
    /// Bake settings of the scene description (`[bake]`).
    pub bake: BakeDefaults,
    /// Base colour textures, indexed by `TextureBinding::texture`.
    pub textures: Vec<Texture>,
    /// Exact-duplicate detection: sorted quantised vertices → face index.
    seen: FxHashMap<Vec<[i64; 3]>, usize>,
    /// Each name's index in `surfaces`, as [`surface`](Self::surface) added them (a scene of
    /// 10 000 named boxes searched its names one by one for each face: 14 s of its import).
    surface_ids: FxHashMap<String, usize>,
}

impl Scene {
    pub(crate) fn new(name: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            ..Self::default()
        }
    }

    /// Index of a surface, added if new.
    pub(crate) fn surface(&mut self, name: &str) -> usize {
        // `surfaces` is public: where names were pushed other than here or by
        // `set_surfaces`, index it again. Its names are distinct, so the index holds one
        // entry a name.
        let stale = self.surface_ids.len() != self.surfaces.len()
            || (self.surface_ids.get(name))
                .is_some_and(|&i| self.surfaces.get(i).is_none_or(|s| s != name));
        if stale {
            self.index_surfaces();
        }
        if let Some(&i) = self.surface_ids.get(name) {
            return i;
        }
        self.surfaces.push(name.to_string());
        let i = self.surfaces.len() - 1;
        self.surface_ids.insert(name.to_string(), i);
        i
    }

    /// Replaces the surface names (faces' `surface` ids are the caller's to renumber).
    pub(crate) fn set_surfaces(&mut self, names: Vec<String>) {
        self.surfaces = names;
        self.index_surfaces();
    }

    /// Indexes `surfaces` anew (`surface_ids`).
    fn index_surfaces(&mut self) {
        self.surface_ids = (self.surfaces.iter().enumerate())
            .map(|(i, s)| (s.clone(), i))
            .collect();
    }

    /// Adds a material (validated); `location` names where it was defined.
    pub(crate) fn add_material(&mut self, material: Material, location: &str) -> Result<usize> {
        material.validate(location)?;
        self.materials.push(material);
        Ok(self.materials.len() - 1)
    }

    /// Adds a polygon (any vertex count, counter-clockwise front), splitting it into planar
    /// convex pieces of 3 or 4 vertices. Non-finite coordinates are an error; degenerate and
    /// duplicate faces are dropped with a warning.
    pub(crate) fn add_polygon(
        &mut self,
        vertices: &[DVec3],
        material: usize,
        surface: usize,
        location: &str,
    ) -> Result<()> {
        self.add_polygon_uv(vertices, material, surface, [None, None], location)
    }

    /// [`Scene::add_polygon`] with texture coordinates (an affine map per set, shared by the
    /// pieces a polygon is split into).
    pub(crate) fn add_polygon_uv(
        &mut self,
        vertices: &[DVec3],
        material: usize,
        surface: usize,
        uv: [Option<UvMap>; 2],
        location: &str,
    ) -> Result<()> {
        if let Some(bad) = vertices.iter().find(|v| !v.is_finite()) {
            return Err(Error::scene(
                location,
                format!("vertex coordinates must be finite numbers, found {bad}"),
            ));
        }
        let pieces = match polygon::split_convex(vertices) {
            Some(p) => p,
            None => {
                self.repairs.degenerate += 1;
                self.warnings.push(format!(
                    "{location}: degenerate face (zero area or fewer than 3 distinct vertices) dropped"
                ));
                return Ok(());
            }
        };
        if let Some((off, edge)) = polygon::non_planar(vertices) {
            self.repairs.non_planar += 1;
            self.repairs.max_deviation = self.repairs.max_deviation.max(off / edge);
            self.warnings.push(format!(
                "{location}: non-planar polygon of {} vertices (a vertex lies {off:.3e} off its mean \
                 plane, {:.2}% of its longest edge) split into {} triangles along its shortest \
                 diagonals that keep them front-facing",
                vertices.len(),
                100.0 * off / edge,
                pieces.len()
            ));
        }
        for piece in pieces {
            let Some(polygon) = Polygon::new(&piece) else {
                self.repairs.degenerate += 1;
                self.warnings
                    .push(format!("{location}: degenerate face piece dropped"));
                continue;
            };
            let key = polygon::duplicate_key(&polygon);
            if let Some(&other) = self.seen.get(&key) {
                self.repairs.duplicates += 1;
                self.warnings.push(format!(
                    "{location}: face duplicates face #{other} (same vertices, same side) and was dropped"
                ));
                continue;
            }
            self.seen.insert(key, self.faces.len());
            self.faces.push(Face {
                polygon,
                material,
                surface,
                uv,
            });
        }
        Ok(())
    }

    /// Axis-aligned bounding box of all faces.
    pub(crate) fn bounds(&self) -> (DVec3, DVec3) {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for f in &self.faces {
            for v in f.polygon.vertices() {
                lo = lo.min(*v);
                hi = hi.max(*v);
            }
        }
        (lo, hi)
    }

    /// Length of the bounding box diagonal: the scale all default sizes are relative to.
    pub fn extent(&self) -> f64 {
        let (lo, hi) = self.bounds();
        (hi - lo).length()
    }

    /// Checks the scene can be baked: at least one face, materials valid.
    pub(crate) fn validate(&self, location: &str) -> Result<()> {
        if self.faces.is_empty() {
            return Err(Error::scene(
                location,
                "the scene has no faces (nothing to bake); check the file holds 'f' lines or polygons",
            ));
        }
        Ok(())
    }

    /// Multiplies every coordinate by `s` (for scale tests and unit conversion).
    pub fn scale(&mut self, s: f64) {
        for f in &mut self.faces {
            let v: Vec<DVec3> = f.polygon.vertices().iter().map(|v| *v * s).collect();
            f.polygon = Polygon::new(&v).expect("scaling keeps a valid polygon valid");
            f.uv = f.uv.map(|m| m.map(|m| m.scaled(s)));
        }
        if let Some(e) = &mut self.hints.element_size {
            *e *= s;
        }
        if let Some(p) = &mut self.hints.patch_size {
            *p *= s;
        }
    }

    /// True when every reflectance is grey (r = g = b), textures included: the bake then
    /// needs one channel.
    pub(crate) fn is_grey(&self) -> bool {
        let grey = |r: [f64; 3]| r[0] == r[1] && r[1] == r[2];
        // Each texture's texels are scanned once, not once per face that uses it.
        let mut grey_texture: Vec<Option<bool>> = vec![None; self.textures.len()];
        for f in &self.faces {
            if !grey(self.materials[f.material].reflectance) {
                return false;
            }
            if let Some((t, _)) = self.texture_of(f) {
                let texels = *grey_texture[t.texture]
                    .get_or_insert_with(|| self.textures[t.texture].is_grey());
                if !(grey(t.scale) && texels) {
                    return false;
                }
            }
        }
        true
    }

    /// A warning when some faces but not all have lightmap coordinates (`TEXCOORD_1`): the
    /// file then stores none of them and the bake packs lightmap charts of its own.
    pub(crate) fn partial_lightmap_warning(&self) -> Option<String> {
        let with = self.faces.iter().filter(|f| f.uv[1].is_some()).count();
        if with == 0 || with == self.faces.len() {
            return None;
        }
        let mut missing: Vec<&str> = self
            .faces
            .iter()
            .filter(|f| f.uv[1].is_none())
            .map(|f| self.surfaces[f.surface].as_str())
            .collect();
        missing.dedup();
        missing.truncate(5);
        Some(format!(
            "{with} of {} faces have lightmap coordinates (TEXCOORD_1), so the bake keeps none \
             and packs lightmap charts of its own; surfaces without them include {missing:?}",
            self.faces.len()
        ))
    }

    /// The texture binding that applies to a face and the face's coordinates for it: its
    /// material's, when the face has the coordinate set it names.
    fn texture_of<'a>(&'a self, face: &'a Face) -> Option<(&'a TextureBinding, &'a UvMap)> {
        let t = self.materials[face.material].texture.as_ref()?;
        Some((t, face.uv.get(t.set)?.as_ref()?))
    }

    /// The diffuse reflectance of `polygon`, a piece of face `face` (an element): the
    /// material's, or with a base colour texture the texture's mean over the piece times the
    /// binding's scale, each channel at most [`MAX_TEXTURED_REFLECTANCE`].
    pub fn reflectance_over(&self, face: usize, polygon: &Polygon, lut: &[f64; 256]) -> [f64; 3] {
        let f = &self.faces[face];
        let m = &self.materials[f.material];
        let Some((t, map)) = self.texture_of(f) else {
            return m.reflectance;
        };
        let moved;
        let map = if t.transform == UvTransform::IDENTITY {
            map
        } else {
            moved = map.then(&t.transform);
            &moved
        };
        let mean = texture::element_average(&self.textures[t.texture], lut, map, polygon);
        [0, 1, 2].map(|c| (t.scale[c] * mean[c]).min(MAX_TEXTURED_REFLECTANCE))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Names are found through the index, also after the list was replaced (as the light
    /// groups drop surfaces left without faces) or pushed to directly.
    #[test]
    fn surface_names_are_found_after_the_list_changes() {
        let mut s = Scene::default();
        assert_eq!((s.surface("a"), s.surface("b"), s.surface("a")), (0, 1, 0));
        s.set_surfaces(vec!["b".into()]);
        assert_eq!((s.surface("b"), s.surface("a")), (0, 1));
        // As many other names: the index follows.
        s.set_surfaces(vec!["x".into(), "y".into()]);
        assert_eq!((s.surface("y"), s.surface("a")), (1, 2));
        s.surfaces.push("z".into());
        assert_eq!((s.surface("z"), s.surface("x"), s.surface("c")), (3, 0, 4));
        assert_eq!(s.surfaces, ["x", "y", "a", "z", "c"]);
    }
}
