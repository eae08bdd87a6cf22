//! The baked scene as glTF 2.0 (written with gltf-json; `.glb` through the gltf crate's GLB
//! container, `.gltf` with its buffer as a base64 data URI).
//!
//! One mesh, one primitive: the display triangles (the fan of each element of GEOMETRY, file
//! order), counter-clockwise around the element normals. Vertices are shared where the field
//! shares corners ([`Field::vertex_key`]) and, with a lightmap, within one chart only.
//! - `POSITION`, `NORMAL` (the element's unit normal);
//! - `COLOR_0` (float RGB): `exposure × B/π`, the exitant radiance of a Lambertian surface
//!   scaled by `exposure` (stated in the material's and the asset's `extras`) and clamped to
//!   [0, 1] as glTF requires of colours, so a viewer shows the relit scene; the material is unlit (`KHR_materials_unlit`, base colour 1:
//!   `COLOR_0` multiplies it, and B already holds the reflectance);
//! - with a lightmap: `TEXCOORD_0` the lightmap UVs and the atlas as the base colour texture
//!   (PNG, sRGB, `exposure × B/π` clamped to 1); the vertex values move to the attribute
//!   `_RADIOSITY` (same values as `COLOR_0` would hold), so the viewer shows the texture alone.

use std::collections::HashMap;
use std::path::Path;

use anyhow::{Context, Result};
use base64::Engine;
use gltf_json as json;
use json::validation::Checked::Valid;
use json::validation::USize64;
use lrr_formats::{Geometry, OperatorFile};

use super::field::Field;
use lrr_precompute::display::charts::{corners, normal};

/// The exported triangles with their vertex attributes.
#[derive(Debug, Clone, Default)]
pub struct MeshData {
    pub positions: Vec<[f32; 3]>,
    pub normals: Vec<[f32; 3]>,
    /// `exposure × B/π` per vertex, clamped to [0, 1] (glTF colours are).
    pub colours: Vec<[f32; 3]>,
    /// Lightmap UVs, when there is a lightmap.
    pub uvs: Option<Vec<[f32; 2]>>,
    pub indices: Vec<u32>,
}

/// The lightmap a mesh refers to: the lightmap UV of every display face corner and the seam it
/// lies on (corners share a vertex only on the same seam), and the image.
pub struct Lightmap {
    /// `F * 4`: UV of corner `c` of display face `s` at `4 s + c`.
    pub uvs: Vec<[f32; 2]>,
    /// `F * 4`: the seam key of each corner (generated: the chart; the scene's: the UV bits).
    pub seams: Vec<u64>,
    pub png: Vec<u8>,
}

/// The mesh of `g` (the file's display faces) with the field's values (`exposure × B/π`) and,
/// with `lightmap`, its UVs.
pub fn mesh(g: &Geometry, field: &Field, exposure: f32, lightmap: Option<&Lightmap>) -> MeshData {
    let n = g.vertex_count.len();
    let scale = exposure / std::f32::consts::PI;
    let mut out = MeshData {
        uvs: lightmap.map(|_| Vec::new()),
        ..MeshData::default()
    };
    let mut ids: HashMap<(u64, u64), u32> = HashMap::new();
    for s in 0..n {
        let pts = corners(g, s);
        let nrm = normal(g, s);
        let mut vertex = |c: usize| -> u32 {
            let key = (
                field.vertex_key(s, c),
                lightmap.map_or(0, |l| l.seams[4 * s + c]),
            );
            *ids.entry(key).or_insert_with(|| {
                let p = pts[c];
                out.positions.push([p.x as f32, p.y as f32, p.z as f32]);
                out.normals.push([nrm.x as f32, nrm.y as f32, nrm.z as f32]);
                out.colours
                    .push(field.corner(s, c).map(|v| (v * scale).clamp(0.0, 1.0)));
                if let (Some(uvs), Some(l)) = (out.uvs.as_mut(), lightmap) {
                    uvs.push(l.uvs[4 * s + c]);
                }
                (out.positions.len() - 1) as u32
            })
        };
        let v: Vec<u32> = (0..pts.len()).map(&mut vertex).collect();
        // The fan of display.rs, turned if the corners run clockwise around the normal.
        let turned = (pts[1] - pts[0]).cross(pts[2] - pts[0]).dot(nrm) < 0.0;
        for i in 1..pts.len() - 1 {
            let (b, c) = if turned {
                (v[i + 1], v[i])
            } else {
                (v[i], v[i + 1])
            };
            out.indices.extend([v[0], b, c]);
        }
    }
    out
}

/// The default exposure: 1 over the brightest radiance `B/π` at a corner of a display face whose
/// element does not emit (emitters then show clamped to white, as lamps do in a photograph);
/// over the brightest of all when every element emits; 1 for a dark frame.
pub fn auto_exposure(file: &OperatorFile, field: &Field) -> f32 {
    let faces = file.faces();
    let g = faces.geometry;
    let emits = |s: usize| {
        let e = faces.element(s);
        file.emission[3 * e..3 * e + 3].iter().any(|&e| e > 0.0)
    };
    let brightest = |skip_emitters: bool| {
        (0..g.vertex_count.len())
            .filter(|&s| !(skip_emitters && emits(s)))
            .flat_map(|s| (0..usize::from(g.vertex_count[s])).map(move |c| (s, c)))
            .map(|(s, c)| field.corner(s, c).into_iter().fold(0.0f32, f32::max))
            .fold(0.0f32, f32::max)
            / std::f32::consts::PI
    };
    let b = match brightest(true) {
        b if b > 0.0 => b,
        _ => brightest(false),
    };
    if b > 0.0 && (1.0 / b).is_finite() {
        1.0 / b
    } else {
        1.0
    }
}

/// Bytes appended to the buffer, 4-aligned, as a buffer view.
struct Bin {
    bytes: Vec<u8>,
}

impl Bin {
    fn view(
        &mut self,
        root: &mut json::Root,
        data: &[u8],
        target: Option<json::buffer::Target>,
    ) -> json::Index<json::buffer::View> {
        while !self.bytes.len().is_multiple_of(4) {
            self.bytes.push(0);
        }
        let offset = self.bytes.len();
        self.bytes.extend_from_slice(data);
        root.push(json::buffer::View {
            buffer: json::Index::new(0),
            byte_length: USize64::from(data.len()),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: None,
            name: None,
            target: target.map(Valid),
            extensions: None,
            extras: Default::default(),
        })
    }

    /// A tightly packed f32 accessor of `components` per element (`VEC2`/`VEC3`), with min/max
    /// when `bounds`.
    fn floats<const N: usize>(
        &mut self,
        root: &mut json::Root,
        values: &[[f32; N]],
        bounds: bool,
    ) -> json::Index<json::Accessor> {
        let data: Vec<u8> = values
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let view = self.view(root, &data, Some(json::buffer::Target::ArrayBuffer));
        let (min, max) = if bounds {
            let mut lo = [f32::INFINITY; N];
            let mut hi = [f32::NEG_INFINITY; N];
            for v in values {
                for k in 0..N {
                    lo[k] = lo[k].min(v[k]);
                    hi[k] = hi[k].max(v[k]);
                }
            }
            (
                Some(json::Value::from(lo.to_vec())),
                Some(json::Value::from(hi.to_vec())),
            )
        } else {
            (None, None)
        };
        let type_ = if N == 2 {
            json::accessor::Type::Vec2
        } else {
            json::accessor::Type::Vec3
        };
        root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(values.len()),
            component_type: Valid(json::accessor::GenericComponentType(
                json::accessor::ComponentType::F32,
            )),
            extensions: None,
            extras: Default::default(),
            type_: Valid(type_),
            min,
            max,
            name: None,
            normalized: false,
            sparse: None,
        })
    }

    fn indices(&mut self, root: &mut json::Root, indices: &[u32]) -> json::Index<json::Accessor> {
        let data: Vec<u8> = indices.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(root, &data, Some(json::buffer::Target::ElementArrayBuffer));
        root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(indices.len()),
            component_type: Valid(json::accessor::GenericComponentType(
                json::accessor::ComponentType::U32,
            )),
            extensions: None,
            extras: Default::default(),
            type_: Valid(json::accessor::Type::Scalar),
            min: None,
            max: None,
            name: None,
            normalized: false,
            sparse: None,
        })
    }
}

/// The glTF document of `mesh` and its binary buffer (not yet given a URI); `note` is the JSON
/// object put into the asset's and the material's `extras`.
pub fn document(
    mesh: &MeshData,
    png: Option<&[u8]>,
    note: &serde_json::Value,
) -> Result<(json::Root, Vec<u8>)> {
    let mut root = json::Root::default();
    let mut bin = Bin { bytes: Vec::new() };
    let extras = Some(serde_json::value::to_raw_value(note).context("the export note")?);
    root.asset = json::Asset {
        generator: Some(format!("lrr {}", env!("CARGO_PKG_VERSION"))),
        extras: extras.clone(),
        ..Default::default()
    };
    let mut attributes = std::collections::BTreeMap::new();
    attributes.insert(
        Valid(json::mesh::Semantic::Positions),
        bin.floats(&mut root, &mesh.positions, true),
    );
    attributes.insert(
        Valid(json::mesh::Semantic::Normals),
        bin.floats(&mut root, &mesh.normals, false),
    );
    let colours = bin.floats(&mut root, &mesh.colours, false);
    let mut base_color_texture = None;
    if let (Some(uvs), Some(png)) = (&mesh.uvs, png) {
        attributes.insert(
            Valid(json::mesh::Semantic::Extras("RADIOSITY".into())),
            colours,
        );
        attributes.insert(
            Valid(json::mesh::Semantic::TexCoords(0)),
            bin.floats(&mut root, uvs, false),
        );
        let view = bin.view(&mut root, png, None);
        let image = root.push(json::Image {
            buffer_view: Some(view),
            mime_type: Some(json::image::MimeType("image/png".into())),
            name: Some("lightmap".into()),
            uri: None,
            extensions: None,
            extras: Default::default(),
        });
        let sampler = root.push(json::texture::Sampler {
            mag_filter: Some(Valid(json::texture::MagFilter::Linear)),
            min_filter: Some(Valid(json::texture::MinFilter::Linear)),
            wrap_s: Valid(json::texture::WrappingMode::ClampToEdge),
            wrap_t: Valid(json::texture::WrappingMode::ClampToEdge),
            ..Default::default()
        });
        let texture = root.push(json::Texture {
            name: Some("lightmap".into()),
            sampler: Some(sampler),
            source: image,
            extensions: None,
            extras: Default::default(),
        });
        base_color_texture = Some(json::texture::Info {
            index: texture,
            tex_coord: 0,
            extensions: None,
            extras: Default::default(),
        });
    } else {
        attributes.insert(Valid(json::mesh::Semantic::Colors(0)), colours);
    }
    let indices = bin.indices(&mut root, &mesh.indices);
    let material = root.push(json::Material {
        name: Some("lrr radiosity (unlit)".into()),
        pbr_metallic_roughness: json::material::PbrMetallicRoughness {
            base_color_factor: json::material::PbrBaseColorFactor([1.0; 4]),
            base_color_texture,
            metallic_factor: json::material::StrengthFactor(0.0),
            roughness_factor: json::material::StrengthFactor(1.0),
            ..Default::default()
        },
        extensions: Some(json::extensions::material::Material {
            unlit: Some(json::extensions::material::Unlit {}),
            ..Default::default()
        }),
        extras: extras.clone(),
        ..Default::default()
    });
    let mesh_index = root.push(json::Mesh {
        name: Some("baked scene".into()),
        primitives: vec![json::mesh::Primitive {
            attributes,
            extensions: None,
            extras: Default::default(),
            indices: Some(indices),
            material: Some(material),
            mode: Valid(json::mesh::Mode::Triangles),
            targets: None,
        }],
        extensions: None,
        extras: Default::default(),
        weights: None,
    });
    let node = root.push(json::Node {
        mesh: Some(mesh_index),
        name: Some("baked scene".into()),
        ..Default::default()
    });
    root.scenes.push(json::Scene {
        nodes: vec![node],
        name: Some("lrr".into()),
        extensions: None,
        extras: Default::default(),
    });
    root.scene = Some(json::Index::new(0));
    root.extensions_used.push("KHR_materials_unlit".into());
    while !bin.bytes.len().is_multiple_of(4) {
        bin.bytes.push(0);
    }
    root.buffers.push(json::Buffer {
        byte_length: USize64::from(bin.bytes.len()),
        name: None,
        uri: None,
        extensions: None,
        extras: Default::default(),
    });
    Ok((root, bin.bytes))
}

/// The bytes of `.glb` (binary) or `.gltf` (JSON, buffer as a data URI).
pub fn encode(mut root: json::Root, bin: Vec<u8>, binary: bool) -> Result<Vec<u8>> {
    if binary {
        let text = json::serialize::to_vec(&root).context("serialising glTF")?;
        let glb = gltf::binary::Glb {
            header: gltf::binary::Header {
                magic: *b"glTF",
                version: 2,
                // Filled in by `to_vec`'s writer from the chunk lengths.
                length: 0,
            },
            json: std::borrow::Cow::Owned(text),
            bin: Some(std::borrow::Cow::Owned(bin)),
        };
        return glb
            .to_vec()
            .map_err(|e| anyhow::anyhow!("encoding GLB: {e}"));
    }
    let data = base64::engine::general_purpose::STANDARD.encode(&bin);
    root.buffers[0].uri = Some(format!("data:application/octet-stream;base64,{data}"));
    json::serialize::to_vec_pretty(&root).context("serialising glTF")
}

/// PNG bytes of an RGB atlas (`exposure × B/π` per texel, linear), sRGB-encoded, 8 bits.
pub fn png(width: usize, height: usize, pixels: &[[f32; 3]], exposure: f32) -> Result<Vec<u8>> {
    let scale = exposure / std::f32::consts::PI;
    let data: Vec<u8> = pixels
        .iter()
        .flat_map(|p| p.map(|v| (srgb((v * scale).clamp(0.0, 1.0)) * 255.0).round() as u8))
        .collect();
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, width as u32, height as u32);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut writer = encoder
        .write_header()
        .context("encoding the lightmap PNG")?;
    writer
        .write_image_data(&data)
        .context("encoding the lightmap PNG")?;
    writer.finish().context("encoding the lightmap PNG")?;
    Ok(out)
}

/// The sRGB transfer function.
fn srgb(v: f32) -> f32 {
    if v <= 0.0031308 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Writes `bytes` to `path` atomically.
pub fn write(path: &Path, bytes: &[u8]) -> Result<()> {
    lrr_formats::write_atomic(path, bytes).with_context(|| format!("writing {}", path.display()))
}
