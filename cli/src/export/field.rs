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

use anyhow::Result;
use glam::DVec3;
use lrr_formats::{OperatorData, OperatorFile};
use lrr_runtime::Reconstruction;

/// A frame's radiosity `B` (W/m² of exitance per channel, like the operator's) over the surface.
pub struct Field<'f> {
    /// `B` per display face (its element's).
    values: Vec<[f32; 3]>,
    /// Per display face: its element sees no patch and emits nothing, so it is black in every
    /// frame (the floor under a block): hidden from view, left out of lightmaps.
    hidden: Vec<bool>,
    /// The smooth reconstruction, this frame's smooth-vertex values and SMOOTH's corners.
    smooth: Option<SmoothFrame<'f>>,
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
        let elements = hidden(file);
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
        })
    }

    /// Whether display face `s` is black in every frame because its element sees nothing (its
    /// row of `F_k`, or of every `Y_c`, is zero) and emits nothing.
    pub fn hidden(&self, s: usize) -> bool {
        self.hidden[s]
    }

    /// `B` at `point` of display face `s`.
    pub fn at(&self, s: usize, point: DVec3) -> [f32; 3] {
        match &self.smooth {
            Some((r, vertices, _)) => r.at(
                vertices,
                s,
                [point.x as f32, point.y as f32, point.z as f32],
            ),
            None => self.values[s],
        }
    }

    /// `B` at corner `c` of display face `s`.
    pub fn corner(&self, s: usize, c: usize) -> [f32; 3] {
        match &self.smooth {
            Some((r, vertices, _)) => r.corner_value(vertices, s, c),
            None => self.values[s],
        }
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

/// [`Field::hidden`] of every element, by file position.
fn hidden(file: &OperatorFile) -> Vec<bool> {
    let (n, k) = (file.n as usize, file.k as usize);
    let (matrix, blocks) = match &file.operator {
        OperatorData::Factored { fk, .. } => (fk, 1),
        OperatorData::PlainYk { yk } => (yk, file.channels as usize),
    };
    (0..n)
        .map(|s| {
            let dark = file.emission[3 * s..3 * s + 3].iter().all(|&e| e == 0.0);
            let sees_nothing = (0..blocks).all(|c| {
                let row = (c * n + s) * k;
                (row..row + k).all(|i| matrix.get(i) == Some(0.0))
            });
            dark && sees_nothing
        })
        .collect()
}
