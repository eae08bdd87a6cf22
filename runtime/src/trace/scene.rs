//! What the tracer reads besides the rays' scene (`rays/scene.rs`: the display triangles and
//! the BVH), copied once from an operator file into flat arrays indexed by `u32` (the buffers a
//! WGSL twin binds): per display face its element's material, the materials' optics, the
//! point lights, the element order and the smooth reconstruction's weights.
//!
//! Everything the tracer indexes is checked here or in `RayScene::new`, so that no file (the
//! file's own validation included or not) can make the tracer read out of bounds or overflow
//! its traversal stack.

use lrr_formats::{Geometry, OperatorFile, PointLight, Smooth};

use crate::error::RuntimeError;
use crate::rays::{RayScene, V3, bad};

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
    /// The display triangles, their faces and the BVH (checked), what rays traverse.
    pub rays: RayScene,
    /// Per file position: the element's original id (the index into a frame's radiosity; the
    /// order the smooth reconstruction reads).
    pub element_id: Vec<u32>,
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
        let rays = RayScene::new(file)?;
        let n = rays.n();
        // Checked by `RayScene::new`: display faces naming elements below n, n element ids
        // in `order`.
        let faces = file.faces();
        let face_element: Vec<u32> = match faces.elements() {
            Some(e) => e.to_vec(),
            None => (0..n as u32).collect(),
        };
        let (optics, material_names, element_material) = materials(file)?;
        let face_material: Vec<u32> = face_element
            .iter()
            .map(|&e| element_material[e as usize])
            .collect();
        let special = (0..rays.tris.len() as u32)
            .filter(|&t| {
                let f = rays.tri_face[t as usize];
                let o = &optics[face_material[f as usize] as usize];
                o.has_highlight() || o.reflects() || o.transmits()
            })
            .collect();
        let lights = file.display.point_lights.clone();
        check_lights(&lights, file.lights.len())?;
        let smooth = match &file.display.smooth {
            Some(weights) => {
                crate::smooth::Reconstruction::new(file)?;
                Some((faces.geometry.clone(), weights.clone()))
            }
            None => None,
        };
        Ok(TraceScene {
            element_id: file.order.clone(),
            face_material,
            special,
            optics,
            material_names,
            lights,
            groups: file.lights.len(),
            has_smooth: smooth.is_some(),
            smooth,
            rays,
        })
    }

    /// Number of elements.
    pub(crate) fn n(&self) -> usize {
        self.rays.n()
    }

    /// The optics of display face `f` (its element's).
    #[inline(always)]
    pub(crate) fn optics_of(&self, f: u32) -> &Optics {
        &self.optics[self.face_material[f as usize] as usize]
    }
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
