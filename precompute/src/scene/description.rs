//! The lrr scene description: a TOML file of materials, polygon surfaces, boxes, OBJ and glTF
//! includes, material overrides, light groups, cameras, point lights and bake settings, so that
//! `lrr bake scene.toml` is a reproducible build step. Unknown keys are errors naming them.
//!
//! ```toml
//! name = "two squares"
//! scale = 1.0                       # optional: multiplies every coordinate
//! [mesh]                            # optional size hints, in scene units (before `scale`)
//! element_size = 0.1
//! patch_size = 0.25
//! [[material]]
//! name = "grey"
//! reflectance = [0.5, 0.5, 0.5]     # Kd, each in [0, 1)
//! radiance = [0.0, 0.0, 0.0]        # Ke; emitted exitance is π·Ke
//! mirror = [0.1, 0.1, 0.1]          # optional optics for the ray tracer: specular, shininess,
//!                                   # mirror, transmission, ior (default: purely diffuse)
//! [[surface]]
//! name = "bottom"
//! material = "grey"
//! polygons = [[[0,0,0],[1,0,0],[1,1,0],[0,1,0]]]   # counter-clockwise seen from the front
//! [[box]]
//! name = "room"                     # faces become surfaces "room.-x", "room.+x", …
//! material = "grey"
//! min = [0,0,0]
//! max = [1,1,1]
//! inward = true                     # normals point into the box (a room); false: a block
//! omit = ["+z"]                     # faces left out
//! [[include]]
//! obj = "model.obj"                 # relative to this file
//! [[include]]
//! gltf = "model.glb"                # .gltf or .glb
//! [[material_override]]             # any material by name, the description's or an include's
//! name = "Glass"
//! transmission = [0.9, 0.9, 0.9]    # also reflectance, radiance and the other optics
//! ior = 1.5
//! [[light_group]]                   # the emitting faces of these materials and surfaces
//! name = "ceiling"                  # (OBJ groups, glTF nodes, description surfaces) become
//! materials = ["lamp"]              # one emitting surface, hence one light group of the file
//! surfaces = ["spot.1", "spot.2"]
//! [[camera]]
//! name = "front"
//! eye = [0, 1, 4]
//! target = [0, 1, 0]
//! up = [0, 1, 0]                    # default +y
//! fov_y_deg = 40
//! [[point_light]]
//! name = "bulb"
//! position = [0, 1.9, 0]
//! intensity = [5, 5, 5]             # W/sr per channel; or colour = [..] and power = W (4π sr)
//! group = "ceiling"                 # optional: follows this light group's intensity (then a
//!                                   # highlight of that emitter; without: lights the scene)
//! [[spot_light]]                    # glTF's spot: full inside inner, falling to 0 at outer
//! name = "spot"
//! position = [0, 1.9, 0]
//! direction = [0, -1, 0]            # where it points
//! intensity = [20, 20, 20]          # W/sr on the axis
//! inner_cone_deg = 20               # default 0
//! outer_cone_deg = 30               # default 45 (glTF's π/4); inner <= outer <= 90
//! [[directional_light]]
//! name = "sun"
//! direction = [-0.3, -1, 0.2]       # the direction its light travels
//! irradiance = [3, 3, 2.5]          # W/m² (scene units) on a surface facing it
//! [sky]                             # at most one: radiance = [..] (uniform), or
//! zenith = [0.5, 0.7, 1.0]          # the radiance straight up and
//! horizon = [0.9, 0.9, 0.9]         # at and below the horizon (a gradient)
//! up = [0, 1, 0]                    # default +y
//! [bake]                            # defaults for `lrr bake`; explicit flags win
//! output = "model.lrr"              # relative to this file (then `-o` may be left out)
//! element_size = 0.1                # or in [mesh], not both
//! patch_size = 0.25
//! method = "2msc"                   # "2mf", "2msc" (default) or "2msc-split"; threshold; min_patch_area (2msc-split)
//! samples = 16
//! precision = "f16"                 # "f32" (default) or "f16"; layout = "factored" | "plain"
//! lightmap_texel_density = 32       # texels per unit of the generated lightmap charts
//! lightmap_padding = 2              # texels dilated around them (default 2); lightmap = false: none
//! ```

use std::collections::HashMap;
use std::path::Path;

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::model::{BakeDefaults, Camera, DirectLight, Material, Optics, PointLight, Scene};
use super::texture::Budget;
use crate::error::{Error, Result};

/// A parsed scene description file (the TOML above).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneDescription {
    /// Scene name; default: the file's stem.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Factor applied to every coordinate (default 1).
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub scale: f64,
    /// Optional mesh size hints (`[mesh]`).
    #[serde(default, skip_serializing_if = "MeshHints::is_empty")]
    pub mesh: MeshHints,
    /// Materials (`[[material]]`), referred to by name.
    #[serde(default, rename = "material", skip_serializing_if = "Vec::is_empty")]
    pub materials: Vec<MaterialDesc>,
    /// Explicit polygon surfaces (`[[surface]]`).
    #[serde(default, rename = "surface", skip_serializing_if = "Vec::is_empty")]
    pub surfaces: Vec<SurfaceDesc>,
    /// Axis-aligned boxes (`[[box]]`), one surface per face.
    #[serde(default, rename = "box", skip_serializing_if = "Vec::is_empty")]
    pub boxes: Vec<BoxDesc>,
    /// OBJ and glTF files merged into the scene (`[[include]]`).
    #[serde(default, rename = "include", skip_serializing_if = "Vec::is_empty")]
    pub includes: Vec<IncludeDesc>,
    /// Changes to materials by name, applied after the includes (`[[material_override]]`).
    #[serde(
        default,
        rename = "material_override",
        skip_serializing_if = "Vec::is_empty"
    )]
    pub overrides: Vec<MaterialOverride>,
    /// Light groups by material and surface name (`[[light_group]]`).
    #[serde(default, rename = "light_group", skip_serializing_if = "Vec::is_empty")]
    pub light_groups: Vec<LightGroupDesc>,
    /// Cameras (`[[camera]]`).
    #[serde(default, rename = "camera", skip_serializing_if = "Vec::is_empty")]
    pub cameras: Vec<CameraDesc>,
    /// Point lights for the ray tracer (`[[point_light]]`).
    #[serde(default, rename = "point_light", skip_serializing_if = "Vec::is_empty")]
    pub point_lights: Vec<PointLightDesc>,
    /// Spot lights (`[[spot_light]]`).
    #[serde(default, rename = "spot_light", skip_serializing_if = "Vec::is_empty")]
    pub spot_lights: Vec<SpotLightDesc>,
    /// Directional lights (`[[directional_light]]`).
    #[serde(
        default,
        rename = "directional_light",
        skip_serializing_if = "Vec::is_empty"
    )]
    pub directional_lights: Vec<DirectionalLightDesc>,
    /// The sky (`[sky]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sky: Option<SkyDesc>,
    /// Bake settings (`[bake]`).
    #[serde(default, skip_serializing_if = "BakeDesc::is_empty")]
    pub bake: BakeDesc,
}

/// Optical properties beyond the diffuse reflectance, for the ray tracer (all optional).
macro_rules! optics_fields {
    ($(#[$m:meta])* pub struct $name:ident { $($(#[$fm:meta])* pub $f:ident: $t:ty,)* }) => {
        $(#[$m])*
        pub struct $name {
            $($(#[$fm])* pub $f: $t,)*
            /// Phong highlight colour, each in [0, 1].
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub specular: Option<[f64; 3]>,
            /// Phong exponent, >= 0.
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub shininess: Option<f64>,
            /// Perfect-mirror reflectance, each in [0, 1].
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub mirror: Option<[f64; 3]>,
            /// Transmission filter (glass), each in [0, 1].
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub transmission: Option<[f64; 3]>,
            /// Index of refraction, >= 1.
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub ior: Option<f64>,
        }
        impl $name {
            /// `base` with the optics this entry sets, checked; `what` names it in errors.
            fn optics(&self, base: Optics, origin: &str, what: &str) -> Result<Optics> {
                let mut o = base;
                let unit = |name: &str, v: Option<[f64; 3]>, to: &mut [f64; 3]| -> Result<()> {
                    if let Some(v) = v {
                        if v.iter().any(|x| !(x.is_finite() && (0.0..=1.0).contains(x))) {
                            return Err(Error::scene(
                                origin,
                                format!("{what}: {name} {v:?} must be three numbers in [0, 1]"),
                            ));
                        }
                        *to = v;
                    }
                    Ok(())
                };
                unit("specular", self.specular, &mut o.specular)?;
                unit("mirror", self.mirror, &mut o.mirror)?;
                unit("transmission", self.transmission, &mut o.transmission)?;
                if let Some(n) = self.shininess {
                    if !(n.is_finite() && n >= 0.0) {
                        return Err(Error::scene(origin, format!("{what}: shininess {n} must be >= 0")));
                    }
                    o.shininess = n;
                }
                if let Some(i) = self.ior {
                    if !(i.is_finite() && i >= 1.0) {
                        return Err(Error::scene(origin, format!("{what}: ior {i} must be >= 1")));
                    }
                    o.ior = i;
                }
                Ok(o)
            }
        }
    };
}

optics_fields! {
/// A change to every material of a name (`[[material_override]]`), the description's own or an
/// included file's; unset fields keep their value.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialOverride {
    /// Name of the material(s) to change.
    pub name: String,
    /// New reflectance, each in [0, 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reflectance: Option<[f64; 3]>,
    /// New emitted radiance (exitance π·radiance).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radiance: Option<[f64; 3]>,
}
}

/// A light group (`[[light_group]]`): the emitting faces of the named materials and surfaces
/// become one emitting surface of this name, which the bake makes one light group of the file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightGroupDesc {
    /// Name of the group (and of its surface).
    pub name: String,
    /// Materials whose emitting faces join it.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub materials: Vec<String>,
    /// Surfaces (OBJ groups/objects, glTF nodes, description surfaces) whose emitting faces
    /// join it.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub surfaces: Vec<String>,
}

/// A pinhole camera (`[[camera]]`), in description units.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    /// Name.
    pub name: String,
    /// Eye position.
    pub eye: [f64; 3],
    /// Point looked at.
    pub target: [f64; 3],
    /// Up direction (default +y).
    #[serde(default = "y_up")]
    pub up: [f64; 3],
    /// Vertical field of view in degrees, in (0, 180).
    pub fov_y_deg: f64,
}

fn y_up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}

/// A point light (`[[point_light]]`): `intensity`, or `power` (W, over 4π sr) with an optional
/// `colour` (default white).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointLightDesc {
    /// Name.
    pub name: String,
    /// Position, in description units.
    pub position: [f64; 3],
    /// Radiant intensity per channel (W/sr).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub intensity: Option<[f64; 3]>,
    /// Colour the power is spread over (default white).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub colour: Option<[f64; 3]>,
    /// Emitted power (W per channel at colour 1): intensity = colour · power / 4π.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub power: Option<f64>,
    /// The light group (an emitting surface, material or `[[light_group]]`) it follows.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub group: Option<String>,
}

/// A spot light (`[[spot_light]]`): glTF's `KHR_lights_punctual` spot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpotLightDesc {
    /// Name.
    pub name: String,
    /// Position, in description units.
    pub position: [f64; 3],
    /// Where it points.
    pub direction: [f64; 3],
    /// Radiant intensity per channel on the axis (W/sr).
    pub intensity: [f64; 3],
    /// Half-angle of the full-intensity cone, degrees (default 0).
    #[serde(default)]
    pub inner_cone_deg: f64,
    /// Half-angle where the light ends, degrees (default 45).
    #[serde(default = "forty_five")]
    pub outer_cone_deg: f64,
}

fn forty_five() -> f64 {
    45.0
}

/// A directional light (`[[directional_light]]`), a sun.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DirectionalLightDesc {
    /// Name.
    pub name: String,
    /// The direction its light travels.
    pub direction: [f64; 3],
    /// Irradiance per channel (W/m², scene units) on a surface facing it.
    pub irradiance: [f64; 3],
}

/// The sky (`[sky]`): `radiance` (uniform), or `zenith` and `horizon` (a gradient about `up`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SkyDesc {
    /// Uniform radiance per channel (W/m²/sr).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radiance: Option<[f64; 3]>,
    /// Radiance straight up (a gradient sky).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub zenith: Option<[f64; 3]>,
    /// Radiance at and below the horizon (a gradient sky).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub horizon: Option<[f64; 3]>,
    /// The gradient's up (default +y).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub up: Option<[f64; 3]>,
}

/// Bake settings (`[bake]`); `lrr bake` flags given explicitly win over them.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BakeDesc {
    /// Operator file, relative to the description.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
    /// Element size (description units; not with `[mesh] element_size`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub element_size: Option<f64>,
    /// Patch size (description units; not with `[mesh] patch_size`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub patch_size: Option<f64>,
    /// `2mf` or `2msc`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub method: Option<String>,
    /// 2MSC threshold, in (0, 1].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub threshold: Option<f64>,
    /// 2MSC smallest patch area (description units²).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_patch_area: Option<f64>,
    /// Quadrature points per element-patch pair.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples: Option<u32>,
    /// `f32` or `f16`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub precision: Option<String>,
    /// `factored` or `plain`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layout: Option<String>,
    /// Texels per description unit of the lightmap charts the bake packs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lightmap_texel_density: Option<f64>,
    /// Texels of padding dilated around the lightmap's charts.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lightmap_padding: Option<u32>,
    /// `false`: the file holds no lightmap coordinates.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lightmap: Option<bool>,
}

impl BakeDesc {
    fn is_empty(&self) -> bool {
        *self == BakeDesc::default()
    }
}

/// Mesh size hints of a description (`[mesh]`), in description units before `scale`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshHints {
    /// Suggested element size.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub element_size: Option<f64>,
    /// Suggested patch size.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub patch_size: Option<f64>,
}

impl MeshHints {
    fn is_empty(&self) -> bool {
        self.element_size.is_none() && self.patch_size.is_none()
    }
}

optics_fields! {
/// A Lambertian material (`[[material]]`), with optional optics for the ray tracer.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialDesc {
    /// Name surfaces and boxes refer to.
    pub name: String,
    /// RGB reflectance (Kd), each in [0, 1).
    pub reflectance: [f64; 3],
    /// RGB emitted radiance (Ke); the emitted exitance is `E = π·Ke`. Default 0.
    #[serde(default)]
    pub radiance: [f64; 3],
}
}

/// A named surface of explicit polygons (`[[surface]]`): vertex lists, or an indexed mesh
/// (`vertices` and `faces` indexing them from 0: each shared vertex written once, about a
/// third of the text of a fine mesh's polygons), or both (the polygons first).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SurfaceDesc {
    /// Surface name.
    pub name: String,
    /// Name of its material.
    pub material: String,
    /// Polygons as vertex lists, counter-clockwise seen from the front, in description units.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub polygons: Vec<Vec<[f64; 3]>>,
    /// Vertices the `faces` index, in description units.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub vertices: Vec<[f64; 3]>,
    /// Polygons as lists of indices into `vertices`, counter-clockwise seen from the front.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub faces: Vec<Vec<u32>>,
}

impl SurfaceDesc {
    /// The same surface with its polygons as an indexed mesh: vertices shared where their
    /// coordinates are bit for bit equal, in order of first use; faces in the polygons' order
    /// (so the scene imports to the same faces).
    pub fn indexed(mut self) -> Self {
        let mut index: HashMap<[u64; 3], u32> = HashMap::new();
        for (i, v) in self.vertices.iter().enumerate() {
            index.entry(v.map(f64::to_bits)).or_insert(i as u32);
        }
        let polygons = std::mem::take(&mut self.polygons);
        let mut faces = Vec::with_capacity(polygons.len() + self.faces.len());
        for polygon in &polygons {
            faces.push(
                polygon
                    .iter()
                    .map(|p| {
                        let next = self.vertices.len() as u32;
                        let i = *index.entry(p.map(f64::to_bits)).or_insert(next);
                        if i == next {
                            self.vertices.push(*p);
                        }
                        i
                    })
                    .collect(),
            );
        }
        faces.append(&mut self.faces);
        self.faces = faces;
        self
    }

    /// Every polygon of the surface as a vertex list: `polygons`, then `faces` (indices
    /// checked by the import; out of range ones are left out here).
    pub fn all_polygons(&self) -> Vec<Vec<[f64; 3]>> {
        let mut out = self.polygons.clone();
        out.extend(self.faces.iter().map(|f| {
            f.iter()
                .filter_map(|&i| self.vertices.get(i as usize).copied())
                .collect()
        }));
        out
    }
}

/// An axis-aligned box (`[[box]]`); each face becomes the surface `name.±axis`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxDesc {
    /// Base name of its surfaces.
    pub name: String,
    /// Name of its material.
    pub material: String,
    /// Lower corner, in description units.
    pub min: [f64; 3],
    /// Upper corner, in description units.
    pub max: [f64; 3],
    /// Normals point into the box (a room) when true, out of it (a block) when false.
    #[serde(default)]
    pub inward: bool,
    /// Faces left out (`"-x"`, `"+x"`, …, `"+z"`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub omit: Vec<String>,
}

/// An OBJ or glTF file to merge (`[[include]]`): exactly one of `obj` and `gltf`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IncludeDesc {
    /// Path of an OBJ file, relative to the description file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub obj: Option<String>,
    /// Path of a glTF 2.0 file (`.gltf` or `.glb`), relative to the description file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gltf: Option<String>,
}

impl IncludeDesc {
    /// The included file's path as written (whichever of `obj` and `gltf` is set).
    pub fn path(&self) -> Option<&str> {
        self.obj.as_deref().or(self.gltf.as_deref())
    }
}

impl Default for SceneDescription {
    /// An empty description (scale 1).
    fn default() -> Self {
        Self {
            name: None,
            scale: 1.0,
            mesh: MeshHints::default(),
            materials: Vec::new(),
            surfaces: Vec::new(),
            boxes: Vec::new(),
            includes: Vec::new(),
            overrides: Vec::new(),
            light_groups: Vec::new(),
            cameras: Vec::new(),
            point_lights: Vec::new(),
            spot_lights: Vec::new(),
            directional_lights: Vec::new(),
            sky: None,
            bake: BakeDesc::default(),
        }
    }
}

fn one() -> f64 {
    1.0
}
fn is_one(x: &f64) -> bool {
    *x == 1.0
}

/// The six faces of a box by name: axis and side.
const BOX_FACES: [(&str, usize, f64); 6] = [
    ("-x", 0, -1.0),
    ("+x", 0, 1.0),
    ("-y", 1, -1.0),
    ("+y", 1, 1.0),
    ("-z", 2, -1.0),
    ("+z", 2, 1.0),
];

impl SceneDescription {
    /// Parses TOML text; `origin` names the file in errors.
    pub fn parse(text: &str, origin: &str) -> Result<Self> {
        toml::from_str(text).map_err(|e| {
            let msg = e.message().to_string();
            let line = e.span().map(|s| {
                text.as_bytes()[..s.start.min(text.len())]
                    .iter()
                    .filter(|&&b| b == b'\n')
                    .count()
                    + 1
            });
            match line {
                Some(l) => Error::scene(format!("{origin}:{l}"), msg),
                None => Error::scene(origin, msg),
            }
        })
    }

    /// The description as TOML text (parses back to the same description).
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("a scene description always serialises")
    }

    /// Builds the scene; `base` is the folder relative includes are resolved against. The
    /// includes' images are planned as [`super::gltf::load`] plans them.
    pub fn build(&self, origin: &str, base: &Path) -> Result<Scene> {
        let budget = Budget {
            planned: 0,
            max_memory: None,
        };
        self.build_within(origin, base, budget)
            .map(|(scene, _)| scene)
    }

    /// [`build`](Self::build), the includes' images planned beside `budget` as they are
    /// decoded; answers the bytes planned in all.
    fn build_within(&self, origin: &str, base: &Path, mut budget: Budget) -> Result<(Scene, u128)> {
        let mut scene = Scene::new(self.name.clone().unwrap_or_else(|| stem(origin)));
        if !(self.scale.is_finite() && self.scale > 0.0) {
            return Err(Error::scene(
                origin,
                format!("scale must be a positive number, found {}", self.scale),
            ));
        }
        for m in &self.materials {
            let what = format!("material '{}'", m.name);
            let material = Material {
                name: m.name.clone(),
                reflectance: m.reflectance,
                emission: m.radiance.map(|k| k * std::f64::consts::PI),
                optics: m.optics(Optics::default(), origin, &what)?,
                texture: None,
            };
            scene.add_material(material, &format!("{origin}: material '{}'", m.name))?;
        }
        let s = self.scale;
        for surface in &self.surfaces {
            let mat = material_index(&scene, &surface.material, origin, &surface.name)?;
            let id = scene.surface(&surface.name);
            for (i, poly) in surface.polygons.iter().enumerate() {
                let v: Vec<DVec3> = poly.iter().map(|p| DVec3::from_array(*p) * s).collect();
                let loc = format!("{origin}: surface '{}' polygon {i}", surface.name);
                scene.add_polygon(&v, mat, id, &loc)?;
            }
            let what = |i: usize| format!("{origin}: surface '{}' face {i}", surface.name);
            if surface.faces.is_empty() != surface.vertices.is_empty() {
                return Err(Error::scene(
                    format!("{origin}: surface '{}'", surface.name),
                    "vertices and faces go together: give both (faces index the vertices \
                     from 0) or neither",
                ));
            }
            for (i, face) in surface.faces.iter().enumerate() {
                let v = face
                    .iter()
                    .map(|&k| {
                        surface
                            .vertices
                            .get(k as usize)
                            .map(|p| DVec3::from_array(*p) * s)
                            .ok_or_else(|| {
                                Error::scene(
                                    what(i),
                                    format!(
                                        "vertex index {k} is out of range: the surface has {} \
                                         vertices, indexed from 0",
                                        surface.vertices.len()
                                    ),
                                )
                            })
                    })
                    .collect::<Result<Vec<DVec3>>>()?;
                scene.add_polygon(&v, mat, id, &what(i))?;
            }
        }
        for b in &self.boxes {
            add_box(&mut scene, b, s, origin)?;
        }
        for (i, inc) in self.includes.iter().enumerate() {
            let sub = match (&inc.obj, &inc.gltf) {
                (Some(obj), None) => {
                    let (scene, planned) = super::obj::load_within(&base.join(obj), budget)?;
                    budget.planned = planned;
                    scene
                }
                (None, Some(gltf)) => {
                    let (scene, planned) = super::gltf::load_within(&base.join(gltf), budget)?;
                    budget.planned = planned;
                    scene
                }
                _ => {
                    return Err(Error::scene(
                        origin,
                        format!(
                            "include {i}: give exactly one of obj = \"FILE.obj\" and gltf = \"FILE.glb\""
                        ),
                    ));
                }
            };
            merge(&mut scene, sub, s);
        }
        self.apply_overrides(&mut scene, origin)?;
        self.apply_light_groups(&mut scene, origin)?;
        self.add_cameras_and_lights(&mut scene, origin)?;
        scene.bake = self.bake_defaults(origin, base)?;
        let size = |name: &str, mesh: Option<f64>, bake: Option<f64>| match (mesh, bake) {
            (Some(_), Some(_)) => Err(Error::scene(
                origin,
                format!("{name} is given in both [mesh] and [bake]; keep one"),
            )),
            (m, b) => Ok(m.or(b).map(|x| x * s)),
        };
        scene.hints.element_size = size(
            "element_size",
            self.mesh.element_size,
            self.bake.element_size,
        )?;
        scene.hints.patch_size = size("patch_size", self.mesh.patch_size, self.bake.patch_size)?;
        for (name, v) in [
            ("element_size", scene.hints.element_size),
            ("patch_size", scene.hints.patch_size),
        ] {
            if let Some(v) = v.filter(|v| !(v.is_finite() && *v > 0.0)) {
                return Err(Error::scene(
                    origin,
                    format!("{name} must be a positive length, found {v}"),
                ));
            }
        }
        Ok((scene, budget.planned))
    }

    /// `[[material_override]]`: every material of the name changes; a name that matches none
    /// is an error listing the materials there are.
    fn apply_overrides(&self, scene: &mut Scene, origin: &str) -> Result<()> {
        for o in &self.overrides {
            let what = format!("material_override '{}'", o.name);
            let mut found = false;
            for m in scene.materials.iter_mut().filter(|m| m.name == o.name) {
                found = true;
                if let Some(r) = o.reflectance {
                    // An explicit reflectance replaces a base colour texture too.
                    m.reflectance = r;
                    m.texture = None;
                }
                if let Some(l) = o.radiance {
                    m.emission = l.map(|k| k * std::f64::consts::PI);
                }
                m.optics = o.optics(m.optics, origin, &what)?;
                m.validate(&format!("{origin}: {what}"))?;
            }
            if !found {
                return Err(Error::scene(
                    origin,
                    format!(
                        "{what}: no material of that name; the scene has {}",
                        list(scene.materials.iter().map(|m| m.name.as_str()))
                    ),
                ));
            }
        }
        Ok(())
    }

    /// `[[light_group]]`: the emitting faces of the named materials and surfaces move to one
    /// surface named after the group (the bake makes a light group per emitting surface).
    fn apply_light_groups(&self, scene: &mut Scene, origin: &str) -> Result<()> {
        let mut taken: Vec<Option<usize>> = vec![None; scene.faces.len()];
        let mut moves = Vec::new();
        for (g, group) in self.light_groups.iter().enumerate() {
            let what = format!("light_group '{}'", group.name);
            for m in &group.materials {
                if !scene.materials.iter().any(|x| &x.name == m) {
                    return Err(Error::scene(
                        origin,
                        format!(
                            "{what}: no material '{m}'; the scene has {}",
                            list(scene.materials.iter().map(|m| m.name.as_str()))
                        ),
                    ));
                }
            }
            for n in &group.surfaces {
                if !scene.surfaces.contains(n) {
                    return Err(Error::scene(
                        origin,
                        format!(
                            "{what}: no surface '{n}'; the scene has {}",
                            list(scene.surfaces.iter().map(String::as_str))
                        ),
                    ));
                }
            }
            let mut count = 0;
            for (f, face) in scene.faces.iter().enumerate() {
                let material = &scene.materials[face.material];
                let selected = group.materials.contains(&material.name)
                    || group.surfaces.contains(&scene.surfaces[face.surface]);
                if !selected || material.emission.iter().all(|&e| e == 0.0) {
                    continue;
                }
                if let Some(other) = taken[f] {
                    return Err(Error::scene(
                        origin,
                        format!(
                            "{what}: an emitting face of surface '{}' is also in light_group '{}'; \
                             a face can be in one group only",
                            scene.surfaces[face.surface], self.light_groups[other].name
                        ),
                    ));
                }
                taken[f] = Some(g);
                count += 1;
            }
            if count == 0 {
                return Err(Error::scene(
                    origin,
                    format!("{what}: its materials and surfaces hold no emitting face"),
                ));
            }
            moves.push(g);
        }
        for g in moves {
            let id = scene.surface(&self.light_groups[g].name);
            for (f, t) in taken.iter().enumerate() {
                if *t == Some(g) {
                    scene.faces[f].surface = id;
                }
            }
        }
        // A surface left without faces is dropped (the ids of the others shift down).
        let mut used = vec![false; scene.surfaces.len()];
        for f in &scene.faces {
            used[f.surface] = true;
        }
        let mut new_id = vec![0; used.len()];
        let mut kept = Vec::new();
        for (i, name) in scene.surfaces.iter().enumerate() {
            if used[i] {
                new_id[i] = kept.len();
                kept.push(name.clone());
            }
        }
        scene.set_surfaces(kept);
        for f in &mut scene.faces {
            f.surface = new_id[f.surface];
        }
        // Two groups' names may clash with a surface that still emits on its own: refuse.
        for group in &self.light_groups {
            let id = scene
                .surfaces
                .iter()
                .position(|s| s == &group.name)
                .expect("group surface");
            let strays = scene.faces.iter().enumerate().any(|(f, face)| {
                face.surface == id
                    && taken[f].is_none()
                    && scene.materials[face.material]
                        .emission
                        .iter()
                        .any(|&e| e > 0.0)
            });
            if strays {
                return Err(Error::scene(
                    origin,
                    format!(
                        "light_group '{}': a surface of that name has emitting faces outside the \
                         group; rename the group",
                        group.name
                    ),
                ));
            }
        }
        Ok(())
    }

    fn add_cameras_and_lights(&self, scene: &mut Scene, origin: &str) -> Result<()> {
        let s = self.scale;
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        for c in &self.cameras {
            let (eye, target, up) = (DVec3::from(c.eye), DVec3::from(c.target), DVec3::from(c.up));
            let ok = finite(&c.eye)
                && finite(&c.target)
                && finite(&c.up)
                && (target - eye).length() > 0.0
                && up.cross(target - eye).length() > 0.0
                && c.fov_y_deg > 0.0
                && c.fov_y_deg < 180.0;
            if !ok {
                return Err(Error::scene(
                    origin,
                    format!(
                        "camera '{}': eye and target must differ, up must not be parallel to \
                         the view, and fov_y_deg must be in (0, 180)",
                        c.name
                    ),
                ));
            }
            scene.cameras.push(Camera {
                name: c.name.clone(),
                eye: (eye * s).to_array(),
                target: (target * s).to_array(),
                up: up.normalize().to_array(),
                fov_y_deg: c.fov_y_deg,
            });
        }
        for l in &self.point_lights {
            let what = format!("point_light '{}'", l.name);
            let intensity = match (l.intensity, l.power) {
                (Some(i), None) if l.colour.is_none() => i,
                (None, Some(p)) => {
                    let c = l.colour.unwrap_or([1.0; 3]);
                    c.map(|c| c * p / (4.0 * std::f64::consts::PI))
                }
                _ => {
                    return Err(Error::scene(
                        origin,
                        format!(
                            "{what}: give either intensity = [r, g, b] or power = W (with an optional colour)"
                        ),
                    ));
                }
            };
            if !finite(&l.position) || intensity.iter().any(|i| !(i.is_finite() && *i >= 0.0)) {
                return Err(Error::scene(
                    origin,
                    format!("{what}: position must be finite and intensity finite and >= 0"),
                ));
            }
            if let Some(g) = &l.group {
                let emits = |surface: Option<usize>, material: Option<usize>| {
                    scene.faces.iter().any(|f| {
                        (Some(f.surface) == surface || Some(f.material) == material)
                            && scene.materials[f.material]
                                .emission
                                .iter()
                                .any(|&e| e > 0.0)
                    })
                };
                let surface = scene.surfaces.iter().position(|s| s == g);
                let material = scene.materials.iter().position(|m| &m.name == g);
                if !emits(surface, material) {
                    return Err(Error::scene(
                        origin,
                        format!(
                            "{what}: group '{g}' is no emitting surface, material or light_group of the scene"
                        ),
                    ));
                }
            }
            scene.point_lights.push(PointLight {
                name: l.name.clone(),
                position: (DVec3::from(l.position) * s).to_array(),
                intensity,
                group: l.group.clone(),
            });
        }
        self.add_direct_lights(scene, origin)
    }

    /// `[[spot_light]]`, `[[directional_light]]` and `[sky]`, checked (errors name the light
    /// and the field), positions scaled.
    fn add_direct_lights(&self, scene: &mut Scene, origin: &str) -> Result<()> {
        use lrr_formats::DirectLightKind as Kind;
        let s = self.scale;
        let bad = |what: String| Error::scene(origin, what);
        let finite = |v: &[f64; 3]| v.iter().all(|x| x.is_finite());
        let radiometric = |v: &[f64; 3]| v.iter().all(|x| x.is_finite() && *x >= 0.0);
        let direction = |v: &[f64; 3]| finite(v) && v.iter().any(|&x| x != 0.0);
        for l in &self.spot_lights {
            let what = format!("spot_light '{}'", l.name);
            if !finite(&l.position) || !direction(&l.direction) {
                return Err(bad(format!(
                    "{what}: position must be finite and direction finite and not zero"
                )));
            }
            if !radiometric(&l.intensity) {
                return Err(bad(format!(
                    "{what}: intensity {:?} must be finite and >= 0 per channel",
                    l.intensity
                )));
            }
            let (inner, outer) = (l.inner_cone_deg, l.outer_cone_deg);
            if !(inner >= 0.0 && inner <= outer && outer <= 90.0) {
                return Err(bad(format!(
                    "{what}: need 0 <= inner_cone_deg <= outer_cone_deg <= 90, got {inner} and \
                     {outer}"
                )));
            }
            scene.direct_lights.push(DirectLight {
                name: l.name.clone(),
                kind: Kind::Spot,
                position: l.position.map(|x| x * s),
                direction: l.direction,
                strength: l.intensity,
                extra: [inner.to_radians(), outer.to_radians(), 0.0],
            });
        }
        for l in &self.directional_lights {
            let what = format!("directional_light '{}'", l.name);
            if !direction(&l.direction) || !radiometric(&l.irradiance) {
                return Err(bad(format!(
                    "{what}: direction must be finite and not zero, irradiance finite and >= 0 \
                     per channel"
                )));
            }
            scene.direct_lights.push(DirectLight {
                name: l.name.clone(),
                kind: Kind::Directional,
                position: [0.0; 3],
                direction: l.direction,
                strength: l.irradiance,
                extra: [0.0; 3],
            });
        }
        if let Some(sky) = &self.sky {
            let light = match (sky.radiance, sky.zenith, sky.horizon) {
                (Some(r), None, None) if sky.up.is_none() => DirectLight {
                    name: "sky".into(),
                    kind: Kind::UniformSky,
                    position: [0.0; 3],
                    direction: [0.0; 3],
                    strength: r,
                    extra: [0.0; 3],
                },
                (None, Some(z), Some(h)) => DirectLight {
                    name: "sky".into(),
                    kind: Kind::GradientSky,
                    position: [0.0; 3],
                    direction: sky.up.unwrap_or([0.0, 1.0, 0.0]),
                    strength: z,
                    extra: h,
                },
                _ => {
                    return Err(bad(
                        "[sky]: give radiance = [r, g, b] (a uniform sky), or zenith and horizon \
                         (a gradient, with an optional up)"
                            .into(),
                    ));
                }
            };
            if !radiometric(&light.strength)
                || !radiometric(&light.extra)
                || (light.kind == Kind::GradientSky && !direction(&light.direction))
            {
                return Err(bad(
                    "[sky]: radiances must be finite and >= 0 per channel, up finite and not \
                     zero"
                        .into(),
                ));
            }
            if scene.direct_lights.iter().any(|l| l.kind.is_sky()) {
                return Err(bad(
                    "[sky]: the scene has a sky already (an include's)".into()
                ));
            }
            scene.direct_lights.push(light);
        }
        Ok(())
    }

    /// `[bake]` checked, in scene units.
    fn bake_defaults(&self, origin: &str, base: &Path) -> Result<BakeDefaults> {
        let b = &self.bake;
        let one_of = |name: &str, v: &Option<String>, allowed: &[&str]| -> Result<()> {
            match v {
                Some(x) if !allowed.contains(&x.as_str()) => Err(Error::scene(
                    origin,
                    format!(
                        "[bake] {name} = \"{x}\"; expected one of {}",
                        allowed.join(", ")
                    ),
                )),
                _ => Ok(()),
            }
        };
        one_of("method", &b.method, &["2mf", "2msc", "2msc-split"])?;
        one_of("precision", &b.precision, &["f32", "f16"])?;
        one_of("layout", &b.layout, &["factored", "plain"])?;
        if let Some(t) = b
            .threshold
            .filter(|t| !(t.is_finite() && *t > 0.0 && *t <= 1.0))
        {
            return Err(Error::scene(
                origin,
                format!("[bake] threshold {t} must be in (0, 1]"),
            ));
        }
        if let Some(a) = b.min_patch_area.filter(|a| !(a.is_finite() && *a >= 0.0)) {
            return Err(Error::scene(
                origin,
                format!("[bake] min_patch_area {a} must be >= 0"),
            ));
        }
        if b.samples == Some(0) {
            return Err(Error::scene(origin, "[bake] samples must be at least 1"));
        }
        if b.output.as_deref() == Some("") {
            return Err(Error::scene(
                origin,
                "[bake] output is empty; name the operator file",
            ));
        }
        if let Some(t) = b
            .lightmap_texel_density
            .filter(|t| !(t.is_finite() && *t > 0.0))
        {
            return Err(Error::scene(
                origin,
                format!("[bake] lightmap_texel_density {t} must be a finite number > 0"),
            ));
        }
        if let Some(p) = b
            .lightmap_padding
            .filter(|&p| p > lrr_formats::MAX_ATLAS_PADDING)
        {
            return Err(Error::scene(
                origin,
                format!(
                    "[bake] lightmap_padding {p} is more than {} texels",
                    lrr_formats::MAX_ATLAS_PADDING
                ),
            ));
        }
        Ok(BakeDefaults {
            method: b.method.clone(),
            threshold: b.threshold,
            min_patch_area: b.min_patch_area.map(|a| a * self.scale * self.scale),
            samples: b.samples,
            precision: b.precision.clone(),
            layout: b.layout.clone(),
            output: b.output.as_ref().map(|o| base.join(o)),
            lightmap_texel_density: b.lightmap_texel_density.map(|t| t / self.scale),
            lightmap_padding: b.lightmap_padding,
            lightmap: b.lightmap,
        })
    }
}

/// "'a', 'b', 'c'" (or "none").
fn list<'a>(names: impl Iterator<Item = &'a str>) -> String {
    let mut seen: Vec<&str> = Vec::new();
    for n in names {
        if !seen.contains(&n) {
            seen.push(n);
        }
    }
    if seen.is_empty() {
        "none".into()
    } else {
        seen.iter()
            .map(|n| format!("'{n}'"))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

fn stem(origin: &str) -> String {
    Path::new(origin)
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("scene")
        .to_string()
}

fn material_index(scene: &Scene, name: &str, origin: &str, user: &str) -> Result<usize> {
    scene.materials.iter().position(|m| m.name == name).ok_or_else(|| {
        Error::scene(
            origin,
            format!("'{user}' uses material '{name}', which is not defined; add a [[material]] named '{name}'"),
        )
    })
}

fn add_box(scene: &mut Scene, b: &BoxDesc, s: f64, origin: &str) -> Result<()> {
    let mat = material_index(scene, &b.material, origin, &b.name)?;
    if let Some(bad) = b
        .omit
        .iter()
        .find(|o| !BOX_FACES.iter().any(|f| f.0 == o.as_str()))
    {
        return Err(Error::scene(
            origin,
            format!(
                "box '{}': unknown face '{bad}' in omit; faces are -x, +x, -y, +y, -z, +z",
                b.name
            ),
        ));
    }
    let lo = DVec3::from_array(b.min) * s;
    let hi = DVec3::from_array(b.max) * s;
    if !(lo.cmplt(hi).all()) {
        return Err(Error::scene(
            origin,
            format!("box '{}': min must be below max on every axis", b.name),
        ));
    }
    for (face, v) in box_polygons(b, lo, hi) {
        let id = scene.surface(&format!("{}.{face}", b.name));
        scene.add_polygon(
            &v,
            mat,
            id,
            &format!("{origin}: box '{}' face {face}", b.name),
        )?;
    }
    Ok(())
}

/// The faces a box makes (omitted ones left out), by face name, each counter-clockwise around
/// its front (outward, or inward for `inward` boxes), between the corners `lo` and `hi`.
pub(super) fn box_polygons(b: &BoxDesc, lo: DVec3, hi: DVec3) -> Vec<(&'static str, Vec<DVec3>)> {
    let mut out = Vec::new();
    for (face, axis, side) in BOX_FACES {
        if b.omit.iter().any(|o| o == face) {
            continue;
        }
        let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
        let at = |cu: f64, cw: f64| {
            let mut p = [0.0; 3];
            p[axis] = if side < 0.0 { lo[axis] } else { hi[axis] };
            p[u] = cu;
            p[w] = cw;
            DVec3::from_array(p)
        };
        // Counter-clockwise around +axis; reversed when the front must face -axis.
        let mut v = vec![
            at(lo[u], lo[w]),
            at(hi[u], lo[w]),
            at(hi[u], hi[w]),
            at(lo[u], hi[w]),
        ];
        let outward = side > 0.0;
        if outward == b.inward {
            v.reverse();
        }
        out.push((face, v));
    }
    out
}

fn merge(scene: &mut Scene, sub: Scene, s: f64) {
    let mat_offset = scene.materials.len();
    let tex_offset = scene.textures.len();
    scene.textures.extend(sub.textures);
    scene
        .materials
        .extend(sub.materials.into_iter().map(|mut m| {
            if let Some(t) = &mut m.texture {
                t.texture += tex_offset;
            }
            m
        }));
    scene.warnings.extend(sub.warnings);
    scene.repairs.add(&sub.repairs);
    let scaled = |p: [f64; 3]| p.map(|x| x * s);
    scene
        .cameras
        .extend(sub.cameras.into_iter().map(|c| Camera {
            eye: scaled(c.eye),
            target: scaled(c.target),
            ..c
        }));
    scene
        .point_lights
        .extend(sub.point_lights.into_iter().map(|l| PointLight {
            position: scaled(l.position),
            ..l
        }));
    scene
        .direct_lights
        .extend(sub.direct_lights.into_iter().map(|l| DirectLight {
            position: scaled(l.position),
            ..l
        }));
    for f in sub.faces {
        let name = &sub.surfaces[f.surface];
        let surface = scene.surface(name);
        let v: Vec<DVec3> = f.polygon.vertices().iter().map(|v| *v * s).collect();
        // A face valid before scaling stays valid after it; duplicates are re-checked.
        let _ = scene.add_polygon_uv(
            &v,
            f.material + mat_offset,
            surface,
            f.uv.map(|m| m.map(|m| m.scaled(s))),
            &format!("include '{name}'"),
        );
    }
}

/// Loads a scene description file.
pub fn load(path: &Path) -> Result<Scene> {
    load_within(path, (0, None)).map(|(scene, _)| scene)
}

/// [`load`] with its faces and each include planned ([`super::import::check_import`]) beside
/// `planned` bytes (its parse's) against `max_memory`; also answers the bytes planned in all.
pub(crate) fn load_within(
    path: &Path,
    (planned, max_memory): (u128, Option<u64>),
) -> Result<(Scene, u128)> {
    let origin = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let text = String::from_utf8(bytes).map_err(|e| {
        let line = e.as_bytes()[..e.utf8_error().valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1;
        Error::scene(
            format!("{origin}:{line}"),
            "the file is not valid UTF-8 text",
        )
    })?;
    let desc = SceneDescription::parse(&text, &origin)?;
    let base = path.parent().unwrap_or(Path::new("."));
    // The faces it writes out, on top of its parse.
    let faces: usize = (desc.surfaces.iter())
        .map(|f| f.polygons.len() + f.faces.len())
        .sum::<usize>()
        + 6 * desc.boxes.len();
    let mut planned = planned + faces as u128 * super::IMPORT_BYTES_PER_FACE;
    super::import::check_planned(path, text.len() as u128, planned, max_memory)?;
    for inc in &desc.includes {
        if let Some(file) = inc.path() {
            let per_byte = super::IMPORT_BYTES_PER_FILE_BYTE;
            planned = super::import::check_import(&base.join(file), planned, per_byte, max_memory)?;
        }
    }
    desc.build_within(
        &origin,
        base,
        Budget {
            planned,
            max_memory,
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grey material `m`, for the tests' descriptions.
    const GREY: &str = r#"
        [[material]]
        name = "m"
        reflectance = [0.5, 0.5, 0.5]
    "#;

    /// The start of a surface `s` of [`GREY`].
    const GREY_SURFACE: &str = r#"
        [[surface]]
        name = "s"
        material = "m"
    "#;

    #[test]
    fn an_indexed_surface_imports_as_its_polygons_do() {
        let polygons = format!(
            "{GREY}{GREY_SURFACE}polygons = [[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], \
             [[1, 0, 0], [2, 0, 0], [1, 1, 0]]]"
        );
        let indexed = format!(
            "{GREY}{GREY_SURFACE}vertices = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0]]
            faces = [[0, 1, 2, 3], [1, 4, 2]]"
        );
        let build = |text: &str| {
            SceneDescription::parse(text, "t.toml")
                .unwrap()
                .build("t.toml", Path::new("."))
                .unwrap()
        };
        let (a, b) = (build(&polygons), build(&indexed));
        assert_eq!(a.faces.len(), 2);
        let corners = |s: &Scene| -> Vec<Vec<DVec3>> {
            s.faces
                .iter()
                .map(|f| f.polygon.vertices().to_vec())
                .collect()
        };
        assert_eq!(corners(&a), corners(&b));
        // indexed() writes the polygons form as the indexed one, vertices shared.
        let d = SceneDescription::parse(&polygons, "t.toml").unwrap();
        let s = d.surfaces[0].clone().indexed();
        assert!(s.polygons.is_empty());
        assert_eq!(s.vertices.len(), 5);
        assert_eq!(s.faces, [vec![0, 1, 2, 3], vec![1, 4, 2]]);
        assert_eq!(s.all_polygons(), d.surfaces[0].polygons);
        // What is wrong is named.
        for (from, to, want) in [
            (
                "[1, 4, 2]]",
                "[1, 5, 2]]",
                "face 1: vertex index 5 is out of range: the surface has 5 vertices",
            ),
            (
                "faces = [[0, 1, 2, 3], [1, 4, 2]]",
                "",
                "vertices and faces go together",
            ),
        ] {
            let text = indexed.replace(from, to);
            let e = SceneDescription::parse(&text, "t.toml")
                .and_then(|d| d.build("t.toml", Path::new(".")))
                .unwrap_err()
                .to_string();
            assert!(e.contains("surface 's'") && e.contains(want), "{e}");
        }
    }

    #[test]
    fn box_faces_point_the_right_way() {
        let text = GREY.to_string()
            + r#"
            [[box]]
            name = "room"
            material = "m"
            min = [0, 0, 0]
            max = [2, 3, 4]
            inward = true
            [[box]]
            name = "block"
            material = "m"
            min = [0.5, 0.5, 0.5]
            max = [1, 1, 1]
            omit = ["-y"]
        "#;
        let d = SceneDescription::parse(&text, "t.toml").unwrap();
        let s = d.build("t.toml", Path::new(".")).unwrap();
        assert_eq!(s.faces.len(), 11);
        let centre_room = DVec3::new(1.0, 1.5, 2.0);
        let centre_block = DVec3::splat(0.75);
        for f in &s.faces {
            let name = &s.surfaces[f.surface];
            if name.starts_with("room") {
                assert!(f.polygon.height(centre_room) > 0.0, "{name}");
            } else {
                assert!(f.polygon.height(centre_block) < 0.0, "{name}");
            }
        }
    }

    #[test]
    fn errors_name_the_line_and_the_problem() {
        let text = "name = \"x\"\n[[material]]\nname = \"m\"\nreflectance = [0.5, 0.5]\n";
        let e = SceneDescription::parse(text, "bad.toml")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("bad.toml:4"), "{e}");
        let text = "[[material]]\nname = \"m\"\nreflectance = [0.5, 0.5, 1.5]\n";
        let d = SceneDescription::parse(text, "r.toml").unwrap();
        let e = d.build("r.toml", Path::new(".")).unwrap_err().to_string();
        assert!(e.contains("reflectance") && e.contains("1.5"), "{e}");
    }

    #[test]
    fn round_trips_through_toml() {
        let d = super::super::procedural::parallel_squares(1.0, 0.5);
        let again = SceneDescription::parse(&d.to_toml(), "x").unwrap();
        assert_eq!(d, again);
    }
}
