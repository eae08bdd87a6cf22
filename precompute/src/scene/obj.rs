//! Wavefront OBJ + MTL import (tobj), with errors that name the file and the line.
//!
//! `Kd` is the diffuse reflectance, `Ke` the emitted radiance (exitance `E = π·Ke`). Faces are
//! one-sided with the counter-clockwise normal in front. A surface is an OBJ group/object; when
//! a group uses several materials each (group, material) pair is its own surface, named
//! `group/material`. tobj does not report line numbers, so a light pre-scan checks what tobj
//! would reject (UTF-8, numbers, index ranges) and records the line of every `f` statement.

use std::collections::HashMap;
use std::path::Path;

use glam::DVec3;

use super::model::{Material, Scene};
use crate::error::{Error, Result};

/// Reflectance used for faces without a material (with a warning).
const DEFAULT_REFLECTANCE: f64 = 0.5;

/// Loads an OBJ file (and the MTL files it names).
pub fn load(path: &Path) -> Result<Scene> {
    let origin = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let face_lines = prescan(&bytes, &origin)?;
    for library in material_libraries(&bytes) {
        let mtl = path.parent().unwrap_or(Path::new(".")).join(&library);
        if let Ok(text) = std::fs::read(&mtl) {
            prescan_mtl(&text, &mtl.display().to_string())?;
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
    for m in &materials {
        let location = format!("{origin}: material '{}'", m.name);
        let kd = m.diffuse.unwrap_or([DEFAULT_REFLECTANCE; 3]);
        let ke = m.emissive.unwrap_or([0.0; 3]);
        let material = Material {
            name: m.name.clone(),
            reflectance: kd,
            emission: ke.map(|k| k * std::f64::consts::PI),
            optics: Default::default(),
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
                Some(l) => format!("{origin}:{l}"),
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
            scene.add_polygon(&vertices, material, surface, &location)?;
        }
    }
    Ok(scene)
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
fn prescan(bytes: &[u8], origin: &str) -> Result<Vec<usize>> {
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
                faces.push(line_no);
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
/// numbers; found by the `obj_import` fuzz target).
fn prescan_mtl(bytes: &[u8], origin: &str) -> Result<()> {
    for (i, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let at = || format!("{origin}:{}", i + 1);
        let line = std::str::from_utf8(raw)
            .map_err(|_| Error::scene(at(), "the line is not valid UTF-8 text"))?;
        let mut words = line.split_whitespace();
        if let Some(key @ ("Ka" | "Kd" | "Ks" | "Ke")) = words.next() {
            let numbers = words.take(3).filter(|w| w.parse::<f64>().is_ok()).count();
            if numbers < 3 {
                return Err(Error::scene(
                    at(),
                    format!("'{key}' needs three numbers (R G B)"),
                ));
            }
        }
    }
    Ok(())
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
        assert!(prescan_mtl(b"newmtl a\nKd 0.5 0.5 0.5 # grey\n", "m.mtl").is_ok());
        assert_eq!(
            material_libraries(b"mtllib a b.mtl\n  mtllib\tc.mtl\nmtllibx\n"),
            vec!["a b.mtl", "c.mtl"]
        );
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
        assert_eq!(lines, vec![5, 6]);
    }
}
