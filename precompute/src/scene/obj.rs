//! Wavefront OBJ + MTL import (tobj), with errors that name the file and the line.
//!
//! `Kd` is the diffuse reflectance, `Ke` the emitted radiance (exitance `E = π·Ke`). A `map_Kd`
//! image multiplies `Kd` (1 when absent) and varies the reflectance over each face through its
//! `vt`, as a glTF base colour texture (`texture`; docs/SCENES.md). What a ray
//! tracer adds ([`Optics`]) comes from `illum`, `Ks`, `Ns`, `Ni`, `Tf` and `d` (or `Tr = 1 - d`):
//! - `Ks` is the Phong highlight colour and `Ns` its exponent, for `illum` 2 and up (and when
//!   `illum` is absent); `illum` 0 and 1 have no highlight.
//! - `illum` 3, 5 and 8 (reflection on) make a mirror of reflectance `Ks` (1 when `Ks` is
//!   absent). `illum` 5 asks for Fresnel-weighted reflection, which lrr models only on
//!   transparent surfaces: an opaque illum-5 surface is a mirror of reflectance `Ks` (warned).
//! - `illum` 4, 6, 7 and 9 (glass) transmit `Tf` (else `1 - d` when `d < 1`, else 1) and refract
//!   with the index `Ni`; their reflection is `Ks` (1 when absent), which the tracer weights by
//!   Fresnel (`illum` 7: refraction + Fresnel, the usual glass).
//! - Any other surface with `d < 1` is see-through: it transmits `(1 - d) · Tf` (`Tf` default 1)
//!   with index `Ni`. A surface may thus be reflective and transparent at once.
//! - An opaque surface ignores `Tf` and `Ni` (exporters write `Tf 1 1 1` and `Ni 0` for opaque
//!   materials).
//!
//! Values out of range (`Ks`, `Tf`, `d` outside [0, 1], `Ns` negative, `Ni` below 1 on a
//! transparent surface, `illum` above 10, anything not finite) are errors naming the MTL file,
//! the material's line and the field. Faces are
//! one-sided with the counter-clockwise normal in front. A surface is an OBJ group/object; when
//! a group uses several materials each (group, material) pair is its own surface, named
//! `group/material`. tobj does not report line numbers, so a light pre-scan checks what tobj
//! would reject (UTF-8, numbers, index ranges) and records the line of every `f` statement.

use std::collections::HashMap;
use std::path::Path;

use glam::DVec3;

use super::model::{Material, Optics, Scene, clamp_reflectance};
use super::texture::{self, Budget, TextureBinding, UvMap, UvTransform, Wrap};
use crate::error::{Error, Result};

/// Reflectance used for faces without a material (with a warning).
const DEFAULT_REFLECTANCE: f64 = 0.5;

/// The texture coordinates of a face (its `vt`, `v` flipped: OBJ puts `v = 0` at the bottom of
/// the image, glTF and [`texture::Texture`] at the top) as an affine map of its plane: the
/// first fan triangle whose corners are not in a line.
fn face_uv(vertices: &[DVec3], indices: &[u32], texcoords: &[f64]) -> Option<UvMap> {
    let t = |i: usize| {
        let k = 2 * indices[i] as usize;
        [texcoords[k], 1.0 - texcoords[k + 1]]
    };
    (1..vertices.len().saturating_sub(1)).find_map(|i| {
        UvMap::from_triangle(
            [vertices[0], vertices[i], vertices[i + 1]],
            [t(0), t(i), t(i + 1)],
        )
    })
}

/// The texture of a `map_Kd` statement (`spec`: options, then the image's path), decoded once
/// per image into `scene.textures`. Of the options, `-clamp on` clamps the coordinates to the
/// image (else it repeats); the others are skipped with a warning.
#[allow(clippy::type_complexity)]
fn diffuse_map(
    spec: &str,
    (folders, images, budget): (
        &[std::path::PathBuf],
        &mut HashMap<(std::path::PathBuf, Wrap), usize>,
        &mut Budget,
    ),
    scene: &mut Scene,
    location: &str,
) -> Result<usize> {
    let words: Vec<&str> = spec.split_whitespace().collect();
    let mut i = 0;
    let mut wrap = Wrap::Repeat;
    let mut skipped = Vec::new();
    while i < words.len() && words[i].starts_with('-') {
        let option = words[i];
        i += 1;
        // An option's arguments: numbers, or on/off.
        let start = i;
        while i < words.len()
            && i + 1 < words.len()
            && (words[i].parse::<f64>().is_ok() || matches!(words[i], "on" | "off"))
        {
            i += 1;
        }
        match (option, &words[start..i]) {
            ("-clamp", ["on"]) => wrap = Wrap::Clamp,
            ("-clamp", _) => {}
            _ => skipped.push(option),
        }
    }
    let file = words[i.min(words.len())..].join(" ");
    if file.is_empty() {
        return Err(Error::scene(
            location,
            format!("map_Kd '{spec}' names no image"),
        ));
    }
    if !skipped.is_empty() {
        scene.warnings.push(format!(
            "{location}: map_Kd option(s) {} ignored",
            skipped.join(", ")
        ));
    }
    let path = folders
        .iter()
        .map(|d| d.join(&file))
        .find(|p| p.is_file())
        .ok_or_else(|| {
            Error::scene(
                location,
                format!("map_Kd image '{file}' is not beside the OBJ or its MTL"),
            )
        })?;
    if let Some(&id) = images.get(&(path.clone(), wrap)) {
        return Ok(id);
    }
    let what = format!("{location}: map_Kd image {}", path.display());
    let bytes = std::fs::read(&path).map_err(|e| Error::scene(&what, e.to_string()))?;
    budget.room_for(&bytes, &what, true)?;
    let decoded = texture::decode(&bytes, file.clone(), [wrap, wrap])
        .map_err(|e| Error::scene(location, format!("map_Kd image {}{e}", path.display())))?;
    scene.textures.push(decoded);
    let id = scene.textures.len() - 1;
    images.insert((path, wrap), id);
    Ok(id)
}

/// Loads an OBJ file (and the MTL files it names). Each `map_Kd` image is planned before it is
/// decoded against 80% of the available memory (`LRR_MEMORY_LIMIT` sets what is available;
/// [`crate::scene::load_within`] takes a limit).
pub fn load(path: &Path) -> Result<Scene> {
    let budget = Budget {
        planned: 0,
        max_memory: None,
    };
    load_within(path, budget).map(|(scene, _)| scene)
}

/// [`load`], each `map_Kd` image planned before it is decoded beside `budget`; answers the
/// bytes planned in all.
pub(crate) fn load_within(path: &Path, mut budget: Budget) -> Result<(Scene, u128)> {
    let origin = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let face_lines = prescan(&bytes, &origin)?;
    // Where each material is defined ("file.mtl:line"), for messages about its values.
    let mut defined = HashMap::new();
    let folder = path.parent().unwrap_or(Path::new("."));
    // Where a map_Kd image may lie: beside the OBJ, or beside one of its MTL files.
    let mut image_folders = vec![folder.to_path_buf()];
    for library in material_libraries(&bytes) {
        let mtl = folder.join(&library);
        if let Some(dir) = mtl.parent()
            && !image_folders.iter().any(|d| d == dir)
        {
            image_folders.push(dir.to_path_buf());
        }
        if let Ok(text) = std::fs::read(&mtl) {
            defined.extend(prescan_mtl(&text, &mtl.display().to_string())?);
        }
    }
    let options = tobj::LoadOptions {
        triangulate: false,
        single_index: false,
        ..Default::default()
    };
    let (models, materials) = tobj::load_obj(path, &options)
        .map_err(|e| Error::scene(&origin, format!("cannot parse OBJ: {e}")))?;
    let materials = materials.map_err(|e| {
        Error::scene(
            &origin,
            format!("cannot load its material library (mtllib): {e}; check the .mtl file exists next to the OBJ"),
        )
    })?;
    let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("scene");
    let mut scene = Scene::new(name);
    let mut material_ids = Vec::with_capacity(materials.len());
    // Decoded map_Kd images by path, each decoded once.
    let mut images: HashMap<(std::path::PathBuf, Wrap), usize> = HashMap::new();
    for m in &materials {
        let location = format!("{origin}: material '{}'", m.name);
        let mut kd = m.diffuse.unwrap_or([DEFAULT_REFLECTANCE; 3]);
        let ke = m.emissive.unwrap_or([0.0; 3]);
        let mtl_location = match defined.get(&m.name) {
            Some(at) => format!("{at}: material '{}'", m.name),
            None => location.clone(),
        };
        let mut texture = None;
        if let Some(spec) = &m.diffuse_texture {
            let images = (&image_folders[..], &mut images, &mut budget);
            match diffuse_map(spec, images, &mut scene, &mtl_location) {
                Ok(id) => {
                    // The map multiplies Kd (1 where the MTL gives none).
                    let factor = m.diffuse.unwrap_or([1.0; 3]);
                    let mean = scene.textures[id].average();
                    kd = clamp_reflectance(
                        [0, 1, 2].map(|c| factor[c] * mean[c]),
                        &format!("{mtl_location}: Kd times its map_Kd's mean"),
                        &mut scene.warnings,
                    );
                    texture = Some(TextureBinding {
                        texture: id,
                        set: 0,
                        scale: factor,
                        transform: UvTransform::IDENTITY,
                    });
                }
                // Too large for the memory: refused, not left out (other colours than the
                // file's, unasked).
                Err(e @ Error::Limits(_)) => return Err(e),
                Err(e) => scene.warnings.push(format!(
                    "{e}; the texture is left out and the material's Kd used alone (put the \
                     image next to the OBJ or its MTL, or convert it to PNG or JPEG)"
                )),
            }
        }
        let material = Material {
            name: m.name.clone(),
            reflectance: kd,
            emission: ke.map(|k| k * std::f64::consts::PI),
            optics: optics(m, &mtl_location, &mut scene.warnings)?,
            texture,
        };
        material_ids.push(scene.add_material(material, &location)?);
    }
    let mut default_material = None;
    let group_materials = materials_per_group(&models);
    let mut face_counter = 0usize;
    for model in &models {
        let mesh = &model.mesh;
        let material = match mesh.material_id {
            Some(id) if id < material_ids.len() => material_ids[id],
            _ => *default_material.get_or_insert_with(|| {
                scene.warnings.push(format!(
                    "{origin}: faces of '{}' have no material; using grey reflectance {DEFAULT_REFLECTANCE}",
                    model.name
                ));
                scene.materials.push(Material {
                    name: "default".into(),
                    reflectance: [DEFAULT_REFLECTANCE; 3],
                    emission: [0.0; 3],
                    optics: Default::default(),
                    texture: None,
                });
                scene.materials.len() - 1
            }),
        };
        let surface_name = surface_name(
            &model.name,
            &scene.materials[material].name,
            &group_materials,
        );
        let surface = scene.surface(&surface_name);
        let mut start = 0usize;
        let arities: Vec<usize> = if mesh.face_arities.is_empty() {
            vec![3; mesh.indices.len() / 3]
        } else {
            mesh.face_arities.iter().map(|&a| a as usize).collect()
        };
        for arity in arities {
            let line = face_lines.get(face_counter).copied();
            face_counter += 1;
            let location = match line {
                Some((l, _)) => format!("{origin}:{l}"),
                None => format!("{origin}: face #{face_counter}"),
            };
            let idx = &mesh.indices[start..start + arity];
            start += arity;
            let vertices: Vec<DVec3> = idx
                .iter()
                .map(|&i| {
                    let i = 3 * i as usize;
                    DVec3::new(
                        mesh.positions[i],
                        mesh.positions[i + 1],
                        mesh.positions[i + 2],
                    )
                })
                .collect();
            // A face without its own `vt` takes the material's mean (Kd times the image's).
            let uv = match scene.materials[material].texture.is_some()
                && line.is_some_and(|(_, textured)| textured)
                && mesh.texcoord_indices.len() == mesh.indices.len()
            {
                true => face_uv(
                    &vertices,
                    &mesh.texcoord_indices[start - arity..start],
                    &mesh.texcoords,
                ),
                false => None,
            };
            scene.add_polygon_uv(&vertices, material, surface, [uv, None], &location)?;
        }
    }
    Ok((scene, budget.planned))
}

fn materials_per_group(models: &[tobj::Model]) -> HashMap<String, usize> {
    let mut count: HashMap<String, Vec<Option<usize>>> = HashMap::new();
    for m in models {
        let e = count.entry(m.name.clone()).or_default();
        if !e.contains(&m.mesh.material_id) {
            e.push(m.mesh.material_id);
        }
    }
    count.into_iter().map(|(k, v)| (k, v.len())).collect()
}

fn surface_name(group: &str, material: &str, per_group: &HashMap<String, usize>) -> String {
    if group.is_empty() || group == "unnamed_object" {
        material.to_string()
    } else if per_group.get(group).copied().unwrap_or(1) > 1 && group != material {
        format!("{group}/{material}")
    } else {
        group.to_string()
    }
}

/// Checks the statements tobj would reject, with line numbers, and returns the line of every
/// face statement in file order.
fn prescan(bytes: &[u8], origin: &str) -> Result<Vec<(usize, bool)>> {
    let mut vertices = 0i64;
    let mut faces = Vec::new();
    for (i, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let line_no = i + 1;
        let at = || format!("{origin}:{line_no}");
        let line = std::str::from_utf8(raw).map_err(|_| {
            Error::scene(
                at(),
                "the line is not valid UTF-8 text (OBJ names must be UTF-8)",
            )
        })?;
        let line = line.split('#').next().unwrap_or("").trim();
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let coords: Vec<&str> = words.collect();
                if coords.len() < 3 {
                    return Err(Error::scene(at(), "a vertex ('v') needs three coordinates"));
                }
                for c in &coords[..3] {
                    match c.parse::<f64>() {
                        Ok(x) if x.is_finite() => {}
                        _ => {
                            return Err(Error::scene(
                                at(),
                                format!("vertex coordinate '{c}' is not a finite number"),
                            ));
                        }
                    }
                }
                vertices += 1;
            }
            Some("f") => {
                let refs: Vec<&str> = words.collect();
                if refs.len() < 3 {
                    return Err(Error::scene(
                        at(),
                        "a face ('f') needs at least three vertices",
                    ));
                }
                // Whether every corner names a texture coordinate (tobj fills a missing one
                // with the one before).
                let textured = refs
                    .iter()
                    .all(|r| r.split('/').nth(1).is_some_and(|t| !t.is_empty()));
                for r in refs {
                    let first = r.split('/').next().unwrap_or("");
                    let idx: i64 = first.parse().map_err(|_| {
                        Error::scene(at(), format!("face vertex '{r}' is not an index"))
                    })?;
                    let ok = (idx > 0 && idx <= vertices) || (idx < 0 && -idx <= vertices);
                    if !ok {
                        return Err(Error::scene(
                            at(),
                            format!(
                                "face vertex index {idx} is out of range: {vertices} vertices are defined so far"
                            ),
                        ));
                    }
                }
                faces.push((line_no, textured));
            }
            _ => {}
        }
    }
    Ok(faces)
}

/// The `mtllib` names of an OBJ, as tobj reads them (everything after the keyword, trimmed).
fn material_libraries(bytes: &[u8]) -> Vec<String> {
    bytes
        .split(|&b| b == b'\n')
        .filter_map(|raw| std::str::from_utf8(raw).ok())
        .filter_map(|line| {
            let line = line.trim_start();
            let rest = line.strip_prefix("mtllib")?;
            rest.starts_with([' ', '\t'])
                .then(|| rest.trim().to_string())
        })
        .collect()
}

/// Checks an MTL file's colour statements (tobj panics on a `Kd` with fewer than three
/// numbers; found by the `obj_import` fuzz target); returns where each material is defined
/// (`newmtl` name → "file:line").
fn prescan_mtl(bytes: &[u8], origin: &str) -> Result<HashMap<String, String>> {
    let mut defined = HashMap::new();
    for (i, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let at = || format!("{origin}:{}", i + 1);
        let line = std::str::from_utf8(raw)
            .map_err(|_| Error::scene(at(), "the line is not valid UTF-8 text"))?;
        let mut words = line.split_whitespace();
        match words.next() {
            Some(key @ ("Ka" | "Kd" | "Ks" | "Ke")) => {
                let numbers = words.take(3).filter(|w| w.parse::<f64>().is_ok()).count();
                if numbers < 3 {
                    return Err(Error::scene(
                        at(),
                        format!("'{key}' needs three numbers (R G B)"),
                    ));
                }
            }
            // tobj takes the rest of the line, trimmed, as the name.
            Some("newmtl") => {
                let name = line.trim().get(6..).unwrap_or_default().trim();
                defined.entry(name.to_string()).or_insert_with(at);
            }
            _ => {}
        }
    }
    Ok(defined)
}

/// The MTL illumination models that reflect by ray tracing (a mirror of reflectance `Ks`).
const MIRROR_MODELS: [u8; 3] = [3, 5, 8];
/// The MTL illumination models of glass (transmission, refraction by `Ni`, reflection `Ks`).
const GLASS_MODELS: [u8; 4] = [4, 6, 7, 9];

/// A material's [`Optics`] from its MTL fields (the rules of the module docs); `location`
/// names the MTL file, line and material.
fn optics(m: &tobj::Material, location: &str, warnings: &mut Vec<String>) -> Result<Optics> {
    let fail = |field: &str, problem: String| Error::scene(location, format!("{field}: {problem}"));
    let colour = |field: &str, v: Option<[f64; 3]>| -> Result<Option<[f64; 3]>> {
        match v {
            Some(c) if c.iter().any(|x| !(0.0..=1.0).contains(x)) => Err(fail(
                field,
                format!("{c:?} must be three numbers in [0, 1]"),
            )),
            _ => Ok(v),
        }
    };
    let illum = m.illumination_model;
    if let Some(i) = illum.filter(|&i| i > 10) {
        return Err(fail(
            "illum",
            format!("{i} is not an MTL illumination model (0 to 10)"),
        ));
    }
    let ks = colour("Ks", m.specular)?;
    let shininess = m.shininess.unwrap_or(0.0);
    if !(shininess.is_finite() && shininess >= 0.0) {
        return Err(fail(
            "Ns",
            format!("{shininess} must be a finite number >= 0"),
        ));
    }
    let tr = match m.unknown_param.get("Tr") {
        None => None,
        Some(text) => Some(
            number(text)
                .ok_or_else(|| fail("Tr", format!("'{text}' must be one number in [0, 1]")))?,
        ),
    };
    let dissolve = m.dissolve.or(tr.map(|t| 1.0 - t));
    if let Some(d) = dissolve.filter(|d| !(0.0..=1.0).contains(d)) {
        let field = if m.dissolve.is_some() { "d" } else { "Tr" };
        return Err(fail(field, format!("dissolve {d} must be in [0, 1]")));
    }
    let tf = match m.unknown_param.get("Tf") {
        None => None,
        Some(text) => colour("Tf", Some(filter(text).ok_or_else(|| {
            fail(
                "Tf",
                format!("'{text}' is not a colour: write Tf r g b (or one grey value); the xyz and spectral forms are not supported"),
            )
        })?))?,
    };
    let glass = illum.is_some_and(|i| GLASS_MODELS.contains(&i));
    let transmission = if glass {
        tf.or(dissolve.filter(|&d| d < 1.0).map(|d| [1.0 - d; 3]))
            .unwrap_or([1.0; 3])
    } else {
        match dissolve.filter(|&d| d < 1.0) {
            Some(d) => tf.unwrap_or([1.0; 3]).map(|t| t * (1.0 - d)),
            None => [0.0; 3],
        }
    };
    let transparent = transmission.iter().any(|&t| t > 0.0);
    let ior = if transparent {
        let ni = m.optical_density.unwrap_or(1.0);
        if !(ni.is_finite() && ni >= 1.0) {
            return Err(fail(
                "Ni",
                format!(
                    "{ni}: a transparent surface needs an index of refraction >= 1 (glass about 1.5)"
                ),
            ));
        }
        ni
    } else {
        1.0
    };
    let highlight = illum.is_none_or(|i| i >= 2);
    let mirror = if glass || illum.is_some_and(|i| MIRROR_MODELS.contains(&i)) {
        ks.unwrap_or([1.0; 3])
    } else {
        [0.0; 3]
    };
    if illum == Some(5) && !transparent {
        warnings.push(format!(
            "{location}: illum 5 asks for Fresnel-weighted reflection, which lrr models on \
             transparent surfaces only: this opaque surface is a mirror of reflectance Ks"
        ));
    }
    Ok(Optics {
        specular: if highlight {
            ks.unwrap_or([0.0; 3])
        } else {
            [0.0; 3]
        },
        shininess,
        mirror,
        transmission,
        ior,
    })
}

/// One finite number (`Tr`).
fn number(text: &str) -> Option<f64> {
    let mut words = text.split_whitespace();
    let v = words
        .next()?
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())?;
    words.next().is_none().then_some(v)
}

/// A `Tf` colour: `r g b`, or one grey value.
fn filter(text: &str) -> Option<[f64; 3]> {
    let v: Vec<f64> = text
        .split_whitespace()
        .map(|w| w.parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect::<Option<_>>()?;
    match v[..] {
        [g] => Some([g; 3]),
        [r, g, b] => Some([r, g, b]),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mtl_colours_need_three_numbers() {
        let e = prescan_mtl(b"newmtl a\nKd 0.5\n", "m.mtl")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("m.mtl:2:") && e.contains("'Kd' needs three numbers"),
            "{e}"
        );
        assert!(prescan_mtl(b"newmtl a\nKe\n", "m.mtl").is_err());
        let defined = prescan_mtl(
            b"newmtl a\nKd 0.5 0.5 0.5 # grey\n\nnewmtl  b c \n",
            "m.mtl",
        );
        assert_eq!(defined.unwrap()["b c"], "m.mtl:4");
        assert_eq!(
            material_libraries(b"mtllib a b.mtl\n  mtllib\tc.mtl\nmtllibx\n"),
            vec!["a b.mtl", "c.mtl"]
        );
    }

    /// Loads a quad whose material is `mtl` (the body after `newmtl m`), from files written
    /// to a fresh directory; the MTL's `newmtl` is on line 2.
    fn with_mtl(tag: &str, mtl: &str) -> Result<Scene> {
        let dir = std::env::temp_dir().join(format!("lrr-mtl-{}-{tag}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join("m.mtl"),
            format!("# optics\nnewmtl m\nKd 0.5 0.5 0.5\n{mtl}\n"),
        )
        .unwrap();
        let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nusemtl m\nf 1 2 3 4\n";
        std::fs::write(dir.join("q.obj"), obj).unwrap();
        let scene = load(&dir.join("q.obj"));
        std::fs::remove_dir_all(&dir).unwrap();
        scene
    }

    fn optics_of(tag: &str, mtl: &str) -> Optics {
        with_mtl(tag, mtl).unwrap().materials[0].optics
    }

    #[test]
    fn mtl_optics_follow_the_illumination_model() {
        let o = optics_of("phong", "illum 2\nKs 0.5 0.4 0.3\nNs 20\nNi 0.0\nTf 1 1 1");
        assert_eq!(o.specular, [0.5, 0.4, 0.3]);
        assert_eq!(o.shininess, 20.0);
        // Opaque: Tf and Ni (as exporters write them) are ignored.
        assert_eq!((o.mirror, o.transmission, o.ior), ([0.0; 3], [0.0; 3], 1.0));
        let o = optics_of("matte", "illum 1\nKs 0.5 0.5 0.5");
        assert_eq!(o, Optics::default());
        let o = optics_of("mirror", "illum 3\nKs 0.9 0.9 0.8");
        assert_eq!((o.mirror, o.specular), ([0.9, 0.9, 0.8], [0.9, 0.9, 0.8]));
        let o = optics_of("mirror-no-ks", "illum 8");
        assert_eq!(o.mirror, [1.0; 3]);
        let o = optics_of("glass", "illum 7\nKs 1 1 1\nNi 1.5\nTf 0.9 0.8 0.7\nNs 200");
        assert_eq!(o.transmission, [0.9, 0.8, 0.7]);
        assert_eq!((o.ior, o.mirror), (1.5, [1.0; 3]));
        // Glass without Tf transmits 1 - d, or everything.
        assert_eq!(
            optics_of("glass-d", "illum 7\nd 0.25\nNi 1.3").transmission,
            [0.75; 3]
        );
        assert_eq!(
            optics_of("glass-clear", "illum 6\nNi 1.3").transmission,
            [1.0; 3]
        );
        assert_eq!(
            optics_of("grey-tf", "illum 4\nTf 0.5").transmission,
            [0.5; 3]
        );
        // Reflective and transparent at once: a mirror that dissolves.
        let o = optics_of("both", "illum 3\nKs 0.6 0.6 0.6\nd 0.25\nNi 1.2");
        assert_eq!(
            (o.mirror, o.transmission, o.ior),
            ([0.6; 3], [0.75; 3], 1.2)
        );
        let o = optics_of("tr", "illum 2\nTr 0.4\nTf 0.5 1 1");
        assert_eq!(o.transmission, [0.2, 0.4, 0.4]);
        assert_eq!(o.ior, 1.0);
        // Fresnel on an opaque surface: a plain mirror, warned.
        let scene = with_mtl("fresnel", "illum 5\nKs 0.8 0.8 0.8").unwrap();
        assert_eq!(scene.materials[0].optics.mirror, [0.8; 3]);
        assert!(
            scene.warnings.iter().any(|w| w.contains("illum 5")),
            "{:?}",
            scene.warnings
        );
    }

    #[test]
    fn mtl_optics_out_of_range_name_file_material_and_field() {
        let cases = [
            (
                "ks",
                "Ks 1.5 0 0",
                "Ks: [1.5, 0.0, 0.0] must be three numbers in [0, 1]",
            ),
            ("ns", "Ns -1", "Ns: -1 must be a finite number >= 0"),
            ("d", "d 2", "d: dissolve 2 must be in [0, 1]"),
            ("tr", "Tr 1.5", "Tr: dissolve -0.5 must be in [0, 1]"),
            ("tr-text", "Tr lots", "Tr: 'lots' must be one number"),
            (
                "tf",
                "illum 7\nTf 1.2 1 1",
                "Tf: [1.2, 1.0, 1.0] must be three numbers",
            ),
            (
                "tf-xyz",
                "illum 7\nTf xyz 1 1 1",
                "Tf: 'xyz 1 1 1' is not a colour",
            ),
            (
                "ni",
                "illum 7\nNi 0.5",
                "Ni: 0.5: a transparent surface needs an index of refraction >= 1",
            ),
            (
                "illum",
                "illum 12",
                "illum: 12 is not an MTL illumination model",
            ),
            ("nan", "Ks nan 0 0", "Ks: [NaN, 0.0, 0.0]"),
        ];
        for (tag, mtl, expected) in cases {
            let e = with_mtl(tag, mtl).err().unwrap().to_string();
            assert!(e.contains("m.mtl:2: material 'm': "), "{e}");
            assert!(e.contains(expected), "{e} (expected {expected:?})");
        }
    }

    #[test]
    fn prescan_reports_lines() {
        let e = prescan(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "a.obj")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("a.obj:4:") && e.contains("out of range"),
            "{e}"
        );
        let e = prescan(b"v 0 0 0\nv nan 0 0\n", "a.obj")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("a.obj:2:") && e.contains("finite"), "{e}");
        let e = prescan(b"o \xff\xfe\n", "a.obj").unwrap_err().to_string();
        assert!(e.starts_with("a.obj:1:") && e.contains("UTF-8"), "{e}");
        let lines = prescan(
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 3\nf -3 -2 -1\n",
            "a.obj",
        )
        .unwrap();
        assert_eq!(lines, vec![(5, false), (6, false)]);
        let lines = prescan(
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/1\nf 1/1/1 2//1 3/1\nf 1 2 3\n",
            "a.obj",
        )
        .unwrap();
        assert_eq!(lines, vec![(5, true), (6, false), (7, false)]);
    }
}
