//! What the file holds for display (format 1.2, LIGHTMAP 1.3, FACES 1.4, every section
//! optional): the smooth reconstruction weights, the materials a ray tracer shades with, point
//! lights, cameras, a flattened BVH over the display triangles, the scene's lightmap coordinates
//! and the display faces. This module holds the types alone (plain data, like `file.rs`); the
//! sections' bytes and invariants live beside the other sections'.
//!
//! # Display faces
//!
//! What is drawn are the *display faces*
//! ([`OperatorFile::faces`](crate::OperatorFile::faces)): the polygons of section FACES
//! ([`Faces`](crate::Faces), format 1.4) when the file has it, each showing the element at file
//! position [`Faces::element`](crate::Faces::element)`[f]` (an element of a dense mesh is drawn
//! as the many small input faces it groups, while GEOMETRY holds the planar polygon its form
//! factors were computed on); without FACES, GEOMETRY's polygons, face `f` showing element `f`
//! (`F = n`). Every display section is defined on the faces: SMOOTH's corners and LIGHTMAP's
//! coordinates are those of the faces' corners, the BVH's triangles those of the faces.
//!
//! # Display triangles
//!
//! The display triangles are not stored: they are the fan triangulation of the display faces,
//! face by face in order. Face `f` with `c` vertices `v_0 … v_{c-1}` gives the triangles
//! `(v_0, v_i, v_{i+1})` for `i = 1 … c - 2`, numbered on from those of face `f - 1`: a
//! triangle's number is its id in [`Bvh::triangles`], and
//! [`FacesRef::triangles`](crate::FacesRef::triangles) enumerates them with their face.
//!
//! # Smooth reconstruction
//!
//! A *smooth vertex* is a corner shared by elements of one smooth surface (same surface, same
//! material, no crease and no contact line between them). Its value is the weighted sum of the
//! radiosity of the elements that share it ([`Smooth::offsets`], [`Smooth::positions`],
//! [`Smooth::weights`]; on a surface's boundary, a linear extrapolation from the elements around
//! it, clamped at zero); inside a face the value is interpolated from its corners' values by
//! mean value coordinates (for a triangle: barycentric coordinates; exact for linear fields,
//! linear along each edge). Corners are those of the display faces, in the same order.

use crate::geometry::Faces;

/// Reconstruction weights: radiosity at any surface point from the element values.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Smooth {
    /// `F * 4`: the smooth vertex of each corner of each display face (`n * 4`, element corners
    /// in file order, without FACES); the unused fourth corner of a triangle is
    /// [`Smooth::NONE`]. Every used corner names a vertex `< offsets.len() - 1`.
    pub corners: Vec<u32>,
    /// `V + 1` offsets, `offsets[0] = 0`, increasing (at least one position per vertex), last =
    /// `positions.len()`: smooth vertex `v` sums `positions[offsets[v]..offsets[v + 1]]`.
    pub offsets: Vec<u32>,
    /// File positions (`< n`) contributing to each smooth vertex.
    pub positions: Vec<u32>,
    /// Their weights: finite, non-zero, within ±8, summing to 1 (within 1e-5) per smooth
    /// vertex. Inside a surface they are positive (a weighted mean); a vertex on a surface's
    /// boundary extrapolates the values around it linearly, with some weights negative, and its
    /// value is clamped at zero per channel (radiosity is never negative).
    pub weights: Vec<f32>,
}

impl Smooth {
    /// The corner value of a triangle's unused fourth corner.
    pub const NONE: u32 = u32::MAX;

    /// Number of smooth vertices `V`.
    pub fn vertex_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }
}

/// How a surface looks to a ray tracer, beyond its diffuse reflectance (which the radiosity
/// already holds). All colours linear RGB.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// Name (UTF-8, may be empty), for messages and `lrr render --explain`.
    pub name: String,
    /// Diffuse reflectance ρ (informational: the radiosity is already shaded with it), in [0, 1].
    pub diffuse: [f32; 3],
    /// Phong highlight colour `Ks` (MTL `Ks`), in [0, 1]; zero: no highlight.
    pub specular: [f32; 3],
    /// Phong exponent (MTL `Ns`), finite, >= 0.
    pub shininess: f32,
    /// Perfect-mirror reflectance, in [0, 1]; zero: no reflection ray.
    pub mirror: [f32; 3],
    /// Transmission filter of a dielectric (MTL `Tf`, or `1 - d`), in [0, 1]; zero: opaque.
    pub transmission: [f32; 3],
    /// Index of refraction (MTL `Ni`), finite, >= 1 (used only where `transmission` is non-zero;
    /// the mirror and refraction terms are then weighted by Fresnel).
    pub ior: f32,
}

impl Material {
    /// A purely diffuse material of reflectance `diffuse`.
    pub fn diffuse(name: impl Into<String>, diffuse: [f32; 3]) -> Self {
        Self {
            name: name.into(),
            diffuse,
            specular: [0.0; 3],
            shininess: 0.0,
            mirror: [0.0; 3],
            transmission: [0.0; 3],
            ior: 1.0,
        }
    }
}

/// The materials and which element uses which.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Materials {
    /// At least one material.
    pub materials: Vec<Material>,
    /// `n`: material of each file position, `< materials.len()`.
    pub element_material: Vec<u32>,
}

/// A point light. One that follows a light group is the highlight of that group's emitting
/// surface: the radiosity carries the surface's diffuse light, the tracer adds only the Phong
/// term, so nothing is counted twice. One of no group ([`PointLight::FIXED`]) is a light of its
/// own: since format 1.5's runtime the direct pass lights the elements with it every frame
/// (`lrr_runtime::lights::file_lights`), besides its highlights. A file baked before, whose
/// fixed point light stood for an emitting surface, now gets that light too; give it a group
/// (or leave it out with `--no-file-lights`).
#[derive(Debug, Clone, PartialEq)]
pub struct PointLight {
    /// Name (UTF-8, may be empty).
    pub name: String,
    /// Position, finite.
    pub position: [f32; 3],
    /// Radiant intensity per channel (irradiance `I cos θ / d²`), finite, >= 0.
    pub intensity: [f32; 3],
    /// Index of the light group (section LIGHTS) whose frame intensity and colour scale this
    /// light, or [`PointLight::FIXED`] for a light that does not follow any group.
    pub group: u32,
}

impl PointLight {
    /// The `group` of a light that follows no group.
    pub const FIXED: u32 = u32::MAX;
}

/// What a [`DirectLight`] is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DirectLightKind {
    /// A spot light: glTF's `KHR_lights_punctual` spot.
    Spot,
    /// A directional light (a sun).
    Directional,
    /// A sky of the same radiance from every direction.
    UniformSky,
    /// A sky of radiance `horizon + (zenith − horizon) · max(0, ω·up)`.
    GradientSky,
}

impl DirectLightKind {
    /// The code DIRECT_LIGHTS stores.
    pub fn code(self) -> u32 {
        match self {
            DirectLightKind::Spot => 0,
            DirectLightKind::Directional => 1,
            DirectLightKind::UniformSky => 2,
            DirectLightKind::GradientSky => 3,
        }
    }

    /// The kind of a stored code.
    pub fn from_code(code: u32) -> Option<Self> {
        Some(match code {
            0 => DirectLightKind::Spot,
            1 => DirectLightKind::Directional,
            2 => DirectLightKind::UniformSky,
            3 => DirectLightKind::GradientSky,
            _ => return None,
        })
    }

    /// A sky (at most one per file).
    pub fn is_sky(self) -> bool {
        matches!(
            self,
            DirectLightKind::UniformSky | DirectLightKind::GradientSky
        )
    }
}

/// A light that is not a surface and not a point light (section DIRECT_LIGHTS, format 1.5):
/// the runtime's direct pass lights the elements with it every frame and the operator bounces
/// that light (DESIGN.md §9). Fields by kind (unused ones zero):
///
/// | kind | `position` | `direction` | `strength` | `extra` |
/// |------|-----------|-------------|------------|---------|
/// | spot | position | where it points | W/sr on the axis | `[inner, outer, 0]`: glTF's cone half-angles, radians, `0 <= inner <= outer <= π/2` |
/// | directional | 0 | the direction light travels | irradiance, W/m² facing it | 0 |
/// | uniform sky | 0 | 0 | radiance, W/m²/sr | 0 |
/// | gradient sky | 0 | up | zenith radiance | horizon radiance |
#[derive(Debug, Clone, PartialEq)]
pub struct DirectLight {
    /// Name (UTF-8, may be empty).
    pub name: String,
    /// What it is.
    pub kind: DirectLightKind,
    /// See the table.
    pub position: [f32; 3],
    /// See the table; not normalised.
    pub direction: [f32; 3],
    /// See the table; finite, >= 0 per channel.
    pub strength: [f32; 3],
    /// See the table.
    pub extra: [f32; 3],
}

/// A pinhole camera.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    /// Name (UTF-8, unique within the file, may be empty for a single camera).
    pub name: String,
    /// Eye position, finite.
    pub eye: [f32; 3],
    /// Point looked at, finite, not the eye.
    pub target: [f32; 3],
    /// Up direction, finite, not parallel to `target - eye`.
    pub up: [f32; 3],
    /// Vertical field of view in degrees, in (0, 180).
    pub fov_y_deg: f32,
}

/// A node of the flattened binary BVH.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BvhNode {
    /// Lower corner of the node's box, finite.
    pub min: [f32; 3],
    /// Upper corner, `>= min`.
    pub max: [f32; 3],
    /// Interior node (`count == 0`): index of the first child; the second is `first + 1`, both
    /// greater than this node's index. Leaf: index of its first entry in [`Bvh::triangles`].
    pub first: u32,
    /// Leaf: number of triangles (at least 1); 0 for an interior node.
    pub count: u32,
}

/// A flattened binary BVH over the display triangles, built at bake time, so that the runtime
/// traces without building anything. Node 0 is the root.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Bvh {
    /// The nodes; the root first. Empty only when there are no triangles.
    pub nodes: Vec<BvhNode>,
    /// Triangle ids (the fan triangles of the display faces, see the module docs) in leaf
    /// order: a permutation of all display triangles.
    pub triangles: Vec<u32>,
}

/// Everything for display; each part may be absent (files without them still load).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Display {
    /// Smooth reconstruction weights (section SMOOTH).
    pub smooth: Option<Smooth>,
    /// Materials for the ray tracer (section MATERIALS).
    pub materials: Option<Materials>,
    /// Point lights (section POINT_LIGHTS; none: not written).
    pub point_lights: Vec<PointLight>,
    /// Spot and directional lights and the sky (section DIRECT_LIGHTS, format 1.5; none: not
    /// written).
    pub direct_lights: Vec<DirectLight>,
    /// The sky's transfer per element (section SKY_TRANSFER, format 1.5): `9 n` floats in file
    /// order, element `s`'s order-2 spherical harmonic coefficients `T_lm = ∫ V(x, ω) max(0,
    /// n·ω) Y_lm(ω) dω` averaged over the element (real orthonormal basis in the order `Y00,
    /// Y1-1 (y), Y10 (z), Y11 (x), Y2-2 (xy), Y2-1 (yz), Y20, Y21 (xz), Y22 (x² − y²)`), so a
    /// sky of coefficients `L_lm` gives the element's irradiance `Σ L_lm T_lm`. Finite.
    pub sky_transfer: Option<Vec<f32>>,
    /// Cameras (section CAMERAS; none: not written).
    pub cameras: Vec<Camera>,
    /// The BVH over the display triangles (section BVH).
    pub bvh: Option<Bvh>,
    /// The scene's own lightmap coordinates (section LIGHTMAP, format 1.3).
    pub lightmap: Option<LightmapUv>,
    /// The display faces (section FACES, format 1.4; written only when `Some`, and then
    /// required, see the crate docs): what is drawn when it is not GEOMETRY. SMOOTH, LIGHTMAP
    /// and the BVH are defined on the faces.
    pub faces: Option<Faces>,
}

impl Display {
    /// The length in bytes of the largest of the display sections' payloads as an operator
    /// file encodes them: what writing the file (one section at a time,
    /// [`OperatorFile::write`](crate::OperatorFile::write)) holds at once for its display.
    pub fn largest_payload_bytes(&self) -> usize {
        let names = |names: &mut dyn Iterator<Item = &str>| names.map(str::len).sum::<usize>();
        let smooth = self.smooth.as_ref().map_or(0, |s| {
            8 + 4 * (s.corners.len() + s.offsets.len() + s.positions.len() + s.weights.len())
        });
        let materials = self.materials.as_ref().map_or(0, |m| {
            8 + 64 * m.materials.len()
                + 4 * m.element_material.len()
                + names(&mut m.materials.iter().map(|m| m.name.as_str()))
        });
        let records = |count: usize, rows: usize, name_bytes: usize| match count {
            0 => 0,
            _ => 8 + 16 * rows * count + name_bytes,
        };
        let point_lights = records(
            self.point_lights.len(),
            2,
            names(&mut self.point_lights.iter().map(|l| l.name.as_str())),
        );
        let direct_lights = records(
            self.direct_lights.len(),
            4,
            names(&mut self.direct_lights.iter().map(|l| l.name.as_str())),
        );
        let cameras = records(
            self.cameras.len(),
            3,
            names(&mut self.cameras.iter().map(|c| c.name.as_str())),
        );
        let bvh = self
            .bvh
            .as_ref()
            .map_or(0, |b| 8 + 32 * b.nodes.len() + 4 * b.triangles.len());
        let lightmap = self.lightmap.as_ref().map_or(0, |l| 4 * l.uv.len());
        let faces = self.faces.as_ref().map_or(0, |f| {
            let count = f.element.len();
            8 + 4 * count
                + count.next_multiple_of(4)
                + 4 * (f.geometry.vertices.len() + f.geometry.normals.len())
        });
        let sky = self.sky_transfer.as_ref().map_or(0, |t| 4 * t.len());
        let atlas = match self.lightmap.as_ref().and_then(|l| l.atlas.as_ref()) {
            Some(_) => 24,
            None => 0,
        };
        [
            smooth,
            materials,
            point_lights,
            direct_lights,
            cameras,
            bvh,
            lightmap,
            faces,
            sky,
            atlas,
        ]
        .into_iter()
        .max()
        .unwrap_or(0)
    }
}

/// Lightmap texture coordinates from the scene (glTF `TEXCOORD_1`): where each display face's
/// corner lies in the user's lightmap atlas, `[0, 1]²` the atlas (values outside wrap or clamp as the
/// user's sampler does; exports keep what falls inside).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LightmapUv {
    /// `F * 4 * 2`: `u, v` of each corner of each display face (`n * 4 * 2`, element corners in
    /// file order as GEOMETRY stores them, without FACES); finite; a triangle's unused fourth
    /// corner is zeros.
    pub uv: Vec<f32>,
    /// The atlas these coordinates address (section ATLAS, format 1.6); `None` in files made
    /// before it (a reader then chooses a size).
    pub atlas: Option<LightmapAtlas>,
}

/// Where LIGHTMAP's coordinates came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LightmapSource {
    /// The scene's own (glTF `TEXCOORD_1`): any atlas size addresses them.
    Scene,
    /// Charts of the display faces packed by the bake for exactly this atlas size.
    Generated,
}

/// The atlas of section ATLAS: its size in texels, the padding the charts were packed with (or,
/// for the scene's coordinates, the dilation the bake suggests) and the texel density.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightmapAtlas {
    /// Texels across, 1 to [`MAX_ATLAS_SIDE`].
    pub width: u32,
    /// Texels down, 1 to [`MAX_ATLAS_SIDE`].
    pub height: u32,
    /// Rings of texels dilated around what the faces cover, at most [`MAX_ATLAS_PADDING`].
    pub padding: u32,
    /// Where the coordinates came from.
    pub source: LightmapSource,
    /// Texels per scene unit of the generated charts (finite, > 0); 0 for the scene's own.
    pub density: f64,
}

/// The largest atlas side a file may name.
pub const MAX_ATLAS_SIDE: u32 = 16384;
/// The largest padding a file may name.
pub const MAX_ATLAS_PADDING: u32 = 64;
