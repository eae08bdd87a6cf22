//! What the tracer reads, copied once from an operator file into flat arrays indexed by `u32`
//! (the buffers a WGSL twin binds): the BVH nodes as the file stores them, the display
//! triangles in the BVH's leaf order (so a leaf's triangles are one contiguous run), each with
//! its display face, and per display face its element's original id, its normal and its
//! element's material. The display faces are the file's
//! ([`OperatorFile::faces`]: section FACES, else GEOMETRY's elements, face = file position).
//!
//! Everything a traversal indexes is checked here, so that no file (the file's own validation
//! included or not) can make the tracer read out of bounds or overflow its traversal stack.

use lrr_formats::{BvhNode, Geometry, OperatorFile, PointLight, Smooth};

use super::bvh::{Hit, MAX_BVH_DEPTH, Ray};
use super::bvh4::{Bvh4, NotATree};
use super::math::{V3, length, sub};
use crate::error::{RuntimeError, input};

/// How one material looks to the tracer (its diffuse part is already in the radiosity).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Optics {
    pub specular: V3,
    pub shininess: f32,
    pub mirror: V3,
    pub transmission: V3,
    pub ior: f32,
}

impl Optics {
    pub(crate) const DIFFUSE: Optics = Optics {
        specular: [0.0; 3],
        shininess: 0.0,
        mirror: [0.0; 3],
        transmission: [0.0; 3],
        ior: 1.0,
    };

    pub(crate) fn has_highlight(&self) -> bool {
        self.specular.iter().any(|&c| c > 0.0)
    }

    pub(crate) fn reflects(&self) -> bool {
        self.mirror.iter().any(|&c| c > 0.0)
    }

    pub(crate) fn transmits(&self) -> bool {
        self.transmission.iter().any(|&c| c > 0.0)
    }
}

/// The tracer's copy of a file's display data.
#[derive(Debug, Clone)]
pub(crate) struct TraceScene {
    /// The file's BVH nodes (node 0 the root; what the GPU twin traverses).
    #[cfg(feature = "gpu")]
    pub nodes: Vec<BvhNode>,
    /// Display triangles in leaf order (`Bvh::triangles` order): v0, v1, v2.
    pub tris: Vec<[f32; 9]>,
    /// The same tree collapsed into 4-wide nodes, what the CPU traverses.
    pub bvh4: Bvh4,
    /// Per leaf-order triangle: its display face.
    pub tri_face: Vec<u32>,
    /// Per leaf-order triangle: its display triangle id (the file's `Bvh::triangles`).
    pub tri_id: Vec<u32>,
    /// Per file position: the element's original id (the index into a frame's radiosity; the
    /// order the smooth reconstruction reads).
    pub element_id: Vec<u32>,
    /// Per display face: the original id of its element (the index into a frame's radiosity).
    pub face_id: Vec<u32>,
    /// Per display face: unit normal.
    pub normals: Vec<V3>,
    /// Per display face: its element's index into `optics`.
    pub face_material: Vec<u32>,
    /// Leaf-order indices of the triangles whose material is not purely diffuse (a specular
    /// colour, a mirror reflectance or a transmission filter): what the effects decision
    /// tests against the view (`effects::decide`).
    pub special: Vec<u32>,
    pub optics: Vec<Optics>,
    /// Material names, for `--explain`.
    pub material_names: Vec<String>,
    pub lights: Vec<PointLight>,
    /// Number of light groups of the file (what a light's `group` indexes).
    pub groups: usize,
    /// Offset of secondary and shadow ray origins off their surface: 1e-5 of the scene's
    /// extent (f32 rounds coordinates to 6e-8 relative; the margin covers the hit distance's
    /// error too).
    pub epsilon: f32,
    /// The file has smooth reconstruction weights (section SMOOTH).
    pub has_smooth: bool,
    /// The display faces' polygons and SMOOTH weights (checked), what [`Reconstruction`] reads;
    /// `None` when the file has no SMOOTH section.
    ///
    /// [`Reconstruction`]: crate::Reconstruction
    pub smooth: Option<(Geometry, Smooth)>,
}

impl TraceScene {
    /// Copies and checks the display data of `file`; an error when it has no BVH or when a part
    /// does not fit the rest.
    pub(crate) fn new(file: &OperatorFile) -> Result<Self, RuntimeError> {
        let n = file.n as usize;
        let g = &file.geometry;
        if g.vertex_count.len() != n || g.vertices.len() != 12 * n || g.normals.len() != 3 * n {
            return Err(bad("the geometry does not have n elements"));
        }
        if file.order.len() != n || file.order.iter().any(|&id| id as usize >= n) {
            return Err(bad("the element order is not a list of n ids below n"));
        }
        let Some(bvh) = &file.display.bvh else {
            return Err(input(
                "the file has no BVH (section BVH, format 1.2), so it cannot be ray traced; \
                 re-bake the scene with this version of lrr (`lrr bake`), which stores one",
            ));
        };
        let faces = file.faces();
        let fg = faces.geometry;
        let count = faces.len();
        let shaped = fg.vertices.len() == 12 * count
            && fg.normals.len() == 3 * count
            && fg.vertex_count.iter().all(|&c| c == 3 || c == 4);
        if !shaped {
            return Err(bad(
                "the display faces are not polygons of 3 or 4 vertices with a normal each",
            ));
        }
        let face_element: Vec<u32> = match faces.elements() {
            Some(e) if e.len() != count || e.iter().any(|&p| p as usize >= n) => {
                return Err(bad("a display face names no element"));
            }
            Some(e) => e.to_vec(),
            None => (0..n as u32).collect(),
        };
        let all: Vec<(u32, [[f32; 3]; 3])> = faces.triangles().collect();
        check_bvh(&bvh.nodes, &bvh.triangles, all.len())?;
        let tris: Vec<[f32; 9]> = bvh
            .triangles
            .iter()
            .map(|&t| {
                let [a, b, c] = all[t as usize].1;
                [a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]]
            })
            .collect();
        let bvh4 = Bvh4::new(&bvh.nodes, &tris).map_err(|e| {
            bad(match e {
                NotATree::Shared => "a BVH node is the child of two nodes",
                NotATree::TooManyTriangles => {
                    "the BVH's leaves list more triangles than the file has"
                }
            })
        })?;
        let tri_face: Vec<u32> = bvh.triangles.iter().map(|&t| all[t as usize].0).collect();
        let (optics, material_names, element_material) = materials(file)?;
        let face_material: Vec<u32> = face_element
            .iter()
            .map(|&e| element_material[e as usize])
            .collect();
        let special = (0..tris.len() as u32)
            .filter(|&t| {
                let f = tri_face[t as usize];
                let o = &optics[face_material[f as usize] as usize];
                o.has_highlight() || o.reflects() || o.transmits()
            })
            .collect();
        let lights = file.display.point_lights.clone();
        check_lights(&lights, file.lights.len())?;
        let smooth = match &file.display.smooth {
            Some(weights) => {
                crate::smooth::Reconstruction::new(file)?;
                Some((fg.clone(), weights.clone()))
            }
            None => None,
        };
        let extent = bvh
            .nodes
            .first()
            .map_or(1.0, |root| length(sub(root.max, root.min)));
        Ok(TraceScene {
            #[cfg(feature = "gpu")]
            nodes: bvh.nodes.clone(),
            tris,
            bvh4,
            tri_face,
            tri_id: bvh.triangles.clone(),
            element_id: file.order.clone(),
            face_id: face_element
                .iter()
                .map(|&e| file.order[e as usize])
                .collect(),
            normals: fg
                .normals
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]])
                .collect(),
            face_material,
            special,
            optics,
            material_names,
            lights,
            groups: file.lights.len(),
            epsilon: 1e-5 * extent.max(f32::MIN_POSITIVE),
            has_smooth: smooth.is_some(),
            smooth,
        })
    }

    /// The nearest triangle `ray` hits in `(t_min, t_max)`; between triangles at the same
    /// distance, the lower leaf-order index.
    #[inline(always)]
    pub(crate) fn closest_hit(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        self.bvh4.closest_hit(ray, t_min, t_max)
    }

    /// [`TraceScene::closest_hit`] of four rays at once (a packet: `bvh4/packet.rs`), the same
    /// answers.
    #[inline(always)]
    pub(crate) fn closest_hit4(
        &self,
        rays: &[Ray; 4],
        t_min: f32,
        t_max: [f32; 4],
    ) -> [Option<Hit>; 4] {
        self.bvh4.closest_hit4(rays, t_min, t_max)
    }

    /// [`TraceScene::closest_hit`] of eight rays at once (a packet: `bvh4/packet8.rs`), the
    /// same answers; for CPUs where [`TraceScene::packets_of_eight`].
    #[inline(always)]
    pub(crate) fn closest_hit8(
        &self,
        rays: &[Ray; 8],
        t_min: f32,
        t_max: [f32; 8],
    ) -> [Option<Hit>; 8] {
        self.bvh4.closest_hit8(rays, t_min, t_max)
    }

    /// Whether closest hits are best traced eight rays at a time on this CPU (AVX2).
    pub(crate) fn packets_of_eight(&self) -> bool {
        Bvh4::packets_of_eight()
    }

    /// [`TraceScene::occluded`] of four rays at once (a packet: `bvh4/packet.rs`), the same
    /// answers.
    #[inline(always)]
    pub(crate) fn occluded4(&self, rays: &[Ray; 4], t_min: f32, t_max: [f32; 4]) -> [bool; 4] {
        self.bvh4.occluded4(rays, t_min, t_max)
    }

    /// Whether any triangle blocks `ray` in `(t_min, t_max)` (shadow rays: the first hit ends
    /// it).
    #[inline(always)]
    pub(crate) fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        self.bvh4.occluded(ray, t_min, t_max)
    }

    /// Number of elements.
    pub(crate) fn n(&self) -> usize {
        self.element_id.len()
    }

    /// The optics of display face `f` (its element's).
    #[inline(always)]
    pub(crate) fn optics_of(&self, f: u32) -> &Optics {
        &self.optics[self.face_material[f as usize] as usize]
    }
}

fn bad(what: &str) -> RuntimeError {
    input(format!(
        "cannot ray trace this file: {what}; it is damaged or was written by a broken \
         writer, re-bake it"
    ))
}

/// Every index a traversal follows stays in bounds, every leaf's triangles exist, the tree
/// terminates (children after their parent) and fits the traversal stack.
fn check_bvh(nodes: &[BvhNode], triangles: &[u32], count: usize) -> Result<(), RuntimeError> {
    if triangles.len() != count || triangles.iter().any(|&t| t as usize >= count) {
        return Err(bad(
            "the BVH's triangle list does not list the display triangles",
        ));
    }
    if nodes.is_empty() {
        return if count == 0 {
            Ok(())
        } else {
            Err(bad("the BVH has no nodes"))
        };
    }
    let mut depth = vec![0usize; nodes.len()];
    for (i, node) in nodes.iter().enumerate() {
        let finite = node.min.iter().chain(&node.max).all(|c| c.is_finite());
        if !finite {
            return Err(bad(&format!("BVH node {i} has a non-finite box")));
        }
        let (first, count_) = (node.first as usize, node.count as usize);
        if count_ > 0 {
            if first
                .checked_add(count_)
                .is_none_or(|end| end > triangles.len())
            {
                return Err(bad(&format!("BVH leaf {i} lists triangles past the end")));
            }
            continue;
        }
        if first <= i || first + 1 >= nodes.len() {
            return Err(bad(&format!(
                "BVH node {i}'s children {first} and {} are not after it and in the list",
                first + 1
            )));
        }
        for c in [first, first + 1] {
            depth[c] = depth[c].max(depth[i] + 1);
            if depth[c] >= MAX_BVH_DEPTH {
                return Err(input(format!(
                    "cannot ray trace this file: its BVH is deeper than {MAX_BVH_DEPTH} levels, \
                     more than the tracer's stack holds; re-bake it with this version of lrr"
                )));
            }
        }
    }
    Ok(())
}

type MaterialTables = (Vec<Optics>, Vec<String>, Vec<u32>);

/// The file's materials, or one diffuse material for all when it has none.
fn materials(file: &OperatorFile) -> Result<MaterialTables, RuntimeError> {
    let n = file.n as usize;
    let Some(m) = &file.display.materials else {
        return Ok((vec![Optics::DIFFUSE], vec![String::new()], vec![0; n]));
    };
    if m.materials.is_empty()
        || m.element_material.len() != n
        || m.element_material
            .iter()
            .any(|&i| i as usize >= m.materials.len())
    {
        return Err(bad("the materials do not name one material per element"));
    }
    let mut optics = Vec::with_capacity(m.materials.len());
    for mat in &m.materials {
        let unit = |v: &[f32; 3]| v.iter().all(|c| (0.0..=1.0).contains(c));
        let ok = unit(&mat.specular)
            && unit(&mat.mirror)
            && unit(&mat.transmission)
            && mat.shininess.is_finite()
            && mat.shininess >= 0.0
            && mat.ior.is_finite()
            && mat.ior >= 1.0;
        if !ok {
            return Err(bad(&format!(
                "material '{}' has a colour outside [0, 1], a negative or non-finite \
                 shininess or an index of refraction below 1",
                mat.name
            )));
        }
        optics.push(Optics {
            specular: mat.specular,
            shininess: mat.shininess,
            mirror: mat.mirror,
            transmission: mat.transmission,
            ior: mat.ior,
        });
    }
    let names = m.materials.iter().map(|m| m.name.clone()).collect();
    Ok((optics, names, m.element_material.clone()))
}

fn check_lights(lights: &[PointLight], groups: usize) -> Result<(), RuntimeError> {
    for l in lights {
        let finite = l.position.iter().all(|c| c.is_finite())
            && l.intensity.iter().all(|c| c.is_finite() && *c >= 0.0);
        if !finite || (l.group != PointLight::FIXED && l.group as usize >= groups) {
            return Err(bad(&format!(
                "point light '{}' has a non-finite position, a negative intensity or a group \
                 the file does not have",
                l.name
            )));
        }
    }
    Ok(())
}
