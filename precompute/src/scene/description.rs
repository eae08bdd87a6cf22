//! The lrr scene description: a TOML file of materials, polygon surfaces, boxes and OBJ includes.
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
//! ```

use std::path::Path;

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::model::{Material, Scene};
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
    #[serde(default, rename = "material")]
    pub materials: Vec<MaterialDesc>,
    /// Explicit polygon surfaces (`[[surface]]`).
    #[serde(default, rename = "surface", skip_serializing_if = "Vec::is_empty")]
    pub surfaces: Vec<SurfaceDesc>,
    /// Axis-aligned boxes (`[[box]]`), one surface per face.
    #[serde(default, rename = "box", skip_serializing_if = "Vec::is_empty")]
    pub boxes: Vec<BoxDesc>,
    /// OBJ files merged into the scene (`[[include]]`).
    #[serde(default, rename = "include", skip_serializing_if = "Vec::is_empty")]
    pub includes: Vec<IncludeDesc>,
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

/// A Lambertian material (`[[material]]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
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

/// A named surface of explicit polygons (`[[surface]]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SurfaceDesc {
    /// Surface name.
    pub name: String,
    /// Name of its material.
    pub material: String,
    /// Polygons as vertex lists, counter-clockwise seen from the front, in description units.
    pub polygons: Vec<Vec<[f64; 3]>>,
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

/// An OBJ file to merge (`[[include]]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IncludeDesc {
    /// Path of the OBJ file, relative to the description file.
    pub obj: String,
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
            let line = e
                .span()
                .map(|s| text[..s.start.min(text.len())].lines().count().max(1));
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

    /// Builds the scene; `base` is the folder relative includes are resolved against.
    pub fn build(&self, origin: &str, base: &Path) -> Result<Scene> {
        let mut scene = Scene::new(self.name.clone().unwrap_or_else(|| stem(origin)));
        if !(self.scale.is_finite() && self.scale > 0.0) {
            return Err(Error::scene(
                origin,
                format!("scale must be a positive number, found {}", self.scale),
            ));
        }
        for m in &self.materials {
            let material = Material {
                name: m.name.clone(),
                reflectance: m.reflectance,
                emission: m.radiance.map(|k| k * std::f64::consts::PI),
                optics: Default::default(),
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
        }
        for b in &self.boxes {
            add_box(&mut scene, b, s, origin)?;
        }
        for inc in &self.includes {
            let path = base.join(&inc.obj);
            let sub = super::obj::load(&path)?;
            merge(&mut scene, sub, s);
        }
        scene.hints.element_size = self.mesh.element_size.map(|x| x * s);
        scene.hints.patch_size = self.mesh.patch_size.map(|x| x * s);
        for (name, v) in [
            ("element_size", scene.hints.element_size),
            ("patch_size", scene.hints.patch_size),
        ] {
            if let Some(v) = v.filter(|v| !(v.is_finite() && *v > 0.0)) {
                return Err(Error::scene(
                    origin,
                    format!("[mesh] {name} must be a positive length, found {v}"),
                ));
            }
        }
        Ok(scene)
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
    scene.materials.extend(sub.materials);
    scene.warnings.extend(sub.warnings);
    scene.repairs.add(&sub.repairs);
    for f in sub.faces {
        let name = &sub.surfaces[f.surface];
        let surface = scene.surface(name);
        let v: Vec<DVec3> = f.polygon.vertices().iter().map(|v| *v * s).collect();
        // A face valid before scaling stays valid after it; duplicates are re-checked.
        let _ = scene.add_polygon(
            &v,
            f.material + mat_offset,
            surface,
            &format!("include '{name}'"),
        );
    }
}

/// Loads a scene description file.
pub fn load(path: &Path) -> Result<Scene> {
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
    desc.build(&origin, base)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_faces_point_the_right_way() {
        let text = r#"
            [[material]]
            name = "m"
            reflectance = [0.5, 0.5, 0.5]
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
        let d = SceneDescription::parse(text, "t.toml").unwrap();
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
