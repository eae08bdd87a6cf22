//! Scenes: Lambertian polygons with materials, grouped into named surfaces.
//!
//! Importers ([`obj`], [`gltf`], [`description`]) turn files into a [`Scene`]; [`procedural`] writes scene
//! descriptions for the furnace and the analytic test pairs, [`showcase`] those of the ray
//! tracer, [`building`] a two-floor house as glTF ([`glb`]) with its description. Every face that reaches the mesher
//! is a planar convex polygon of 3 or 4 vertices whose counter-clockwise normal is its (only)
//! front: `Scene::add_polygon` splits non-planar or concave quads and larger polygons into
//! such pieces, and drops degenerate or duplicate faces with a warning naming where they came
//! from.

pub mod building;
pub mod description;
pub mod glb;
pub mod gltf;
mod model;
pub mod obj;
mod polygon;
pub mod procedural;
pub mod showcase;
pub mod texture;

pub use model::{
    BakeDefaults, Camera, Face, MAX_TEXTURED_REFLECTANCE, Material, Optics, PointLight, Repairs,
    Scene, SizeHints,
};

use crate::error::{Error, Result};

/// Loads a scene from an OBJ file, a glTF 2.0 file (`.gltf`, `.glb`) or a scene description
/// (`.toml`), by extension.
pub fn load(path: &std::path::Path) -> Result<Scene> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let mut scene = match ext.as_str() {
        "obj" => obj::load(path)?,
        "toml" => description::load(path)?,
        "gltf" | "glb" => gltf::load(path)?,
        _ => {
            return Err(Error::scene(
                path.display().to_string(),
                "unknown scene type; expected an OBJ file (.obj), glTF 2.0 (.gltf, .glb) or an lrr scene description (.toml)",
            ));
        }
    };
    scene.validate(&path.display().to_string())?;
    if let Some(w) = scene.partial_lightmap_warning() {
        scene.warnings.push(format!("{}: {w}", path.display()));
    }
    Ok(scene)
}
