//! Writes simple scenes as binary glTF 2.0 (`.glb`), the form [`super::gltf`] reads back:
//! named nodes, each one mesh with a primitive per material (indexed triangles, positions in
//! f32), materials as rough dielectrics (`baseColorFactor` = the diffuse reflectance,
//! metallic 0, roughness 1) with an emissive factor scaled by `KHR_materials_emissive_strength`
//! where the radiance exceeds 1. The JSON is built with serde_json (keys in a fixed order), the
//! container by the gltf crate: the same scene gives the same bytes.

use gltf::binary::{Glb, Header};
use serde_json::{Value, json};

use crate::error::{Error, Result};

/// A material: reflectance and emitted radiance per channel.
#[derive(Debug, Clone, PartialEq)]
pub struct GlbMaterial {
    /// Name.
    pub name: String,
    /// Diffuse reflectance, each in [0, 1).
    pub reflectance: [f64; 3],
    /// Emitted radiance (exitance π·radiance).
    pub radiance: [f64; 3],
}

/// A node: its name and, per material (an index into the materials), convex polygons
/// (counter-clockwise around their front), written as fans of triangles.
#[derive(Debug, Clone, PartialEq)]
pub struct GlbNode {
    /// Name (the surface the importer makes of it).
    pub name: String,
    /// (material index, polygons) per primitive.
    pub primitives: Vec<(usize, Vec<Vec<[f64; 3]>>)>,
}

/// The binary chunk and the JSON arrays that index it.
#[derive(Default)]
struct Buffers {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Buffers {
    /// Appends `bytes` as a buffer view (4-byte aligned) and returns its index.
    fn view(&mut self, bytes: &[u8], target: u32) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.views.push(json!({
            "buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len(), "target": target
        }));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    /// Positions as a VEC3 FLOAT accessor with its bounds; returns its index.
    fn positions(&mut self, p: &[[f32; 3]]) -> usize {
        let bytes: Vec<u8> = p.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes, 34962);
        let bound = |f: fn(f32, f32) -> f32, start: f32| {
            (0..3)
                .map(|a| p.iter().map(|v| v[a]).fold(start, f))
                .collect::<Vec<f32>>()
        };
        self.accessors.push(json!({
            "bufferView": view, "componentType": 5126, "count": p.len(), "type": "VEC3",
            "min": bound(f32::min, f32::INFINITY), "max": bound(f32::max, f32::NEG_INFINITY)
        }));
        self.accessors.len() - 1
    }

    /// Indices as a SCALAR UNSIGNED_INT accessor; returns its index.
    fn indices(&mut self, i: &[u32]) -> usize {
        let bytes: Vec<u8> = i.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes, 34963);
        self.accessors.push(json!({
            "bufferView": view, "componentType": 5125, "count": i.len(), "type": "SCALAR"
        }));
        self.accessors.len() - 1
    }
}

/// The material's JSON, emission split into a factor in [0, 1] and a strength.
fn material(m: &GlbMaterial) -> Value {
    let [r, g, b] = m.reflectance;
    let mut v = json!({
        "name": m.name,
        "pbrMetallicRoughness": {
            "baseColorFactor": [r, g, b, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0
        }
    });
    let peak = m.radiance.iter().copied().fold(0.0, f64::max);
    if peak > 0.0 {
        let strength = peak.max(1.0);
        v["emissiveFactor"] = json!(m.radiance.map(|x| x / strength));
        if strength > 1.0 {
            v["extensions"] = json!({
                "KHR_materials_emissive_strength": { "emissiveStrength": strength }
            });
        }
    }
    v
}

/// The GLB bytes of `nodes` (all roots of one scene) with `materials`; `generator` names the
/// writer in `asset`. Polygons need 3 or more vertices; material indices must exist.
pub fn write(nodes: &[GlbNode], materials: &[GlbMaterial], generator: &str) -> Result<Vec<u8>> {
    let mut buffers = Buffers::default();
    let mut meshes = Vec::new();
    for node in nodes {
        let mut primitives = Vec::new();
        for (m, polygons) in &node.primitives {
            if *m >= materials.len() || polygons.iter().any(|p| p.len() < 3) {
                return Err(Error::scene(
                    &node.name,
                    "a primitive names a missing material or has a polygon of fewer than 3 vertices",
                ));
            }
            let (mut positions, mut indices) = (Vec::new(), Vec::new());
            for p in polygons {
                let first = positions.len() as u32;
                positions.extend(p.iter().map(|v| v.map(|x| x as f32)));
                for i in 1..p.len() as u32 - 1 {
                    indices.extend([first, first + i, first + i + 1]);
                }
            }
            let position = buffers.positions(&positions);
            let index = buffers.indices(&indices);
            primitives.push(json!({
                "attributes": { "POSITION": position }, "indices": index, "material": m
            }));
        }
        meshes.push(json!({ "name": node.name, "primitives": primitives }));
    }
    let node_json: Vec<Value> = (0..nodes.len())
        .map(|i| json!({ "name": nodes[i].name, "mesh": i }))
        .collect();
    let emissive = materials
        .iter()
        .any(|m| m.radiance.iter().any(|&x| x > 1.0));
    let mut root = json!({
        "asset": { "version": "2.0", "generator": generator },
        "scene": 0,
        "scenes": [{ "nodes": (0..nodes.len()).collect::<Vec<_>>() }],
        "nodes": node_json,
        "meshes": meshes,
        "materials": materials.iter().map(material).collect::<Vec<_>>(),
        "accessors": buffers.accessors,
        "bufferViews": buffers.views,
        "buffers": [{ "byteLength": buffers.bin.len() }],
    });
    if emissive {
        root["extensionsUsed"] = json!(["KHR_materials_emissive_strength"]);
    }
    let text = serde_json::to_vec(&root).map_err(|e| Error::scene(generator, e.to_string()))?;
    let glb = Glb {
        header: Header {
            magic: *b"glTF",
            version: 2,
            // Filled in by `to_vec` from the chunk lengths.
            length: 0,
        },
        json: std::borrow::Cow::Owned(text),
        bin: Some(std::borrow::Cow::Owned(buffers.bin)),
    };
    glb.to_vec()
        .map_err(|e| Error::scene(generator, format!("encoding GLB: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_written_scene_imports_back_with_its_names_materials_and_faces() {
        let materials = vec![
            GlbMaterial {
                name: "grey".into(),
                reflectance: [0.5, 0.25, 0.125],
                radiance: [0.0; 3],
            },
            GlbMaterial {
                name: "lamp".into(),
                reflectance: [0.5; 3],
                radiance: [8.0, 4.0, 2.0],
            },
        ];
        let square = |y: f64, up: bool| {
            let mut p = vec![[0.0, y, 0.0], [0.0, y, 1.0], [1.0, y, 1.0], [1.0, y, 0.0]];
            if !up {
                p.reverse();
            }
            p
        };
        let nodes = vec![
            GlbNode {
                name: "room".into(),
                primitives: vec![(0, vec![square(0.0, true)]), (1, vec![square(2.0, false)])],
            },
            GlbNode {
                name: "room.lamp".into(),
                primitives: vec![(1, vec![square(1.5, false)])],
            },
        ];
        let bytes = write(&nodes, &materials, "test").unwrap();
        assert_eq!(bytes, write(&nodes, &materials, "test").unwrap());
        let s =
            super::super::gltf::import(&bytes, std::path::Path::new("."), "t", "t.glb").unwrap();
        assert!(s.warnings.is_empty(), "{:?}", s.warnings);
        assert_eq!(s.surfaces, ["room/grey", "room/lamp", "room.lamp"]);
        assert_eq!(s.faces.len(), 6);
        let lamp = s.materials.iter().find(|m| m.name == "lamp").unwrap();
        let pi = std::f64::consts::PI;
        assert_eq!(lamp.emission, [8.0 * pi, 4.0 * pi, 2.0 * pi]);
        let grey = s.materials.iter().find(|m| m.name == "grey").unwrap();
        assert_eq!(grey.reflectance, [0.5, 0.25, 0.125]);
        // Fronts kept: the floor faces up, the others down.
        for f in &s.faces {
            let up = f.polygon.height(glam::DVec3::new(0.5, 10.0, 0.5)) > 0.0;
            assert_eq!(up, s.surfaces[f.surface] == "room/grey");
        }
    }
}
