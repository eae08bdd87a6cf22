//! `lrr export OUT.lrr -o FILE`: a frame of a baked operator as files other tools read, the
//! format from the extension (docs/EXPORTS.md):
//! - `.exr`: a lightmap atlas of the exitant radiance `B/π` (OpenEXR, linear RGB), all light
//!   groups together or one layer per group (`--layers groups`);
//! - `.glb` / `.gltf`: the baked scene with `exposure × B/π` per vertex (`COLOR_0`), and with
//!   `--lightmap` the atlas as a texture with its UVs.
//!
//! The pieces, bottom first: [`charts`] (coplanar connected elements, flattened),
//! [`atlas`] (packing with etagere), [`field`] (the frame's radiosity over the surface),
//! [`raster`] (texels from the field, dilated), [`scene_uv`] (the same over the scene's own
//! lightmap coordinates, section LIGHTMAP), [`gltf`] (the glTF document).

pub mod atlas;
pub mod charts;
pub mod field;
pub mod gltf;
pub mod raster;
pub mod scene_uv;

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Result, bail};
use clap::Args;
use lrr_runtime::{Operator, RgbMut};

use crate::emission::{self, EmissionArgs, Lighting, Reconstruct, reconstruction};
use crate::exr_image::{self, ExrSamples, RgbLayer};
use atlas::{Layout, Sizing};
use charts::Chart;
use field::Field;
use raster::Atlas;

#[derive(Debug, Args)]
pub struct ExportArgs {
    /// Operator file.
    pub file: PathBuf,
    /// Output: `.exr` (lightmap atlas), `.glb` or `.gltf` (scene with vertex colours).
    #[arg(long, short, value_name = "FILE")]
    pub output: PathBuf,
    #[command(flatten)]
    pub emission: EmissionArgs,
    /// How values inside elements come from the element values: `smooth` (the default when
    /// the file has smooth weights) or `flat` (the default otherwise, saying so).
    #[arg(long, value_enum)]
    pub reconstruct: Option<Reconstruct>,
    /// glTF: add the lightmap atlas as the base colour texture (PNG) with its UVs as
    /// TEXCOORD_0; the vertex values then move to the attribute `_RADIOSITY`.
    #[arg(long)]
    pub lightmap: bool,
    #[command(flatten)]
    pub lightmap_args: LightmapArgs,
    /// EXR: `all` (one RGB image, channels R, G, B) or `groups` (one layer per light group,
    /// channels NAME.R, NAME.G, NAME.B, each the group alone at its --group intensity, so an
    /// engine relights them by weighting the layers).
    #[arg(long, value_enum, default_value_t = Layers::All)]
    pub layers: Layers,
    /// EXR sample type: `half` or `float`.
    #[arg(long, value_enum, default_value_t = ExrSamples::Half)]
    pub samples: ExrSamples,
    /// glTF: the factor on B/π in the vertex colours and the texture, which are clamped to 1
    /// [default: 1 over the brightest value on a surface that does not emit].
    #[arg(long, value_name = "E")]
    pub exposure: Option<f32>,
}

/// The lightmap's flags, shared by `lrr export` and `lrr relight`.
#[derive(Debug, Args)]
pub struct LightmapArgs {
    /// Lightmap coordinates: `scene` (the scene's own TEXCOORD_1, kept by the bake; the
    /// default when the file has them) or `generated` (charts packed here).
    #[arg(long, value_enum)]
    pub uv: Option<UvSource>,
    /// Lightmap: a square atlas of N×N texels, the texel density the largest that packs
    /// [default: 1024 unless --texel-density is given].
    #[arg(long, value_name = "N", conflicts_with = "texel_density")]
    pub size: Option<usize>,
    /// Lightmap: texels per scene unit; the atlas is the smallest square (a multiple of 4
    /// texels) that packs.
    #[arg(long, value_name = "T")]
    pub texel_density: Option<f64>,
    /// Lightmap: texels of dilated border around each chart (bilinear filtering needs 1; mip
    /// levels more).
    #[arg(long, value_name = "P", default_value_t = 2)]
    pub padding: usize,
}

impl LightmapArgs {
    /// The layout these flags ask for (see [`LightmapLayout::new`]).
    pub fn layout(&self, op: &Operator) -> Result<LightmapLayout> {
        LightmapLayout::new(op, self.uv, self.size, self.texel_density, self.padding)
    }

    /// Whether any flag that shapes a lightmap was given.
    fn given(&self) -> bool {
        self.size.is_some() || self.texel_density.is_some() || self.uv.is_some()
    }
}

/// `--uv`: where lightmap texels go.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum UvSource {
    /// The scene's own lightmap coordinates (glTF TEXCOORD_1; section LIGHTMAP of the file).
    Scene,
    /// Charts of coplanar elements packed into an atlas here.
    Generated,
}

/// Where the texels of a lightmap go.
pub enum LightmapLayout {
    /// Charts packed by [`atlas::pack`].
    Generated { charts: Vec<Chart>, layout: Layout },
    /// The scene's coordinates over a `size × size` atlas, dilated `padding` rings.
    Scene { size: usize, padding: usize },
}

impl LightmapLayout {
    /// Chooses and lays out the lightmap as the flags ask: the scene's coordinates by default
    /// when the file has them. `--texel-density` needs generated charts.
    pub fn new(
        op: &Operator,
        uv: Option<UvSource>,
        size: Option<usize>,
        density: Option<f64>,
        padding: usize,
    ) -> Result<Self> {
        let has_scene_uv = op.file().display.lightmap.is_some();
        let source = uv.unwrap_or(if has_scene_uv && density.is_none() {
            UvSource::Scene
        } else {
            UvSource::Generated
        });
        match source {
            UvSource::Scene => {
                if !has_scene_uv {
                    bail!(
                        "--uv scene: the file has no lightmap coordinates of the scene (section \
                         LIGHTMAP: bake a scene whose every mesh has TEXCOORD_1 with this lrr), \
                         or use --uv generated"
                    );
                }
                if density.is_some() {
                    bail!(
                        "--texel-density sizes generated charts; the scene's lightmap \
                         coordinates fill the whole atlas: give --size N, or --uv generated"
                    );
                }
                let size = size.unwrap_or(1024);
                if !(1..=16384).contains(&size) {
                    bail!("--size {size}: the atlas must be 1 to 16384 texels a side");
                }
                Ok(Self::Scene { size, padding })
            }
            UvSource::Generated => {
                let charts = charts::charts(op.file().faces().geometry);
                let sizing = match (size, density) {
                    (_, Some(t)) => Sizing::Density(t),
                    (Some(n), None) => Sizing::Size(n),
                    (None, None) => Sizing::Size(1024),
                };
                let layout = atlas::pack(&charts, sizing, padding)?;
                Ok(Self::Generated { charts, layout })
            }
        }
    }

    /// Width and height in texels.
    pub fn size(&self) -> (usize, usize) {
        match self {
            Self::Generated { layout, .. } => (layout.width, layout.height),
            Self::Scene { size, .. } => (*size, *size),
        }
    }

    /// What the layout is, for messages and the files' notes.
    pub fn describe(&self) -> String {
        match self {
            Self::Generated { charts, layout } => format!(
                "{} generated charts at {:.6} texels per scene unit, padding {}",
                charts.len(),
                layout.density,
                layout.padding
            ),
            Self::Scene { padding, .. } => {
                format!("the scene's lightmap coordinates (TEXCOORD_1), dilated {padding} texels")
            }
        }
    }

    /// The lightmap UV of every display face corner (`4 s + c`) and its seam key.
    pub fn corner_uvs(&self, op: &Operator) -> (Vec<[f32; 2]>, Vec<u64>) {
        let g = op.file().faces().geometry;
        let n = g.vertex_count.len();
        let mut uvs = vec![[0.0; 2]; 4 * n];
        let mut seams = vec![0; 4 * n];
        match self {
            Self::Generated { charts, layout } => {
                for (c, chart) in charts.iter().enumerate() {
                    for &s in &chart.faces {
                        let s = s as usize;
                        for (k, p) in charts::corners(g, s).iter().enumerate() {
                            uvs[4 * s + k] = layout.uv(c, chart.flatten(*p));
                            seams[4 * s + k] = c as u64;
                        }
                    }
                }
            }
            Self::Scene { .. } => {
                let uv = &op
                    .file()
                    .display
                    .lightmap
                    .as_ref()
                    .expect("Scene needs LIGHTMAP")
                    .uv;
                for (i, (out, seam)) in uvs.iter_mut().zip(&mut seams).enumerate() {
                    *out = [uv[2 * i], uv[2 * i + 1]];
                    *seam =
                        u64::from(uv[2 * i].to_bits()) << 32 | u64::from(uv[2 * i + 1].to_bits());
                }
            }
        }
        (uvs, seams)
    }
}

/// The atlas of the exitant radiance `B/π` of `field` over `op`'s surfaces, laid out by `lay`.
pub fn lightmap_atlas(op: &Operator, field: &Field, lay: &LightmapLayout) -> Atlas {
    match lay {
        LightmapLayout::Generated { charts, layout } => radiance_atlas(op, field, charts, layout),
        LightmapLayout::Scene { size, padding } => {
            let file = op.file();
            let uv = &file
                .display
                .lightmap
                .as_ref()
                .expect("Scene needs LIGHTMAP")
                .uv;
            let value = |s, p| radiance(field, s, p);
            scene_uv::rasterise(file.faces().geometry, uv, *size, *size, *padding, &value)
        }
    }
}

/// `--layers`: what the EXR holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Layers {
    /// The frame's radiosity, all groups together.
    All,
    /// One layer per light group.
    Groups,
}

/// What the output's extension asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Exr,
    Glb,
    Gltf,
}

pub fn run(a: &ExportArgs, out: &mut dyn Write) -> Result<()> {
    let format = format(&a.output)?;
    check_flags(a, format)?;
    let op = Operator::load(&a.file).map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?;
    let lighting = a.emission.lighting(&op)?;
    match format {
        Format::Exr => export_exr(a, &op, &lighting, out),
        Format::Glb | Format::Gltf => export_gltf(a, &op, &lighting, format == Format::Glb, out),
    }
}

fn format(path: &Path) -> Result<Format> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("exr") => Ok(Format::Exr),
        Some("glb") => Ok(Format::Glb),
        Some("gltf") => Ok(Format::Gltf),
        _ => bail!(
            "{}: unknown export format; the extension chooses it: .exr (lightmap), .glb or .gltf (scene)",
            path.display()
        ),
    }
}

/// Flags that do not apply to the format are errors, not silently ignored.
fn check_flags(a: &ExportArgs, format: Format) -> Result<()> {
    let name = a.output.display();
    if format == Format::Exr {
        if a.lightmap {
            bail!("--lightmap is for glTF outputs ({name} is an EXR lightmap already)");
        }
        if a.exposure.is_some() {
            bail!("--exposure is for glTF outputs (an EXR holds B/π unscaled)");
        }
    } else {
        if a.layers != Layers::All {
            bail!("--layers groups is for EXR outputs, not {name}");
        }
        if !a.lightmap && a.lightmap_args.given() {
            bail!("--size, --texel-density and --uv shape a lightmap: add --lightmap for {name}");
        }
        if let Some(e) = a.exposure
            && !(e.is_finite() && e > 0.0)
        {
            bail!("--exposure {e}: must be a finite number > 0");
        }
    }
    Ok(())
}

/// The lightmap's layout as the flags ask.
fn lay_out(a: &ExportArgs, op: &Operator) -> Result<LightmapLayout> {
    a.lightmap_args.layout(op)
}

/// The exitant radiance `B/π` of `field` at point `p` of display face `s`; None for a face whose
/// element is hidden in every frame (left to dilation).
fn radiance(field: &Field, s: usize, p: glam::DVec3) -> Option<[f32; 3]> {
    (!field.hidden(s)).then(|| field.at(s, p).map(|v| v / std::f32::consts::PI))
}

/// The atlas of the exitant radiance `B/π` of `field` over the charts of `op`'s display faces.
pub fn radiance_atlas(op: &Operator, field: &Field, charts: &[Chart], layout: &Layout) -> Atlas {
    let value = |s, p| radiance(field, s, p);
    raster::rasterise(op.file().faces().geometry, charts, layout, &value)
}

fn export_exr(
    a: &ExportArgs,
    op: &Operator,
    lighting: &Lighting,
    out: &mut dyn Write,
) -> Result<()> {
    let lay = lay_out(a, op)?;
    let (width, height) = lay.size();
    let smooth = reconstruction(op, a.reconstruct, &a.file)?;
    let lights = a.emission.lights.lights(op)?;
    // The lights that are not surfaces: in the frame of all groups, or a layer of their own.
    let mut lit = None;
    let frames = match a.layers {
        Layers::All => {
            let frame = emission::frame(op, lighting, &lights, emission::Device::Cpu)?;
            let b = frame.shown.clone();
            lit = Some((0, frame));
            vec![(None, b)]
        }
        Layers::Groups => {
            let mut frames = group_frames(op, lighting)?;
            if !lights.is_empty() {
                let dark = Lighting::Emission(vec![[0.0; 3]; op.n()]);
                let frame = emission::frame(op, &dark, &lights, emission::Device::Cpu)?;
                lit = Some((frames.len(), frame));
                frames.push((Some("lights".to_string()), Vec::new()));
            }
            frames
        }
    };
    let mut atlases: Vec<(Option<String>, Atlas)> = Vec::new();
    for (i, (name, b)) in frames.iter().enumerate() {
        let field = match &lit {
            Some((j, frame)) if *j == i => {
                Field::new(op.file(), &frame.shown, smooth)?.with_direct(frame, op.file())
            }
            _ => Field::new(op.file(), b, smooth)?,
        };
        atlases.push((name.clone(), lightmap_atlas(op, &field, &lay)));
    }
    let layers: Vec<RgbLayer> = atlases
        .iter()
        .map(|(name, atlas)| RgbLayer {
            name: name.as_deref(),
            pixels: &atlas.pixels,
        })
        .collect();
    let note = format!(
        "exitant radiance B/pi (linear RGB, emission units per sr), reconstruction {}, {}",
        Field::new(op.file(), &vec![[0.0; 3]; op.n()], smooth)?.method(),
        lay.describe()
    );
    exr_image::write_rgb(&a.output, width, height, &layers, a.samples, &note)?;
    writeln!(
        out,
        "wrote {}: {width}×{height} texels, {} layer(s), {}",
        a.output.display(),
        layers.len(),
        lay.describe()
    )?;
    Ok(())
}

/// A named frame's radiosity per element (original ids); no name: all groups together.
type Frame = (Option<String>, Vec<[f32; 3]>);

/// One frame per light group: the group alone at its intensity (1 unless `--group` says), and
/// one named `ungrouped` for baked emission outside every group, if any.
fn group_frames(op: &Operator, lighting: &Lighting) -> Result<Vec<Frame>> {
    let count = op.light_groups().len();
    let intensities = match lighting {
        Lighting::Baked => vec![1.0; count],
        Lighting::Groups(a) => a.clone(),
        Lighting::Emission(_) => bail!("--layers groups takes --group intensities, not --emission"),
    };
    if count == 0 {
        bail!("--layers groups: the file has no light groups (re-bake a scene with emitters)");
    }
    let mut frames = Vec::new();
    for (g, name) in op.light_groups().enumerate() {
        let mut a = vec![0.0; count];
        a[g] = intensities[g];
        let mut b = vec![[0.0f32; 3]; op.n()];
        op.evaluate_groups(&a, RgbMut::triples(&mut b))?;
        frames.push((Some(name.to_string()), b));
    }
    if let Some(rest) = ungrouped_emission(op) {
        let mut b = vec![[0.0f32; 3]; op.n()];
        op.evaluate(&rest, &mut b)?;
        frames.push((Some("ungrouped".to_string()), b));
    }
    Ok(frames)
}

/// The baked emission of elements in no light group (original ids), if any emits.
fn ungrouped_emission(op: &Operator) -> Option<Vec<[f32; 3]>> {
    let file = op.file();
    let mut grouped = vec![false; op.n()];
    for g in &file.lights {
        for &s in &g.positions {
            grouped[s as usize] = true;
        }
    }
    let mut rest = vec![[0.0f32; 3]; op.n()];
    let mut any = false;
    for (s, &id) in file.order.iter().enumerate() {
        let e = [
            file.emission[3 * s],
            file.emission[3 * s + 1],
            file.emission[3 * s + 2],
        ];
        if !grouped[s] && e.iter().any(|&v| v > 0.0) {
            rest[id as usize] = e;
            any = true;
        }
    }
    any.then_some(rest)
}

fn export_gltf(
    a: &ExportArgs,
    op: &Operator,
    lighting: &Lighting,
    binary: bool,
    out: &mut dyn Write,
) -> Result<()> {
    let lights = a.emission.lights.lights(op)?;
    let frame = emission::frame(op, lighting, &lights, emission::Device::Cpu)?;
    let g = op.file().faces().geometry;
    let smooth = reconstruction(op, a.reconstruct, &a.file)?;
    let field = Field::new(op.file(), &frame.shown, smooth)?.with_direct(&frame, op.file());
    let exposure = a
        .exposure
        .unwrap_or_else(|| gltf::auto_exposure(op.file(), &field));
    let laid_out = if a.lightmap {
        Some(lay_out(a, op)?)
    } else {
        None
    };
    let lightmap = match &laid_out {
        Some(lay) => {
            let atlas = lightmap_atlas(op, &field, lay);
            // The atlas holds B/π; the PNG is exposure × that.
            let png = gltf::png(
                atlas.width,
                atlas.height,
                &atlas.pixels,
                exposure * std::f32::consts::PI,
            )?;
            let (uvs, seams) = lay.corner_uvs(op);
            Some(gltf::Lightmap { uvs, seams, png })
        }
        None => None,
    };
    let mesh = gltf::mesh(g, &field, exposure, lightmap.as_ref());
    let note = serde_json::json!({
        "lrr": {
            "quantity": "min(1, exposure * B/pi): exitant radiance of the Lambertian surfaces, linear RGB, clamped",
            "exposure": exposure,
            "vertex_values": if a.lightmap { "_RADIOSITY" } else { "COLOR_0" },
            "lightmap": if a.lightmap { "baseColorTexture on TEXCOORD_0 (PNG, sRGB, clamped to 1)" } else { "none" },
            "reconstruction": field.method(),
            "source": a.file.display().to_string(),
        }
    });
    let (root, bin) = gltf::document(&mesh, lightmap.as_ref().map(|l| l.png.as_slice()), &note)?;
    let bytes = gltf::encode(root, bin, binary)?;
    gltf::write(&a.output, &bytes)?;
    writeln!(
        out,
        "wrote {}: {} vertices, {} triangles, exposure {exposure:.6e} on B/π{}",
        a.output.display(),
        mesh.positions.len(),
        mesh.indices.len() / 3,
        match &laid_out {
            Some(lay) => format!(
                ", lightmap {}×{} texels ({})",
                lay.size().0,
                lay.size().1,
                lay.describe()
            ),
            None => String::new(),
        }
    )?;
    Ok(())
}
