//! The radiosity of one frame as a field over the surface, what every export samples: the
//! value at a point of a display face and at a face's corners, and which corners share one
//! exported vertex. The surface is the file's display faces
//! ([`OperatorFile::faces`]: section FACES, else GEOMETRY's elements, face = file position),
//! each showing its element's radiosity. This file is the one place the reconstruction is
//! chosen:
//! - smooth (the default when the file has SMOOTH weights): the runtime's
//!   [`Reconstruction`], smooth-vertex values interpolated by mean value coordinates; corners
//!   of one smooth vertex are one exported vertex;
//! - flat: the element's value over each of its faces; no corners are shared.
//!
//! A frame with lights that are not surfaces ([`Field::with_direct`]) reconstructs the bounced
//! light (`emission::Frame::shown`) and adds the direct light at the point or corner itself, so
//! shadow edges in a lightmap are as sharp as its texels, not as coarse as the elements.

use anyhow::Result;
use glam::DVec3;
use lrr_formats::OperatorFile;
use lrr_runtime::Reconstruction;

use crate::emission::Frame;

/// A frame's radiosity `B` (W/m² of exitance per channel, like the operator's) over the surface.
pub struct Field<'f> {
    /// `B` per display face (its element's).
    values: Vec<[f32; 3]>,
    /// Per display face: its element sees no patch and emits nothing, so it is black in every
    /// frame (the floor under a block): hidden from view, left out of lightmaps.
    hidden: Vec<bool>,
    /// The smooth reconstruction, this frame's smooth-vertex values and SMOOTH's corners.
    smooth: Option<SmoothFrame<'f>>,
    /// The frame's lights that are not surfaces, added per point; with the display faces.
    direct: Option<(&'f Frame, &'f OperatorFile)>,
}

type SmoothFrame<'f> = (Reconstruction<'f>, Vec<[f32; 3]>, &'f [u32]);

impl<'f> Field<'f> {
    /// The field of `radiosity` (per element, original ids) on `file`'s display faces, smooth
    /// through `smooth` (made from `file`) or flat.
    pub fn new(
        file: &'f OperatorFile,
        radiosity: &[[f32; 3]],
        smooth: Option<Reconstruction<'f>>,
    ) -> Result<Self> {
        let faces = file.faces();
        let elements = lrr_runtime::hidden_elements(file);
        let (values, hidden) = (0..faces.len())
            .map(|f| {
                let e = faces.element(f);
                (radiosity[file.order[e] as usize], elements[e])
            })
            .unzip();
        let smooth = match (smooth, &file.display.smooth) {
            (Some(r), Some(weights)) => {
                let mut vertices = vec![[0.0f32; 3]; r.vertex_count()];
                r.vertex_values(radiosity, &mut vertices)?;
                Some((r, vertices, weights.corners.as_slice()))
            }
            _ => None,
        };
        Ok(Self {
            values,
            hidden,
            smooth,
            direct: None,
        })
    }

    /// The field of `frame` (made with [`Field::new`] from `frame.shown`): the bounced light
    /// reconstructed over the surface plus the direct light of the frame's lights at each
    /// point.
    pub fn with_direct(mut self, frame: &'f Frame, file: &'f OperatorFile) -> Self {
        if !frame.lights.is_empty() {
            self.direct = Some((frame, file));
        }
        self
    }

    /// Whether the frame has lights that are not surfaces.
    pub fn has_direct(&self) -> bool {
        self.direct.is_some()
    }

    /// `ρ H` of the frame's lights that are not surfaces at `point` of display face `s` (zero
    /// without them).
    pub fn direct(&self, s: usize, point: [f32; 3]) -> [f32; 3] {
        let Some((frame, file)) = self.direct else {
            return [0.0; 3];
        };
        let faces = file.faces();
        let element = file.order[faces.element(s)] as usize;
        let n = faces.geometry.normal(s);
        frame.at(element, point, n)
    }

    /// Whether display face `s` is black in every frame because its element sees nothing (its
    /// row of `F_k`, or of every `Y_c`, is zero) and emits nothing.
    pub fn hidden(&self, s: usize) -> bool {
        self.hidden[s]
    }

    /// `B` at `point` of display face `s`.
    pub fn at(&self, s: usize, point: DVec3) -> [f32; 3] {
        let p = [point.x as f32, point.y as f32, point.z as f32];
        let b = match &self.smooth {
            Some((r, vertices, _)) => r.at(vertices, s, p),
            None => self.values[s],
        };
        add(b, self.direct(s, p))
    }

    /// `B` at corner `c` of display face `s`.
    pub fn corner(&self, s: usize, c: usize) -> [f32; 3] {
        let b = match &self.smooth {
            Some((r, vertices, _)) => r.corner_value(vertices, s, c),
            None => self.values[s],
        };
        let Some((_, file)) = self.direct else {
            return b;
        };
        let v = &file.faces().geometry.vertices[12 * s + 3 * c..12 * s + 3 * c + 3];
        add(b, self.direct(s, [v[0], v[1], v[2]]))
    }

    /// A key equal for corners that are one vertex of the exported mesh: the smooth vertex, or
    /// (flat) the corner itself.
    pub fn vertex_key(&self, s: usize, c: usize) -> u64 {
        match &self.smooth {
            Some((_, _, corners)) => u64::from(corners[4 * s + c]),
            None => 1 << 63 | (s as u64) << 2 | c as u64,
        }
    }

    /// How the values were reconstructed, for notes in the exported files.
    pub fn method(&self) -> &'static str {
        match self.smooth {
            Some(_) => "smooth (SMOOTH weights, mean value coordinates)",
            None => "flat (element values)",
        }
    }
}

fn add(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
