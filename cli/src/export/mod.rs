//! `lrr export OUT.lrr -o FILE`: a frame of a baked operator as files other tools read, the
//! format from the extension (docs/EXPORTS.md):
//! - `.exr`: a lightmap atlas of the exitant radiance `B/π` (OpenEXR, linear RGB), all light
//!   groups together or one layer per group (`--layers groups`);
//! - `.glb` / `.gltf`: the baked scene with `exposure × B/π` per vertex (`COLOR_0`), and with
//!   `--lightmap` the atlas as a texture with its UVs.
//!
//! The pieces: [`field`] (the frame's radiosity over the surface, for vertex colours and the
//! direct light at lightmap samples), [`gltf`] (the glTF document). Lightmap texels come from
//! the runtime's [`Lightmap`] over the file's coordinates (sections LIGHTMAP and ATLAS: the
//! scene's own, or charts packed by the bake); `--size`, `--texel-density` and `--padding` pack
//! charts again with the bake's code (`lrr_precompute::display::{charts, atlas}`).

pub mod field;
pub mod gltf;

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Result, bail};
use clap::Args;
use lrr_formats::{LightmapSource, MAX_ATLAS_PADDING, MAX_ATLAS_SIDE};
use lrr_precompute::display::{self, atlas, charts};
use lrr_runtime::{Lightmap, LightmapValues, Operator, RgbMut};

use crate::emission::{self, EmissionArgs, Lighting, Reconstruct, reconstruction};
use crate::exr_image::{self, ExrSamples, RgbLayer};
use atlas::Sizing;
use field::Field;

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
    /// Lightmap coordinates: `scene` (the scene's own TEXCOORD_1, kept by the bake) or
    /// `generated` (charts packed by the bake, or here when a flag below reshapes them)
    /// [default: what the file holds].
    #[arg(long, value_enum)]
    pub uv: Option<UvSource>,
    /// Lightmap: a square atlas of N×N texels (generated charts are packed again here at the
    /// largest density that fits) [default: the file's atlas].
    #[arg(long, value_name = "N", conflicts_with = "texel_density")]
    pub size: Option<usize>,
    /// Lightmap: texels per scene unit; charts are packed again here into the smallest square
    /// (a multiple of 4 texels) that holds them.
    #[arg(long, value_name = "T")]
    pub texel_density: Option<f64>,
    /// Lightmap: texels of dilated border around each chart (bilinear filtering needs 1; mip
    /// levels more) [default: the file's atlas, else 2].
    #[arg(long, value_name = "P")]
    pub padding: Option<usize>,
}

impl LightmapArgs {
    /// The layout these flags ask for (see [`LightmapLayout::new`]).
    pub fn layout(&self, op: &Operator) -> Result<LightmapLayout> {
        LightmapLayout::new(op, self.uv, self.size, self.texel_density, self.padding)
    }

    /// Whether any flag that shapes a lightmap was given.
    fn given(&self) -> bool {
        self.size.is_some()
            || self.texel_density.is_some()
            || self.uv.is_some()
            || self.padding.is_some()
    }
}

/// `--uv`: where lightmap texels go.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum UvSource {
    /// The scene's own lightmap coordinates (glTF TEXCOORD_1; section LIGHTMAP of the file).
    Scene,
    /// Charts of coplanar faces packed into an atlas (by the bake, or here).
    Generated,
}

/// Where the texels of a lightmap go: coordinates at every display face corner over a
/// `width × height` atlas dilated `padding` rings. The file's own (sections LIGHTMAP and
/// ATLAS) unless the flags reshape them; the texels themselves come from the runtime's
/// [`Lightmap`], as an engine fills them.
pub struct LightmapLayout {
    /// `F * 8`: `u, v` of each display face corner, as section LIGHTMAP.
    uv: Vec<f32>,
    width: usize,
    height: usize,
    padding: usize,
    /// What the layout is, for messages and the files' notes.
    description: String,
}

impl LightmapLayout {
    /// Chooses and lays out the lightmap as the flags ask: the file's atlas by default; the
    /// scene's coordinates at another `size`; charts packed again at `size` or `density`.
    pub fn new(
        op: &Operator,
        uv: Option<UvSource>,
        size: Option<usize>,
        density: Option<f64>,
        padding: Option<usize>,
    ) -> Result<Self> {
        let file = op.file();
        let stored = file.display.lightmap.as_ref();
        let stored_source = stored.map(|l| match l.atlas {
            Some(a) => a.source,
            // Before format 1.6 LIGHTMAP held only the scene's coordinates.
            None => LightmapSource::Scene,
        });
        let source = uv.unwrap_or(match (stored_source, density) {
            (Some(LightmapSource::Scene), None) => UvSource::Scene,
            _ => UvSource::Generated,
        });
        let atlas = stored.and_then(|l| l.atlas);
        let padding = padding.unwrap_or(atlas.map_or(2, |a| a.padding as usize));
        if padding > MAX_ATLAS_PADDING as usize {
            bail!("--padding {padding}: at most {MAX_ATLAS_PADDING} texels");
        }
        match source {
            UvSource::Scene => {
                if stored_source != Some(LightmapSource::Scene) {
                    bail!(
                        "--uv scene: the file has no lightmap coordinates of the scene (section \
                         LIGHTMAP from TEXCOORD_1: bake a scene whose every mesh has TEXCOORD_1), \
                         or use --uv generated"
                    );
                }
                if density.is_some() {
                    bail!(
                        "--texel-density sizes generated charts; the scene's lightmap \
                         coordinates fill the whole atlas: give --size N, or --uv generated"
                    );
                }
                let side = atlas.map_or(1024, |a| a.width as usize);
                let (width, height) = match size {
                    Some(n) => (n, n),
                    None => (side, atlas.map_or(1024, |a| a.height as usize)),
                };
                if !(1..=MAX_ATLAS_SIDE as usize).contains(&width) {
                    bail!("--size {width}: the atlas must be 1 to {MAX_ATLAS_SIDE} texels a side");
                }
                Ok(Self {
                    uv: stored.expect("checked above").uv.clone(),
                    width,
                    height,
                    padding,
                    description: format!(
                        "the scene's lightmap coordinates (TEXCOORD_1), dilated {padding} texels"
                    ),
                })
            }
            UvSource::Generated => {
                let reuse = stored_source == Some(LightmapSource::Generated)
                    && size.is_none()
                    && density.is_none()
                    && atlas.is_some_and(|a| a.padding as usize == padding);
                if let (true, Some(a), Some(l)) = (reuse, atlas, stored) {
                    return Ok(Self {
                        uv: l.uv.clone(),
                        width: a.width as usize,
                        height: a.height as usize,
                        padding,
                        description: format!(
                            "the bake's generated charts at {:.6} texels per scene unit, padding \
                             {padding}",
                            a.density
                        ),
                    });
                }
                let g = file.faces().geometry;
                let charts = charts::charts(g);
                let sizing = match (size, density) {
                    (_, Some(t)) => Sizing::Density(t),
                    (Some(n), None) => Sizing::Size(n),
                    (None, None) => Sizing::Size(1024),
                };
                let layout = atlas::pack(&charts, sizing, padding).map_err(|e| {
                    anyhow::anyhow!("the lightmap (--size, --texel-density, --padding): {e}")
                })?;
                Ok(Self {
                    uv: display::chart_uvs(g, &charts, &layout),
                    width: layout.width,
                    height: layout.height,
                    padding,
                    description: format!(
                        "{} generated charts packed here at {:.6} texels per scene unit, padding \
                         {padding}",
                        charts.len(),
                        layout.density
                    ),
                })
            }
        }
    }

    /// Width and height in texels.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// What the layout is, for messages and the files' notes.
    pub fn describe(&self) -> String {
        self.description.clone()
    }

    /// The runtime's lightmap over this layout, reconstructed smooth or flat.
    pub fn lightmap(&self, op: &Operator, smooth: bool) -> Result<Lightmap> {
        let values = match smooth {
            true => LightmapValues::Smooth,
            false => LightmapValues::Flat,
        };
        let mut map = Lightmap::with_coordinates(
            op.file(),
            &self.uv,
            self.width,
            self.height,
            self.padding,
            Some(values),
        )?;
        map.set_threads(0);
        Ok(map)
    }

    /// The lightmap UV of every display face corner (`4 s + c`) and its seam key (corners
    /// with the same coordinates may be one exported vertex).
    pub fn corner_uvs(&self) -> (Vec<[f32; 2]>, Vec<u64>) {
        let uvs: Vec<[f32; 2]> = self.uv.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
        let seams = uvs
            .iter()
            .map(|[u, v]| u64::from(u.to_bits()) << 32 | u64::from(v.to_bits()))
            .collect();
        (uvs, seams)
    }
}

/// The atlas of the exitant radiance `B/π` of a frame over `op`'s surfaces, filled by `map`:
/// the bounced light `shown` reconstructed, plus (with `field` of a frame with lights) their
/// direct light at each sample, then dilated.
pub fn lightmap_atlas(
    map: &mut Lightmap,
    shown: &[[f32; 3]],
    field: Option<&Field>,
) -> Result<Vec<[f32; 3]>> {
    let mut texels = vec![[0.0f32; 3]; map.width() * map.height()];
    map.fill_samples(shown, &mut texels)?;
    if let Some(field) = field.filter(|f| f.has_direct()) {
        for s in map.samples() {
            let d = field.direct(s.face, s.point);
            for c in 0..3 {
                texels[s.texel][c] += d[c] * std::f32::consts::FRAC_1_PI;
            }
        }
    }
    map.dilate(&mut texels)?;
    Ok(texels)
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

fn export_exr(
    a: &ExportArgs,
    op: &Operator,
    lighting: &Lighting,
    out: &mut dyn Write,
) -> Result<()> {
    let lay = a.lightmap_args.layout(op)?;
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
    let mut map = lay.lightmap(op, smooth.is_some())?;
    let mut atlases: Vec<(Option<String>, Vec<[f32; 3]>)> = Vec::new();
    for (i, (name, b)) in frames.iter().enumerate() {
        let texels = match &lit {
            Some((j, frame)) if *j == i => {
                let field =
                    Field::new(op.file(), &frame.shown, smooth)?.with_direct(frame, op.file());
                lightmap_atlas(&mut map, &frame.shown, Some(&field))?
            }
            _ => lightmap_atlas(&mut map, b, None)?,
        };
        atlases.push((name.clone(), texels));
    }
    let layers: Vec<RgbLayer> = atlases
        .iter()
        .map(|(name, texels)| RgbLayer {
            name: name.as_deref(),
            pixels: texels,
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
        Some(a.lightmap_args.layout(op)?)
    } else {
        None
    };
    let lightmap = match &laid_out {
        Some(lay) => {
            let mut map = lay.lightmap(op, smooth.is_some())?;
            let texels = lightmap_atlas(&mut map, &frame.shown, Some(&field))?;
            // The atlas holds B/π; the PNG is exposure × that.
            let (width, height) = lay.size();
            let png = gltf::png(width, height, &texels, exposure * std::f32::consts::PI)?;
            let (uvs, seams) = lay.corner_uvs();
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
