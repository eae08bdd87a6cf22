//! The plan file (`lrr plan SCENE -o PLAN`): a scene's meshes, made once and read by every
//! shard (`lrr bake SCENE --shard I/N --plan PLAN`) instead of each shard meshing again.
//!
//! 2MF meshing costs a shard almost nothing (0.1% of its form factors in the Cornell box at
//! N = 7), but 2MSC builds its patches from probe solves: half a shard's form-factor time at
//! N = 7, repeated by every shard (docs/DISTRIBUTED.md). The plan stores the mesh exactly
//! (every f64 by its bits), so a shard that reads it computes the same rows and the merge
//! writes the same bytes. Layout: magic `LRRPLAN3` (2: elements list the face pieces they
//! group; 3: and whether they are lit on them, `Element::on_parts`), body length, XXH64 of
//! the body, body
//! (lrr version, scene content hash, settings text, then the mesh).

use std::path::Path;

use glam::DVec3;
use lrr_formats::checksum;

use super::part::{Dec, Decoded, Enc};
use crate::error::{Error, Result};
use crate::geometry::{Polygon, Region};
use crate::mesh::Element;
use crate::patches::{Mesh, Patch};
use crate::scene::Scene;

const MAGIC: &[u8; 8] = b"LRRPLAN3";

/// What a plan must match: the shard's lrr version, scene and settings.
pub(crate) struct PlanIdentity<'a> {
    pub version: &'a str,
    pub scene_hash: u64,
    pub settings: &'a str,
}

/// Writes the plan of `mesh` atomically.
pub(crate) fn write(path: &Path, id: &PlanIdentity, mesh: &Mesh) -> Result<()> {
    let mut e = Enc::default();
    e.str(id.version);
    e.u64(id.scene_hash);
    e.str(id.settings);
    e.u64(mesh.elements.len() as u64);
    for el in &mesh.elements {
        polygon(&mut e, &el.polygon);
        for v in [el.face, el.surface, el.patch] {
            e.u64(u64::from(v));
        }
        e.u64(u64::from(el.on_parts));
        e.u64(el.parts.len() as u64);
        for (face, p) in &el.parts {
            e.u64(u64::from(*face));
            polygon(&mut e, p);
        }
    }
    e.u64(mesh.patches.len() as u64);
    for p in &mesh.patches {
        e.u64(p.shape.parts().len() as u64);
        p.shape.parts().iter().for_each(|q| polygon(&mut e, q));
        e.u64(u64::from(p.face));
        e.u64(u64::from(p.surface));
    }
    e.u64s(mesh.order.iter().map(|&v| u64::from(v)));
    e.u64s(mesh.index.iter().map(|&v| u64::from(v)));
    e.f64s(&mesh.weights);
    // Elements split where light changes (`crate::refine`): the file's `refined_elements`.
    e.u64(mesh.meshing.refined as u64);
    e.bytes(&mesh.siblings);
    let body = e.0;
    let mut bytes = MAGIC.to_vec();
    bytes.extend_from_slice(&(body.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&checksum(&body).to_le_bytes());
    bytes.extend_from_slice(&body);
    lrr_formats::write_atomic(path, &bytes)?;
    Ok(())
}

/// Reads a plan and checks that it was made for `id`; the mesh's invariants are checked too,
/// and that it fits `scene` (its faces, surfaces and bounding box).
pub(crate) fn read(path: &Path, id: &PlanIdentity, scene: &Scene) -> Result<Mesh> {
    let bad = |m: String| Error::part(path, m);
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    if bytes.len() < 24 || &bytes[..8] != MAGIC {
        return Err(bad(
            "not a plan of this lrr (no LRRPLAN3 header): write one with `lrr plan`".into(),
        ));
    }
    let word = |i: usize| u64::from_le_bytes(bytes[i..i + 8].try_into().expect("8 bytes"));
    let body = &bytes[24..];
    if word(8) != body.len() as u64 || word(16) != checksum(body) {
        return Err(bad(
            "truncated or damaged: length or checksum wrong; run `lrr plan` again".into(),
        ));
    }
    let mut d = Dec::new(body);
    let (version, scene_hash, settings) = (
        d.str().map_err(&bad)?,
        d.u64().map_err(&bad)?,
        d.str().map_err(&bad)?,
    );
    let mismatch = if version != id.version {
        Some(format!("was written by {version}, this is {}", id.version))
    } else if scene_hash != id.scene_hash {
        Some("was made for another scene (content hash differs)".to_string())
    } else if settings != id.settings {
        Some(format!(
            "was made with other settings ({settings}, not {})",
            id.settings
        ))
    } else {
        None
    };
    if let Some(m) = mismatch {
        return Err(bad(format!(
            "this plan {m}; run `lrr plan` with the shard's scene and flags"
        )));
    }
    let mesh = mesh(&mut d).map_err(|m| bad(format!("damaged: {m}")))?;
    mesh.validate()
        .map_err(|m| bad(format!("damaged: the mesh fails its checks: {m}")))?;
    fits(&mesh, scene).map_err(|m| bad(format!("damaged: {m}; run `lrr plan` again")))?;
    Ok(mesh)
}

/// The mesh's faces and surfaces are the scene's (indices in range), and every polygon
/// (elements, their face pieces, patches) lies inside the scene's bounding box grown by 1e-6
/// of its diagonal (meshing only cuts the scene's faces), with a finite normal and scale. The
/// mesh's own checks see neither: the `shard_plan` fuzz target found resealed plans of valid
/// shape with coordinates near 1e300, which overflowed the smooth weights' spatial grid
/// (`mesh::smooth`, an i64 cell index + 1), and with a face index past the scene's faces
/// (`display::materials` indexed out of bounds).
fn fits(mesh: &Mesh, scene: &Scene) -> std::result::Result<(), String> {
    let (lo, hi) = scene.bounds();
    let pad = DVec3::splat(1e-6 * (hi - lo).length());
    let (lo, hi) = (lo - pad, hi + pad);
    let inside = |p: &Polygon| {
        p.vertices()
            .iter()
            .all(|v| v.cmpge(lo).all() && v.cmple(hi).all())
            && p.normal.is_finite()
            && p.scale.is_finite()
    };
    let (faces, surfaces) = (scene.faces.len(), scene.surfaces.len());
    let known = |face: u32, surface: u32| (face as usize) < faces && (surface as usize) < surfaces;
    for (i, e) in mesh.elements.iter().enumerate() {
        if !known(e.face, e.surface) || e.parts.iter().any(|&(f, _)| f as usize >= faces) {
            return Err(format!(
                "element {i} names a face or surface the scene lacks ({} faces, {} surfaces)",
                faces, surfaces
            ));
        }
        // An element lit on its parts stands for them by a proxy of their area in their
        // plane, which may reach past them (a rotated rectangle about a cell at the floor's
        // edge): it must lie within its parts' box grown by that box's diagonal.
        let proxy_near_parts = || {
            let (mut a, mut b) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            for v in e.parts.iter().flat_map(|(_, p)| p.vertices().iter()) {
                (a, b) = (a.min(*v), b.max(*v));
            }
            let grow = DVec3::splat((b - a).length());
            let (a, b) = (a - grow, b + grow);
            let p = &e.polygon;
            p.normal.is_finite()
                && p.scale.is_finite()
                && p.vertices()
                    .iter()
                    .all(|v| v.cmpge(a).all() && v.cmple(b).all())
        };
        let polygon_fits = if e.on_parts {
            !e.parts.is_empty() && proxy_near_parts()
        } else {
            inside(&e.polygon)
        };
        if !polygon_fits || !e.parts.iter().all(|(_, p)| inside(p)) {
            return Err(format!("element {i} lies outside the scene"));
        }
    }
    for (i, p) in mesh.patches.iter().enumerate() {
        if !known(p.face, p.surface) {
            return Err(format!(
                "patch {i} names a face or surface the scene lacks ({} faces, {} surfaces)",
                faces, surfaces
            ));
        }
        if !p.shape.parts().iter().all(inside) {
            return Err(format!("patch {i} lies outside the scene"));
        }
    }
    Ok(())
}

fn mesh(d: &mut Dec) -> Decoded<Mesh> {
    let mut elements = Vec::new();
    for _ in 0..d.count(8 * 16)? {
        let polygon = read_polygon(d)?;
        let [face, surface, patch] = [d.u32()?, d.u32()?, d.u32()?];
        let on_parts = match d.u64()? {
            0 => false,
            1 => true,
            other => return Err(format!("an element's on_parts flag is {other}, not 0 or 1")),
        };
        let mut parts = Vec::new();
        for _ in 0..d.count(8 * 15)? {
            parts.push((d.u32()?, read_polygon(d)?));
        }
        elements.push(Element {
            polygon,
            face,
            surface,
            patch,
            parts,
            on_parts,
        });
    }
    let mut patches = Vec::new();
    for _ in 0..d.count(8 * 16)? {
        let parts = (0..d.count(8 * 14)?)
            .map(|_| read_polygon(d))
            .collect::<Decoded<Vec<_>>>()?;
        if parts.is_empty() {
            return Err("a patch without parts".into());
        }
        patches.push(Patch {
            shape: Region::new(parts),
            face: d.u32()?,
            surface: d.u32()?,
        });
    }
    let mut mesh = Mesh {
        elements,
        patches,
        order: d.u32s()?,
        index: d.u32s()?,
        weights: d.f64s()?,
        // Meshing happened in `lrr plan`, which reported it; a plan does not store the report
        // but for the elements refinement split (the file's metadata).
        meshing: crate::mesh::MeshReport::default(),
        siblings: Vec::new(),
        contacts: None,
    };
    mesh.meshing.refined = d.usize()?;
    mesh.siblings = d.bytes()?;
    d.end()?;
    if mesh.order.len() != mesh.n() || mesh.weights.len() != mesh.n() {
        return Err("order or weights disagree with the elements".into());
    }
    if mesh.order.iter().any(|&e| e as usize >= mesh.n()) {
        return Err("an element id out of range".into());
    }
    Ok(mesh)
}

fn polygon(e: &mut Enc, p: &Polygon) {
    for v in p.vertices.iter().chain([&p.normal]) {
        v.to_array().iter().for_each(|c| e.u64(c.to_bits()));
    }
    e.u64(p.count as u64);
    e.u64(p.scale.to_bits());
}

fn read_polygon(d: &mut Dec) -> Decoded<Polygon> {
    let mut v = [DVec3::ZERO; 5];
    for x in &mut v {
        *x = DVec3::new(d.f64()?, d.f64()?, d.f64()?);
    }
    let count = d.usize()?;
    if !(3..=4).contains(&count) {
        return Err(format!("a polygon of {count} vertices"));
    }
    Ok(Polygon {
        vertices: [v[0], v[1], v[2], v[3]],
        count,
        normal: v[4],
        scale: d.f64()?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::MeshSizes;
    use crate::patches::PatchMethod;

    /// A plan keeps the elements lit on their parts (`Element::on_parts`: the flag, the parts)
    /// and their patches' parts: the mesh read back equals the mesh written.
    #[test]
    fn a_plan_keeps_elements_lit_on_their_parts() {
        let scene = crate::mesh::boxes_on_floor();
        let sizes = MeshSizes {
            element_size: 1.0,
            patch_size: 3.0,
        };
        let mesh = Mesh::build(&scene, sizes, PatchMethod::TwoFixed, None).unwrap();
        assert!(mesh.elements.iter().filter(|e| e.on_parts).count() >= 50);
        let path = std::env::temp_dir().join(format!("lrr-plan-{}.plan", std::process::id()));
        let id = PlanIdentity {
            version: "test",
            scene_hash: 7,
            settings: "h 1",
        };
        write(&path, &id, &mesh).unwrap();
        let back = read(&path, &id, &scene);
        std::fs::remove_file(&path).ok();
        let back = back.unwrap();
        assert_eq!(back.elements, mesh.elements);
        let shapes = |m: &Mesh| {
            m.patches
                .iter()
                .map(|p| p.shape.clone())
                .collect::<Vec<_>>()
        };
        assert_eq!(shapes(&back), shapes(&mesh));
        assert_eq!(back.weights, mesh.weights);
    }
}
