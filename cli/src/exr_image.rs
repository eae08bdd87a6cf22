//! Linear RGB images as OpenEXR through the `exr` crate: one image (channels `R`, `G`, `B`) or
//! several layers in one part (channels `NAME.R`, `NAME.G`, `NAME.B`, OpenEXR's layer naming,
//! which compositors and engines read as layers), as binary16 or f32, written atomically.
//! Shared by `lrr export` (lightmaps) and any command writing a linear image.

use std::path::Path;

use anyhow::{Context, Result, bail};
use exr::prelude::*;

/// How samples are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ExrSamples {
    /// binary16 (`half`): 11 significant bits, up to 65504; what engines load as lightmaps.
    Half,
    /// f32.
    Float,
}

/// One layer: `name` (`None`: plain `R`, `G`, `B`) and `width * height` RGB pixels, rows top
/// to bottom.
pub struct RgbLayer<'a> {
    pub name: Option<&'a str>,
    pub pixels: &'a [[f32; 3]],
}

/// Writes `layers` (all `width × height`) as one EXR part to `path` (temporary file + rename),
/// with `note` as the text attribute `lrr` (what the values are). Channel samples are rounded
/// to `samples`; values must be finite.
pub fn write_rgb(
    path: &Path,
    width: usize,
    height: usize,
    layers: &[RgbLayer<'_>],
    samples: ExrSamples,
    note: &str,
) -> Result<()> {
    let bytes = encode(width, height, layers, samples, note)?;
    lrr_formats::write_atomic(path, &bytes).with_context(|| format!("writing {}", path.display()))
}

/// The bytes of [`write_rgb`].
pub fn encode(
    width: usize,
    height: usize,
    layers: &[RgbLayer<'_>],
    samples: ExrSamples,
    note: &str,
) -> Result<Vec<u8>> {
    if width == 0 || height == 0 || layers.is_empty() {
        bail!("an EXR image needs at least one layer of at least 1×1 pixels");
    }
    let mut channels = SmallVec::<[AnyChannel<FlatSamples>; 4]>::new();
    for layer in layers {
        if layer.pixels.len() != width * height {
            bail!(
                "layer {:?}: {} pixels for a {width}×{height} image",
                layer.name,
                layer.pixels.len()
            );
        }
        if layer.pixels.iter().flatten().any(|v| !v.is_finite()) {
            bail!("layer {:?}: a non-finite value", layer.name);
        }
        for (c, letter) in ["R", "G", "B"].iter().enumerate() {
            let name = match layer.name {
                Some(n) => format!("{n}.{letter}"),
                None => letter.to_string(),
            };
            let text = Text::new_or_none(&name).with_context(|| {
                format!("EXR channel name '{name}': only characters up to U+00FF are stored")
            })?;
            let values = layer.pixels.iter().map(|p| p[c]);
            let data = match samples {
                ExrSamples::Half => FlatSamples::F16(values.map(f16::from_f32).collect()),
                ExrSamples::Float => FlatSamples::F32(values.collect()),
            };
            channels.push(AnyChannel::new(text, data));
        }
    }
    let channels = AnyChannels::sort(channels);
    let names: Vec<&Text> = channels.list.iter().map(|c| &c.name).collect();
    if names.windows(2).any(|w| w[0] == w[1]) {
        bail!("two EXR layers share a name");
    }
    let mut attributes = ImageAttributes::new(IntegerBounds::from_dimensions((width, height)));
    // One entry: the crate writes `other` in HashMap order, so more would make the bytes vary.
    attributes.other.insert(
        Text::from("lrr"),
        AttributeValue::Text(Text::new_or_none(note).context("the EXR note must be Latin-1")?),
    );
    let layer = Layer::new(
        (width, height),
        LayerAttributes::default(),
        Encoding::FAST_LOSSLESS,
        channels,
    );
    let image = Image::new(attributes, layer);
    let mut bytes = std::io::Cursor::new(Vec::new());
    // Sequential: the parallel writer stores blocks in the order they finish (varying bytes).
    image
        .write()
        .non_parallel()
        .to_buffered(&mut bytes)
        .context("encoding the EXR image")?;
    Ok(bytes.into_inner())
}
