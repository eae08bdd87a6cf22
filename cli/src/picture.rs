//! What a traced image needs around the tracer, shared by `lrr render` (one frame) and
//! `lrr relight --images` (a sequence): the camera flags and the file's named cameras
//! ([`CameraArgs`]), the image size, and the two outputs: PNG (8-bit sRGB at an exposure,
//! [`exposure`] and [`encode_png`]) and EXR (linear RGB radiance, [`encode_exr`]).

use std::path::Path;

use anyhow::{Context, Result, bail};
use clap::Args;
use lrr_formats::Camera;
use lrr_runtime::trace::{CameraChoiceError, CameraFields, Image, Tracer};

use crate::exr_image::{self, ExrSamples, RgbLayer};

/// The camera flags: the file's camera of a name (or its first), each field overridable.
#[derive(Debug, Clone, Default, Args)]
pub struct CameraArgs {
    /// Eye position X,Y,Z [default: the file's camera].
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<[f32; 3]>,
    /// Point looked at X,Y,Z [default: the file's camera].
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub target: Option<[f32; 3]>,
    /// Up direction X,Y,Z [default: the file's camera, else 0,1,0].
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub up: Option<[f32; 3]>,
    /// Vertical field of view in degrees [default: the file's camera, else 60].
    #[arg(long, value_name = "DEG")]
    pub fov_y: Option<f32>,
    /// The file's camera of this name [default: its first camera]; the flags above override
    /// its fields.
    #[arg(long, value_name = "NAME")]
    pub camera: Option<String>,
}

impl CameraArgs {
    /// The camera the flags and the cameras of `tracer`'s file (`file`, for errors) make.
    pub fn camera(&self, tracer: &Tracer, file: &Path) -> Result<Camera> {
        let fields = CameraFields {
            name: self.camera.clone(),
            eye: self.eye,
            target: self.target,
            up: self.up,
            fov_y_deg: self.fov_y,
        };
        fields.choose(tracer.cameras()).map_err(|e| match e {
            CameraChoiceError::NoSuchCamera { name, available } => anyhow::anyhow!(
                "--camera {name}: the file has no such camera (it has: {available})"
            ),
            CameraChoiceError::NoCamera => anyhow::anyhow!(
                "{}: the file has no camera; give one with --eye X,Y,Z --target X,Y,Z \
                 (and --up, --fov-y)",
                file.display()
            ),
        })
    }
}

/// Parses `X,Y,Z`.
pub(crate) fn parse_vec3(text: &str) -> std::result::Result<[f32; 3], String> {
    let parts: Vec<f32> = text
        .split(',')
        .map(|p| p.trim().parse::<f32>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| format!("'{text}' is not three numbers X,Y,Z"))?;
    match parts[..] {
        [x, y, z] if parts.iter().all(|c| c.is_finite()) => Ok([x, y, z]),
        _ => Err(format!("'{text}' is not three finite numbers X,Y,Z")),
    }
}

/// Parses an image size `WxH` (1 to 2^28 pixels).
pub(crate) fn parse_size(text: &str) -> std::result::Result<(u32, u32), String> {
    let err = || format!("'{text}' is not a size WxH like 1920x1080");
    let (w, h) = text.split_once(['x', 'X']).ok_or_else(err)?;
    let (w, h): (u32, u32) = (
        w.trim().parse().map_err(|_| err())?,
        h.trim().parse().map_err(|_| err())?,
    );
    if w == 0 || h == 0 || w as u64 * h as u64 > 1 << 28 {
        return Err(format!("'{text}': need 1 to 2^28 pixels"));
    }
    Ok((w, h))
}

/// An image file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ImageFormat {
    /// 8-bit sRGB, tone-mapped at an exposure.
    Png,
    /// Linear RGB radiance (OpenEXR).
    Exr,
}

impl ImageFormat {
    /// The format of `path` by its extension (`flag` names the option in the error).
    pub fn of(path: &Path, flag: &str) -> Result<Self> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("png") => Ok(Self::Png),
            Some("exr") => Ok(Self::Exr),
            _ => bail!(
                "{flag} {}: the image format comes from the extension: .png (tone-mapped) or \
                 .exr (linear)",
                path.display()
            ),
        }
    }

    /// The file extension.
    pub fn extension(self) -> &'static str {
        match self {
            Self::Png => "png",
            Self::Exr => "exr",
        }
    }
}

/// The scale applied before the sRGB curve: `2^ev`, or the one mapping the 99th percentile of
/// the luminance of lit pixels to 1; with a phrase saying which.
pub fn exposure(image: &Image, ev: Option<f32>) -> (f32, &'static str) {
    if let Some(ev) = ev {
        return (2f32.powf(ev), "--exposure");
    }
    let mut lum: Vec<f32> = image
        .pixels
        .iter()
        .map(|p| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2])
        .filter(|l| *l > 0.0)
        .collect();
    if lum.is_empty() {
        return (1.0, "auto: the image is black");
    }
    let at = (lum.len() - 1) * 99 / 100;
    let (_, p99, _) = lum.select_nth_unstable_by(at, f32::total_cmp);
    (
        1.0 / *p99,
        "auto: the 99th percentile of the luminance maps to white",
    )
}

/// The sRGB transfer function of a linear value in [0, 1].
fn srgb(v: f32) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let s = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// The image as an 8-bit sRGB PNG, values scaled by `scale` and clipped.
pub fn encode_png(image: &Image, scale: f32) -> Result<Vec<u8>> {
    let mut bytes = Vec::new();
    let mut enc = png::Encoder::new(&mut bytes, image.width, image.height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let data: Vec<u8> = image
        .pixels
        .iter()
        .flat_map(|p| p.map(|c| srgb(c * scale)))
        .collect();
    let mut writer = enc.write_header().context("encoding the PNG")?;
    writer.write_image_data(&data).context("encoding the PNG")?;
    writer.finish().context("encoding the PNG")?;
    Ok(bytes)
}

/// The image as EXR bytes: linear RGB radiance, channels R, G, B; `note` says where it comes
/// from.
pub fn encode_exr(image: &Image, samples: ExrSamples, note: &str) -> Result<Vec<u8>> {
    let layer = RgbLayer {
        name: None,
        pixels: &image.pixels,
    };
    let note = format!("linear RGB radiance (W sr^-1 m^-2 in the scene's units), {note}");
    exr_image::encode(
        image.width as usize,
        image.height as usize,
        &[layer],
        samples,
        &note,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vectors_sizes_and_srgb_parse_and_map() {
        assert_eq!(parse_vec3("1,-2.5, 3").unwrap(), [1.0, -2.5, 3.0]);
        assert!(parse_vec3("1,2").unwrap_err().contains("X,Y,Z"));
        assert!(parse_vec3("1,2,nan").is_err());
        assert_eq!(parse_size("1920x1080").unwrap(), (1920, 1080));
        assert!(parse_size("0x5").is_err());
        assert!(parse_size("big").unwrap_err().contains("WxH"));
        assert_eq!(srgb(0.0), 0);
        assert_eq!(srgb(1.0), 255);
        assert_eq!(srgb(2.0), 255);
        // Mid-grey 0.18 linear is 118 in sRGB (IEC 61966-2-1).
        assert_eq!(srgb(0.18), 118);
    }

    #[test]
    fn the_exposure_maps_the_99th_percentile_to_white() {
        let mut pixels = vec![[0.0f32; 3]; 100];
        for (i, p) in pixels.iter_mut().enumerate().skip(1) {
            *p = [i as f32; 3];
        }
        let image = Image {
            width: 10,
            height: 10,
            pixels,
        };
        // 99 lit pixels of luminance 1..=99: the 99th percentile is the one at index 97.
        let (scale, how) = exposure(&image, None);
        assert!((scale - 1.0 / 98.0).abs() < 1e-6, "{scale}");
        assert!(how.starts_with("auto"));
        assert_eq!(exposure(&image, Some(-1.0)).0, 0.5);
    }
}
