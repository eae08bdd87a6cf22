//! Textures on faces: texture coordinates as an affine map of each planar face, decoded base
//! colour images, and the average of a texture over an element (its diffuse reflectance).
//!
//! A face's texture coordinates are the affine map `uv(p) = G·p + c` that takes its triangle's
//! three vertices to their `TEXCOORD` values ([`UvMap::from_triangle`]); on a plane an affine
//! map is fixed by three points, so the map is exact inside the triangle and extends it to the
//! plane. The mesher's elements are pieces of faces (or, where coplanar faces of one surface
//! are merged, of their union): an element's texture coordinates come from the map of the face
//! it records (`Element::face`), exact wherever the merged faces share one affine map (a quad
//! of two triangles, a planar projection) and an affine extension of it otherwise.
//!
//! The reflectance of an element is `scale ⊙ mean(texture over the element)`
//! ([`element_average`]): the mean of the bilinearly filtered linear texture over the element's
//! area, by the midpoint rule on `m²` sub-triangles of each fan triangle, `m` the triangle's
//! longest edge in texels (between 1 and [`MAX_SPLITS`]), so every texel the element covers is
//! sampled once or more up to 16 texels per edge.

use glam::DVec3;

use crate::geometry::Polygon;

/// Most sub-triangles per fan-triangle edge when averaging a texture over an element (so at
/// most 256 samples per fan triangle).
pub const MAX_SPLITS: usize = 16;

/// How texture coordinates outside [0, 1] map into the image (glTF sampler wrap modes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Wrap {
    /// The image repeats (glTF's default).
    #[default]
    Repeat,
    /// Coordinates are clamped to the edge texels.
    Clamp,
    /// The image repeats mirrored every other time.
    Mirror,
}

impl Wrap {
    /// The texel index for integer texel coordinate `i` of an axis of `n` texels.
    fn index(self, i: i64, n: usize) -> usize {
        let n = n as i64;
        let i = match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::Clamp => i.clamp(0, n - 1),
            Wrap::Mirror => {
                let m = i.rem_euclid(2 * n);
                if m < n { m } else { 2 * n - 1 - m }
            }
        };
        i as usize
    }
}

/// A decoded 8-bit sRGB image with its wrap modes, sampled as linear RGB.
#[derive(Debug, Clone, PartialEq)]
pub struct Texture {
    /// Name for messages (the glTF image).
    pub name: String,
    /// Width in texels (> 0).
    pub width: usize,
    /// Height in texels (> 0).
    pub height: usize,
    /// sRGB-encoded RGB texels, rows top to bottom (`v = 0` is the top row, as in glTF).
    pub texels: Vec<[u8; 3]>,
    /// Wrap mode along `u`.
    pub wrap_u: Wrap,
    /// Wrap mode along `v`.
    pub wrap_v: Wrap,
}

impl Texture {
    /// True when every texel is grey (r = g = b).
    pub fn is_grey(&self) -> bool {
        self.texels.iter().all(|t| t[0] == t[1] && t[1] == t[2])
    }

    /// The mean linear RGB over all texels.
    pub fn average(&self) -> [f64; 3] {
        let lut = linear_lut();
        let mut sum = [0.0f64; 3];
        for t in &self.texels {
            for c in 0..3 {
                sum[c] += lut[t[c] as usize];
            }
        }
        sum.map(|s| s / self.texels.len() as f64)
    }

    /// Bilinearly filtered linear RGB at texture coordinates `(u, v)` (texel centres at
    /// half-integers, as glTF and graphics APIs sample).
    pub fn sample(&self, lut: &[f64; 256], u: f64, v: f64) -> [f64; 3] {
        let x = u * self.width as f64 - 0.5;
        let y = v * self.height as f64 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        // Coordinates far outside the image still wrap; i64 keeps the arithmetic exact.
        let (x0, y0) = (x0.clamp(-1e15, 1e15) as i64, y0.clamp(-1e15, 1e15) as i64);
        let mut out = [0.0; 3];
        for (dy, wy) in [(0, 1.0 - fy), (1, fy)] {
            let row = self.wrap_v.index(y0 + dy, self.height) * self.width;
            for (dx, wx) in [(0, 1.0 - fx), (1, fx)] {
                let t = self.texels[row + self.wrap_u.index(x0 + dx, self.width)];
                for c in 0..3 {
                    out[c] += wx * wy * lut[t[c] as usize];
                }
            }
        }
        out
    }
}

/// Largest image (width × height) a texture may decode to.
const MAX_TEXELS: u64 = 1 << 26;

/// Bytes an image may take per texel while it decodes: the decoder's image (up to 8 for
/// 16-bit RGBA), its RGB8 copy (3) and the texture's own texels (3), rounded up.
pub(crate) const DECODE_BYTES_PER_TEXEL: u128 = 16;
/// Bytes a decoded texture keeps per texel (RGB8).
const KEPT_BYTES_PER_TEXEL: u128 = 3;

/// The memory an import plans against `--max-memory`: its files' estimate so far, then each
/// image as it is decoded ([`Budget::room_for`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Budget {
    /// Bytes planned so far (files, faces, textures kept).
    pub planned: u128,
    pub max_memory: Option<u64>,
}

impl Budget {
    /// Refuses decoding `encoded` (the image `what`) when its texels, from its header, would
    /// not fit beside what is planned: [`DECODE_BYTES_PER_TEXEL`] each; then counts the
    /// texture when it is `kept` (not when only its mean is taken). An image whose header
    /// cannot be read, or that declares more than [`decode`] takes, is left to its error
    /// (a texture left out with a warning: more memory would not help).
    pub(crate) fn room_for(
        &mut self,
        encoded: &[u8],
        what: &str,
        kept: bool,
    ) -> crate::error::Result<()> {
        let Some((width, height)) = dimensions(encoded) else {
            return Ok(());
        };
        let texels = u128::from(width) * u128::from(height);
        if texels > u128::from(MAX_TEXELS) {
            return Ok(());
        }
        crate::memory::check_then(
            self.planned + texels * DECODE_BYTES_PER_TEXEL,
            self.max_memory,
            || format!("decoding {what} ({width}×{height} texels)"),
            |_| {
                "use a smaller image (a bake needs its colours, not its detail), or raise \
                 --max-memory"
                    .to_string()
            },
        )?;
        if kept {
            self.planned += texels * KEPT_BYTES_PER_TEXEL;
        }
        Ok(())
    }
}

/// The width and height a PNG or JPEG image declares in its header, without decoding it.
pub(crate) fn dimensions(encoded: &[u8]) -> Option<(u32, u32)> {
    image::io::Reader::new(std::io::Cursor::new(encoded))
        .with_guessed_format()
        .ok()?
        .into_dimensions()
        .ok()
}

/// Decodes a PNG or JPEG image (`encoded`) into a texture with wrap modes `[u, v]`. The error
/// reads on after the image's name: `": …"` or `" cannot be decoded …"`.
pub(crate) fn decode(
    encoded: &[u8],
    name: String,
    [wrap_u, wrap_v]: [Wrap; 2],
) -> std::result::Result<Texture, String> {
    let mut reader = image::io::Reader::new(std::io::Cursor::new(encoded));
    let mut limits = image::io::Limits::default();
    limits.max_alloc = Some(4 * MAX_TEXELS);
    reader.limits(limits);
    let decoded = reader
        .with_guessed_format()
        .map_err(|e| format!(": {e}"))?
        .decode()
        .map_err(|e| format!(" cannot be decoded (PNG or JPEG expected): {e}"))?;
    let rgb = decoded.to_rgb8();
    if u64::from(rgb.width()) * u64::from(rgb.height()) == 0 {
        return Err(" has no texels".to_string());
    }
    Ok(Texture {
        name,
        width: rgb.width() as usize,
        height: rgb.height() as usize,
        texels: rgb.pixels().map(|p| p.0).collect(),
        wrap_u,
        wrap_v,
    })
}

/// The sRGB transfer function, inverted, for every 8-bit value.
pub fn linear_lut() -> [f64; 256] {
    std::array::from_fn(|i| srgb_to_linear(i as f64 / 255.0))
}

/// The sRGB transfer function, inverted.
pub(crate) fn srgb_to_linear(v: f64) -> f64 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Texture coordinates on a face's plane: `uv(p) = (g[0]·p + c[0], g[1]·p + c[1])`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UvMap {
    /// Gradients of `u` and `v` in the face's plane (scene units⁻¹).
    pub gradient: [DVec3; 2],
    /// Offsets of `u` and `v`.
    pub offset: [f64; 2],
}

impl UvMap {
    /// The affine map of a triangle's plane taking `p[i]` to `t[i]`; None for a degenerate
    /// triangle or non-finite coordinates.
    pub fn from_triangle(p: [DVec3; 3], t: [[f64; 2]; 3]) -> Option<Self> {
        let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
        let (a, b, c) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let det = a * c - b * b;
        let well_shaped = det.is_finite() && det > 1e-24 * a * c;
        if !well_shaped {
            return None;
        }
        // s(p) = r1·(p − p0) and t(p) = r2·(p − p0) are p's coordinates along e1 and e2.
        let r1 = (c * e1 - b * e2) / det;
        let r2 = (a * e2 - b * e1) / det;
        let mut gradient = [DVec3::ZERO; 2];
        let mut offset = [0.0; 2];
        for k in 0..2 {
            gradient[k] = (t[1][k] - t[0][k]) * r1 + (t[2][k] - t[0][k]) * r2;
            offset[k] = t[0][k] - gradient[k].dot(p[0]);
        }
        let map = Self { gradient, offset };
        let finite = gradient.iter().all(|g| g.is_finite()) && offset.iter().all(|o| o.is_finite());
        finite.then_some(map)
    }

    /// Texture coordinates at `p`.
    pub fn at(&self, p: DVec3) -> [f64; 2] {
        [0, 1].map(|k| self.gradient[k].dot(p) + self.offset[k])
    }

    /// The same map after every coordinate of the scene is multiplied by `s`.
    pub fn scaled(&self, s: f64) -> Self {
        Self {
            gradient: self.gradient.map(|g| g / s),
            offset: self.offset,
        }
    }

    /// This map followed by `t`.
    pub fn then(&self, t: &UvTransform) -> Self {
        let m = &t.0;
        Self {
            gradient: [0, 1].map(|k| m[k][0] * self.gradient[0] + m[k][1] * self.gradient[1]),
            offset: [0, 1].map(|k| m[k][0] * self.offset[0] + m[k][1] * self.offset[1] + m[k][2]),
        }
    }
}

/// An affine map of texture coordinates, `uv' = m · (u, v, 1)` (glTF's
/// `KHR_texture_transform` on a base colour texture).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UvTransform(pub [[f64; 3]; 2]);

impl UvTransform {
    /// `uv' = uv`.
    pub const IDENTITY: Self = Self([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);

    /// `KHR_texture_transform`'s `T · R · S`: scale, then rotate by `rotation` radians
    /// (`u' = u cos + v sin`, `v' = −u sin + v cos`: counter-clockwise in the image, whose `v`
    /// points down), then offset.
    pub fn khr(offset: [f64; 2], rotation: f64, scale: [f64; 2]) -> Self {
        let (s, c) = rotation.sin_cos();
        Self([
            [c * scale[0], s * scale[1], offset[0]],
            [-s * scale[0], c * scale[1], offset[1]],
        ])
    }
}

/// What ties a material to a base colour texture: its reflectance at a point is
/// `scale ⊙ texture(uv)` with `uv` from the face's `TEXCOORD_set`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TextureBinding {
    /// Index into `Scene::textures`.
    pub texture: usize,
    /// The texture coordinate set (`TEXCOORD_0` or `TEXCOORD_1`).
    pub set: usize,
    /// Per channel factor (glTF: baseColorFactor × the diffuse share of metal and transmission).
    pub scale: [f64; 3],
    /// Applied to the set's coordinates before the texture is read (glTF's
    /// `KHR_texture_transform`; the identity elsewhere).
    pub transform: UvTransform,
}

/// The mean linear RGB of `texture` over `polygon`, texture coordinates from `map`.
pub fn element_average(
    texture: &Texture,
    lut: &[f64; 256],
    map: &UvMap,
    polygon: &Polygon,
) -> [f64; 3] {
    let v = polygon.vertices();
    let uv: Vec<[f64; 2]> = v.iter().map(|p| map.at(*p)).collect();
    let mut sum = [0.0; 3];
    let mut total = 0.0;
    for i in 1..v.len() - 1 {
        let area = 0.5 * (v[i] - v[0]).cross(v[i + 1] - v[0]).length();
        let mean = triangle_average(texture, lut, [uv[0], uv[i], uv[i + 1]]);
        for c in 0..3 {
            sum[c] += area * mean[c];
        }
        total += area;
    }
    sum.map(|s| s / total)
}

/// The mean over a triangle given by its corners' texture coordinates: midpoint rule on the
/// `m²` congruent sub-triangles (`m` up to [`MAX_SPLITS`]).
fn triangle_average(texture: &Texture, lut: &[f64; 256], t: [[f64; 2]; 3]) -> [f64; 3] {
    let texels = |a: [f64; 2], b: [f64; 2]| {
        let du = (a[0] - b[0]) * texture.width as f64;
        let dv = (a[1] - b[1]) * texture.height as f64;
        du.hypot(dv)
    };
    let longest = texels(t[0], t[1])
        .max(texels(t[1], t[2]))
        .max(texels(t[2], t[0]));
    let m = if longest.is_finite() {
        (longest.ceil() as usize).clamp(1, MAX_SPLITS)
    } else {
        1
    };
    let at = |a: f64, b: f64| {
        let w = [1.0 - a - b, a, b];
        [0, 1].map(|k| w[0] * t[0][k] + w[1] * t[1][k] + w[2] * t[2][k])
    };
    let mut sum = [0.0; 3];
    let mf = m as f64;
    let mut add = |a: f64, b: f64| {
        let [u, v] = at(a / mf, b / mf);
        let s = texture.sample(lut, u, v);
        for c in 0..3 {
            sum[c] += s[c];
        }
    };
    for i in 0..m {
        for j in 0..m - i {
            // The upright sub-triangle at (i, j), and the inverted one beside it.
            let (x, y) = (i as f64, j as f64);
            add(x + 1.0 / 3.0, y + 1.0 / 3.0);
            if i + j + 1 < m {
                add(x + 2.0 / 3.0, y + 2.0 / 3.0);
            }
        }
    }
    sum.map(|s| s / (mf * mf))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker(wrap: Wrap) -> Texture {
        // 2×2: black, white / white, black.
        Texture {
            name: "checker".into(),
            width: 2,
            height: 2,
            texels: vec![[0; 3], [255; 3], [255; 3], [0; 3]],
            wrap_u: wrap,
            wrap_v: wrap,
        }
    }

    #[test]
    fn the_map_takes_the_triangle_to_its_coordinates_and_extends_it_affinely() {
        let p = [
            DVec3::new(1.0, 2.0, 3.0),
            DVec3::new(4.0, 2.5, 3.0),
            DVec3::new(1.5, 6.0, 3.0),
        ];
        let t = [[0.1, 0.2], [0.9, 0.25], [0.3, 0.8]];
        let map = UvMap::from_triangle(p, t).unwrap();
        for i in 0..3 {
            let uv = map.at(p[i]);
            assert!((uv[0] - t[i][0]).abs() < 1e-14 && (uv[1] - t[i][1]).abs() < 1e-14);
        }
        // The midpoint of an edge maps to the midpoint of its coordinates; a point off the
        // plane maps as its projection (gradients lie in the plane).
        let mid = map.at(0.5 * (p[1] + p[2]));
        assert!((mid[0] - 0.6).abs() < 1e-14 && (mid[1] - 0.525).abs() < 1e-14);
        let off = map.at(p[0] + DVec3::Z * 7.0);
        assert!((off[0] - 0.1).abs() < 1e-14 && (off[1] - 0.2).abs() < 1e-14);
        // Scaling the scene keeps the coordinates of scaled points.
        let scaled = map.scaled(3.0).at(p[1] * 3.0);
        assert!((scaled[0] - 0.9).abs() < 1e-14);
        assert!(UvMap::from_triangle([p[0], p[1], p[1]], t).is_none());
    }

    #[test]
    fn wrap_modes_fold_indices_as_gltf_samplers_do() {
        let n = 3;
        let r: Vec<usize> = (-4..5).map(|i| Wrap::Repeat.index(i, n)).collect();
        assert_eq!(r, [2, 0, 1, 2, 0, 1, 2, 0, 1]);
        let c: Vec<usize> = (-2..5).map(|i| Wrap::Clamp.index(i, n)).collect();
        assert_eq!(c, [0, 0, 0, 1, 2, 2, 2]);
        let m: Vec<usize> = (-4..7).map(|i| Wrap::Mirror.index(i, n)).collect();
        assert_eq!(m, [2, 2, 1, 0, 0, 1, 2, 2, 1, 0, 0]);
    }

    #[test]
    fn bilinear_samples_hit_texel_centres_and_blend_between_them() {
        let lut = linear_lut();
        let tex = checker(Wrap::Repeat);
        assert_eq!(tex.sample(&lut, 0.25, 0.25), [0.0; 3]);
        assert_eq!(tex.sample(&lut, 0.75, 0.25), [1.0; 3]);
        let between = tex.sample(&lut, 0.5, 0.25);
        assert!((between[0] - 0.5).abs() < 1e-15);
        // Repeat wraps a quarter texel past the right edge onto column 0.
        let wrapped = tex.sample(&lut, 1.25, 0.25);
        assert_eq!(wrapped, [0.0; 3]);
        assert!(tex.is_grey());
        assert!((tex.average()[1] - 0.5).abs() < 1e-15);
    }

    #[test]
    fn an_elements_average_is_the_mean_of_the_texels_it_covers() {
        // A 4×1 texture: the quad [0, 1]² with u = x covers it all; its left half only the
        // first two texels (sampled at texel centres away from the half's edge, bilinear
        // blending near the middle).
        let tex = Texture {
            name: "ramp".into(),
            width: 4,
            height: 1,
            texels: vec![[0; 3], [0; 3], [255; 3], [255; 3]],
            wrap_u: Wrap::Clamp,
            wrap_v: Wrap::Clamp,
        };
        let lut = linear_lut();
        let p = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let map = UvMap::from_triangle(p, [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]).unwrap();
        let quad = |x0: f64, x1: f64| {
            Polygon::new(&[
                DVec3::new(x0, 0.0, 0.0),
                DVec3::new(x1, 0.0, 0.0),
                DVec3::new(x1, 1.0, 0.0),
                DVec3::new(x0, 1.0, 0.0),
            ])
            .unwrap()
        };
        let whole = element_average(&tex, &lut, &map, &quad(0.0, 1.0));
        assert!((whole[0] - 0.5).abs() < 1e-3, "{whole:?}");
        let left = element_average(&tex, &lut, &map, &quad(0.0, 0.4));
        let right = element_average(&tex, &lut, &map, &quad(0.6, 1.0));
        assert!(left[0] < 0.05 && right[0] > 0.95, "{left:?} {right:?}");
        // The two halves average to the whole (areas equal).
        let l = element_average(&tex, &lut, &map, &quad(0.0, 0.5));
        let r = element_average(&tex, &lut, &map, &quad(0.5, 1.0));
        assert!(((l[0] + r[0]) / 2.0 - whole[0]).abs() < 1e-3);
    }

    #[test]
    fn images_are_planned_from_their_headers_before_they_are_decoded() {
        let png = |side: u32| {
            let mut out = Vec::new();
            image::ImageEncoder::write_image(
                image::codecs::png::PngEncoder::new(&mut out),
                &vec![7u8; (3 * side * side) as usize],
                side,
                side,
                image::ColorType::Rgb8,
            )
            .unwrap();
            out
        };
        let big = png(1024);
        assert_eq!(dimensions(&big), Some((1024, 1024)));
        assert_eq!(dimensions(b"not an image"), None);
        // 2^20 texels: 16 MiB to decode beside 1 MiB already planned.
        let mut budget = Budget {
            planned: 1 << 20,
            max_memory: Some(16 << 20),
        };
        let e = budget
            .room_for(&big, "floor.glb: image 0", true)
            .unwrap_err();
        assert!(matches!(e, crate::error::Error::Limits(_)), "{e}");
        assert!(
            e.to_string()
                .starts_with("decoding floor.glb: image 0 (1024×1024 texels) needs about 17.0"),
            "{e}"
        );
        assert_eq!(budget.planned, 1 << 20);
        // With room: the texture it keeps (3 bytes a texel) is counted; an unreadable header
        // is left to the decoder's own error.
        budget.max_memory = Some(17 << 20);
        budget.room_for(&big, "floor.glb: image 0", false).unwrap();
        assert_eq!(budget.planned, 1 << 20);
        budget.room_for(&big, "floor.glb: image 0", true).unwrap();
        assert_eq!(budget.planned, (1 << 20) + 3 * (1 << 20));
        budget.room_for(b"not an image", "x", true).unwrap();
        assert_eq!(budget.planned, 4 << 20);
        // A header declaring more than a texture may hold (2^26 texels) is left to the
        // decoder's refusal, whatever the memory.
        let mut huge = png(1);
        let ihdr = huge.windows(4).position(|w| w == b"IHDR").unwrap() + 4;
        huge[ihdr..ihdr + 4].copy_from_slice(&16384u32.to_be_bytes());
        huge[ihdr + 4..ihdr + 8].copy_from_slice(&16384u32.to_be_bytes());
        // The chunk's CRC-32 (over its type and 13 data bytes) made again.
        let crc = huge[ihdr - 4..ihdr + 13].iter().fold(!0u32, |mut c, &b| {
            c ^= u32::from(b);
            for _ in 0..8 {
                c = if c & 1 == 1 {
                    (c >> 1) ^ 0xEDB8_8320
                } else {
                    c >> 1
                };
            }
            c
        });
        huge[ihdr + 13..ihdr + 17].copy_from_slice(&(!crc).to_be_bytes());
        assert_eq!(dimensions(&huge), Some((16384, 16384)));
        budget.max_memory = Some(1 << 20);
        budget.room_for(&huge, "x", true).unwrap();
        assert!(decode(&huge, "x".into(), [Wrap::Repeat; 2]).is_err());
    }
}
