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
mod import;
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

pub use import::{DESCRIPTION_BYTES_PER_BYTE, IMPORT_BYTES_PER_FACE, IMPORT_BYTES_PER_FILE_BYTE};

use crate::error::{Error, Result};
use import::check_import;

/// Loads a scene from an OBJ file, a glTF 2.0 file (`.gltf`, `.glb`) or a scene description
/// (`.toml`), by extension: [`load_within`] with no limit but the memory available.
pub fn load(path: &std::path::Path) -> Result<Scene> {
    load_within(path, None).map(|(scene, _)| scene)
}

/// [`load`] planned like a bake's stages: each file is refused before it is read when
/// [`IMPORT_BYTES_PER_FILE_BYTE`] times its size ([`DESCRIPTION_BYTES_PER_BYTE`] for a scene
/// description) does not fit `max_memory` (`--max-memory`; 80% of the available memory
/// without one); a description's faces ([`IMPORT_BYTES_PER_FACE`]) and includes are planned
/// beside its own bytes once it is parsed, and each texture image, from the size its header
/// declares, before it is decoded ([`texture::DECODE_BYTES_PER_TEXEL`]; 3 bytes a texel kept
/// after). Also answers the bytes planned.
pub fn load_within(path: &std::path::Path, max_memory: Option<u64>) -> Result<(Scene, u128)> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    if !["obj", "toml", "gltf", "glb"].contains(&ext.as_str()) {
        return Err(Error::scene(
            path.display().to_string(),
            "unknown scene type; expected an OBJ file (.obj), glTF 2.0 (.gltf, .glb) or an lrr scene description (.toml)",
        ));
    }
    let per_byte = match ext.as_str() {
        "toml" => DESCRIPTION_BYTES_PER_BYTE,
        _ => IMPORT_BYTES_PER_FILE_BYTE,
    };
    let own = check_import(path, 0, per_byte, max_memory)?;
    let (mut scene, planned) = match ext.as_str() {
        "toml" => description::load_within(path, (own, max_memory))?,
        "obj" => obj::load_within(
            path,
            texture::Budget {
                planned: own,
                max_memory,
            },
        )?,
        _ => gltf::load_within(
            path,
            texture::Budget {
                planned: own,
                max_memory,
            },
        )?,
    };
    scene.validate(&path.display().to_string())?;
    if let Some(w) = scene.partial_lightmap_warning() {
        scene.warnings.push(format!("{}: {w}", path.display()));
    }
    Ok((scene, planned))
}
