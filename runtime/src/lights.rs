//! Lights that are not surfaces (DESIGN.md §9): point, spot and directional lights and a sky, and
//! the per-frame direct pass that turns them into an emission the operator bounces.
//!
//! The operator maps any emission to radiosity, `B = G E`. A light enters through `E`: for
//! element `i`, `E_i = ρ_i ⊙ H_i`, where `H_i` is the light's direct irradiance averaged over the
//! element, visibility included. [`DirectLighting::irradiance`] computes `H` per element at fixed
//! sample points (chosen once, when the pass is made, so a frame never flickers), each behind a
//! shadow ray through the file's BVH; [`reflected`] makes `ρ ⊙ H`; `B = G E` then holds the
//! reflected direct light and every further bounce, and `B − E` the bounced part alone, which
//! the display adds to the direct light at the shaded point itself ([`DirectLighting::at`]):
//! shadow edges as sharp as the light makes them, not as coarse as the elements.
//!
//! Irradiance at a point `x` with front normal `n` (elements are one-sided: light from behind
//! does nothing):
//!
//! ```text
//! point        H = I · max(0, n·ω) / |p − x|² · V(x, p)           ω = (p − x)/|p − x|, I in W/sr
//! spot         the same times glTF's cone falloff: t = clamp((cos α − cos outer)
//!              / max(1e-3, cos inner − cos outer), 0, 1), falloff t²   (α: angle off the axis)
//! directional  H = E⊥ · max(0, −n·d) · V(x, −d)                   d the travel direction,
//!                                                                  E⊥ in W/m² facing it
//! sky          H = ∫ L(ω) V(x, ω) max(0, n·ω) dω = Σ_lm L_lm T_lm  (order-2 spherical
//!              harmonics: T per element, projected once from cosine-weighted rays)
//! ```
//!
//! Only what a frame calls for is traced: no lights, no rays; a light whose place, direction and
//! cone did not change since the last frame is not traced again (its colour and intensity scale
//! a cached geometric term); the sky's transfer is projected on the first frame that has a sky.
//!
//! In every build of the runtime (an application runs this pass every frame; the C interface's
//! `lrr_direct_*`): the shadow rays are any-hit queries through `rays/`, the file's BVH checked
//! and collapsed once. The ray tracer (feature `trace`) shades its hits with the arithmetic of
//! [`DirectLighting::at`].

use std::f32::consts::PI;

use lrr_formats::OperatorFile;

use crate::error::{RuntimeError, input};
use crate::rays::{Ray, RayScene, V3, add, cross, dot, length, mad, normalize, scale, sub};

/// A light that is not a surface, as a frame gives it. Every field may change every frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Light {
    /// A point light.
    Point {
        /// Where it is.
        position: [f32; 3],
        /// Radiant intensity per channel, W/sr (irradiance `I cos θ / d²`).
        intensity: [f32; 3],
    },
    /// A spot light: a point light whose intensity falls off off its axis as glTF's
    /// `KHR_lights_punctual` says, from 1 inside `inner` to 0 outside `outer`.
    Spot {
        /// Where it is.
        position: [f32; 3],
        /// Where it points (any length but zero).
        direction: [f32; 3],
        /// Radiant intensity per channel on the axis, W/sr.
        intensity: [f32; 3],
        /// Half-angle of the full-intensity cone, radians, `0 <= inner <= outer`.
        inner: f32,
        /// Half-angle where the light ends, radians, `<= π/2`.
        outer: f32,
    },
    /// A directional light (a sun).
    Directional {
        /// The direction its light travels (any length but zero).
        direction: [f32; 3],
        /// Irradiance per channel, W/m² (scene units) on a surface facing it.
        irradiance: [f32; 3],
    },
}

impl Light {
    /// Its colour times intensity (W/sr, or W/m² for a directional light).
    pub fn strength(&self) -> [f32; 3] {
        match *self {
            Light::Point { intensity, .. } | Light::Spot { intensity, .. } => intensity,
            Light::Directional { irradiance, .. } => irradiance,
        }
    }

    /// The same light with its colour times intensity (W/sr, or W/m² for a directional light)
    /// set to `strength`.
    pub fn with_strength(&self, strength: [f32; 3]) -> Light {
        let mut l = *self;
        match &mut l {
            Light::Point { intensity, .. } | Light::Spot { intensity, .. } => *intensity = strength,
            Light::Directional { irradiance, .. } => *irradiance = strength,
        }
        l
    }

    /// The light with its strength set to 1: what its shadows and falloff depend on.
    pub(crate) fn shape(&self) -> Light {
        self.with_strength([1.0; 3])
    }

    /// Checks the values (finite, non-negative strengths, non-zero directions, cones in
    /// order); the message names the field.
    pub fn check(&self) -> Result<(), String> {
        let finite = |v: [f32; 3]| v.iter().all(|c| c.is_finite());
        // A direction normalises to a unit vector: its f32 length finite and above zero.
        let usable = |v: [f32; 3]| finite(v) && length(v).is_finite() && length(v) > 0.0;
        let strength = self.strength();
        if !strength.iter().all(|c| c.is_finite() && *c >= 0.0) {
            return Err(format!(
                "its intensity {strength:?} must be finite and >= 0 per channel"
            ));
        }
        match *self {
            Light::Point { position, .. } if !finite(position) => {
                Err(format!("its position {position:?} is not finite"))
            }
            Light::Spot {
                position,
                direction,
                inner,
                outer,
                ..
            } => {
                if !finite(position) {
                    return Err(format!("its position {position:?} is not finite"));
                }
                if !usable(direction) {
                    return Err(format!(
                        "its direction {direction:?} must be finite and not zero, its length \
                         finite in f32"
                    ));
                }
                if !(inner >= 0.0 && inner <= outer && outer <= std::f32::consts::FRAC_PI_2) {
                    return Err(format!(
                        "its cone angles must satisfy 0 <= inner <= outer <= 90 degrees, got \
                         inner {:.4} and outer {:.4} degrees",
                        inner.to_degrees(),
                        outer.to_degrees()
                    ));
                }
                Ok(())
            }
            Light::Directional { direction, .. } if !usable(direction) => Err(format!(
                "its direction {direction:?} must be finite and not zero"
            )),
            _ => Ok(()),
        }
    }

    /// The irradiance per unit strength at `x` (front normal `n`, unit) before visibility, and
    /// the shadow ray's direction (unit, towards the light) and length (`INFINITY` for a
    /// directional light); `None` when no light arrives.
    #[inline]
    pub(crate) fn towards(&self, x: V3, n: V3) -> Option<(f32, V3, f32)> {
        // A light at `position`: the cosine, the unit direction, the distance and its square,
        // when it is in front of the surface (the GPU twin, trace.wgsl's `towards`, divides by
        // d² last, as here).
        let at = |position: V3| {
            let to = sub(position, x);
            let d2 = dot(to, to);
            if d2 <= 0.0 {
                return None;
            }
            let dist = d2.sqrt();
            let w = scale(to, 1.0 / dist);
            let cos = dot(n, w);
            (cos > 0.0).then_some((cos, w, dist, d2))
        };
        match *self {
            Light::Point { position, .. } => {
                at(position).map(|(cos, w, dist, d2)| (cos / d2, w, dist))
            }
            Light::Spot {
                position,
                direction,
                inner,
                outer,
                ..
            } => {
                let (cos, w, dist, d2) = at(position)?;
                let falloff = spot_falloff(-dot(normalize(direction), w), inner, outer);
                (falloff > 0.0).then(|| (cos * falloff / d2, w, dist))
            }
            Light::Directional { direction, .. } => {
                let w = scale(normalize(direction), -1.0);
                let cos = dot(n, w);
                (cos > 0.0).then_some((cos, w, f32::INFINITY))
            }
        }
    }
}

// What the GPU twins upload per light (gpu/direct.rs; with `trace`, gpu/trace.rs).
#[cfg(feature = "gpu")]
impl Light {
    /// The light as `trace.wgsl`'s `DirectLight` record (`lrr_shaders::direct_light`): what
    /// [`Light::towards`] and [`spot_falloff`] compute from the light alone (a spot's unit axis,
    /// a sun's unit direction towards it, the cones' cosines and the falloff's scale), computed
    /// here by the same operations, so that the shader rounds only what depends on the point.
    pub(crate) fn gpu_record(&self) -> [u32; 16] {
        use lrr_shaders::{DirectKind, direct_light};
        match *self {
            Light::Point {
                position,
                intensity,
            } => direct_light(
                DirectKind::Point,
                position,
                [0.0; 3],
                intensity,
                0.0,
                0.0,
                0.0,
            ),
            Light::Spot {
                position,
                direction,
                intensity,
                inner,
                outer,
            } => {
                let (cos_inner, cos_outer) = (inner.cos(), outer.cos());
                let falloff_scale = 1.0 / (cos_inner - cos_outer).max(1e-3);
                direct_light(
                    DirectKind::Spot,
                    position,
                    normalize(direction),
                    intensity,
                    cos_inner,
                    cos_outer,
                    falloff_scale,
                )
            }
            Light::Directional {
                direction,
                irradiance,
            } => direct_light(
                DirectKind::Sun,
                [0.0; 3],
                scale(normalize(direction), -1.0),
                irradiance,
                0.0,
                0.0,
                0.0,
            ),
        }
    }
}

/// glTF's spot falloff at `cos_axis`, the cosine of the angle off the spot's axis: a smooth
/// square from 1 at the inner cone to 0 at the outer (`KHR_lights_punctual`'s
/// `lightAngleScale`/`lightAngleOffset`, the divisor at least 1e-3; equal cones give a hard edge).
#[inline]
pub fn spot_falloff(cos_axis: f32, inner: f32, outer: f32) -> f32 {
    let (cos_inner, cos_outer) = (inner.cos(), outer.cos());
    if cos_axis < cos_outer {
        return 0.0;
    }
    if cos_inner <= cos_outer {
        return 1.0;
    }
    let scale = 1.0 / (cos_inner - cos_outer).max(1e-3);
    let t = ((cos_axis - cos_outer) * scale).clamp(0.0, 1.0);
    t * t
}

/// A sky: radiance per direction, as order-2 spherical harmonics once projected.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sky {
    /// The same radiance from every direction.
    Uniform {
        /// Radiance per channel, W/m²/sr.
        radiance: [f32; 3],
    },
    /// `horizon + (zenith − horizon) · max(0, ω·up)`.
    Gradient {
        /// Radiance straight up.
        zenith: [f32; 3],
        /// Radiance at and below the horizon.
        horizon: [f32; 3],
        /// Up (any length but zero): it rotates the sky.
        up: [f32; 3],
    },
}

impl Sky {
    /// Checks the values; the message names the field.
    pub fn check(&self) -> Result<(), String> {
        let radiance = |v: [f32; 3]| v.iter().all(|c| c.is_finite() && *c >= 0.0);
        match *self {
            Sky::Uniform { radiance: r } if !radiance(r) => Err(format!(
                "its radiance {r:?} must be finite and >= 0 per channel"
            )),
            Sky::Gradient {
                zenith,
                horizon,
                up,
            } => {
                if !radiance(zenith) || !radiance(horizon) {
                    return Err(format!(
                        "its zenith {zenith:?} and horizon {horizon:?} radiances must be \
                         finite and >= 0 per channel"
                    ));
                }
                if !(length(up).is_finite() && length(up) > 0.0) {
                    return Err(format!(
                        "its up direction {up:?} must be finite and not zero"
                    ));
                }
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// The order-2 spherical harmonic coefficients `L_lm` per channel (real, orthonormal
    /// basis, [`sh9`] order). The gradient's clamped cosine is its order-2 projection (the
    /// zonal coefficients √π/2, √(π/3), √(5π)/8 rotated to `up`).
    pub fn coefficients(&self) -> [[f32; 3]; 9] {
        let mut c = [[0.0f32; 3]; 9];
        let y00 = 0.5 / PI.sqrt();
        match *self {
            Sky::Uniform { radiance } => c[0] = scale(radiance, 1.0 / y00),
            Sky::Gradient {
                zenith,
                horizon,
                up,
            } => {
                // horizon everywhere, plus (zenith − horizon) times the clamped cosine about up.
                c[0] = scale(horizon, 1.0 / y00);
                let delta = sub(zenith, horizon);
                let zonal = [PI.sqrt() / 2.0, (PI / 3.0).sqrt(), (5.0 * PI).sqrt() / 8.0];
                let y = sh9(normalize(up));
                for (i, yi) in y.iter().enumerate() {
                    let l = if i == 0 {
                        0
                    } else if i < 4 {
                        1
                    } else {
                        2
                    };
                    let k = zonal[l] * (4.0 * PI / (2 * l + 1) as f32).sqrt() * yi;
                    c[i] = add(c[i], scale(delta, k));
                }
            }
        }
        c
    }
}

/// The nine real orthonormal spherical harmonics of order ≤ 2 at unit `w`:
/// `Y00, Y1-1 (y), Y10 (z), Y11 (x), Y2-2 (xy), Y2-1 (yz), Y20, Y21 (xz), Y22 (x² − y²)`.
#[inline]
pub fn sh9(w: [f32; 3]) -> [f32; 9] {
    let [x, y, z] = w;
    [
        0.282_094_8,
        0.488_602_5 * y,
        0.488_602_5 * z,
        0.488_602_5 * x,
        1.092_548_4 * x * y,
        1.092_548_4 * y * z,
        0.315_391_57 * (3.0 * z * z - 1.0),
        1.092_548_4 * x * z,
        0.546_274_2 * (x * x - y * y),
    ]
}

/// The lights a file holds that the direct pass shades: its point lights that follow no light
/// group (a point light of a group is the highlight of that group's emitting surface, whose
/// light the radiosity already carries), its spot and directional lights (section
/// DIRECT_LIGHTS), and its sky.
pub fn file_lights(file: &OperatorFile) -> (Vec<Light>, Option<Sky>) {
    use lrr_formats::{DirectLightKind as Kind, PointLight};
    let mut lights: Vec<Light> = file
        .display
        .point_lights
        .iter()
        .filter(|l| l.group == PointLight::FIXED)
        .map(|l| Light::Point {
            position: l.position,
            intensity: l.intensity,
        })
        .collect();
    let mut sky = None;
    for l in &file.display.direct_lights {
        match l.kind {
            Kind::Spot => lights.push(Light::Spot {
                position: l.position,
                direction: l.direction,
                intensity: l.strength,
                inner: l.extra[0],
                outer: l.extra[1],
            }),
            Kind::Directional => lights.push(Light::Directional {
                direction: l.direction,
                irradiance: l.strength,
            }),
            Kind::UniformSky => {
                sky = Some(Sky::Uniform {
                    radiance: l.strength,
                })
            }
            Kind::GradientSky => {
                sky = Some(Sky::Gradient {
                    zenith: l.strength,
                    horizon: l.extra,
                    up: l.direction,
                })
            }
        }
    }
    (lights, sky)
}

/// `out[i] = base[i] + ρ[i] ⊙ h[i]`: the emission a frame gives the operator (the baked or
/// group emission `base` plus the lights' reflected direct light).
pub fn reflected(
    rho: &[[f32; 3]],
    h: &[[f32; 3]],
    base: &[[f32; 3]],
    out: &mut [[f32; 3]],
) -> Result<(), RuntimeError> {
    let n = out.len();
    if rho.len() != n || h.len() != n || base.len() != n {
        return Err(input(format!(
            "reflected direct light: {} reflectances, {} irradiances and {} base emissions for \
             {n} elements",
            rho.len(),
            h.len(),
            base.len()
        )));
    }
    for i in 0..n {
        for c in 0..3 {
            out[i][c] = base[i][c] + rho[i][c] * h[i][c];
        }
    }
    Ok(())
}

/// What one call of [`DirectLighting::irradiance`] traced.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DirectReport {
    /// Lights whose geometric term was traced this frame (the others came from the cache).
    pub traced: u32,
    /// Lights whose term came from the cache (only their strength changed, or nothing).
    pub cached: u32,
    /// Shadow rays cast (sky projection included).
    pub rays: u64,
}

/// One sample point of an element: on its surface, with its front normal.
#[derive(Debug, Clone, Copy)]
struct Sample {
    point: V3,
    normal: V3,
}

/// The default number of sample points per element.
pub const DEFAULT_SAMPLES: u32 = 4;

/// Cosine-weighted directions per sample point for the sky's transfer.
const SKY_DIRECTIONS: u32 = 64;

/// The per-frame direct pass of an operator file: fixed sample points per element, shadow rays
/// through the file's BVH, a cache of each light's geometric term. See the [module docs](self).
#[derive(Debug, Clone)]
pub struct DirectLighting {
    scene: RayScene,
    samples: Vec<Sample>,
    per_element: usize,
    threads: usize,
    /// Per light slot of the last frame: its shape and its irradiance per unit strength.
    cache: Vec<(Light, Vec<f32>)>,
    /// The sky's transfer per element, order-2 harmonics (projected on first use).
    sky: Option<Vec<[f32; 9]>>,
}

impl DirectLighting {
    /// The pass of `file` with `samples` points per element (1 to 64; [`DEFAULT_SAMPLES`]) on
    /// `threads` threads (0: what the machine has). An error when the file has no BVH (re-bake
    /// it) or its display data does not fit together.
    pub fn new(file: &OperatorFile, samples: u32, threads: usize) -> Result<Self, RuntimeError> {
        if !(1..=64).contains(&samples) {
            return Err(input(format!(
                "direct lighting: {samples} samples per element; use 1 to 64"
            )));
        }
        let scene = RayScene::new(file)?;
        let n = scene.n();
        // Each element's display triangles with their areas and front normals.
        let mut tris: Vec<Vec<(usize, f32)>> = vec![Vec::new(); n];
        for (t, tri) in scene.tris.iter().enumerate() {
            let face = scene.tri_face[t] as usize;
            let e = scene.face_id[face] as usize;
            let area = 0.5 * length(cross(sub(v(tri, 1), v(tri, 0)), sub(v(tri, 2), v(tri, 0))));
            tris[e].push((t, area));
        }
        let s = samples as usize;
        let mut points = Vec::with_capacity(n * s);
        for list in &tris {
            let total: f64 = list.iter().map(|&(_, a)| a as f64).sum();
            if list.is_empty() || total <= 0.0 {
                // An element drawn by no triangle of area (never in a bake's file): its samples
                // see no light.
                points.extend(std::iter::repeat_n(
                    Sample {
                        point: [f32::NAN; 3],
                        normal: [0.0; 3],
                    },
                    s,
                ));
                continue;
            }
            for j in 0..s {
                // Equal-area strata along the triangles (by cumulative area), van der Corput
                // across: a Hammersley set over the element. A stratum's middle that falls on
                // the end of a triangle's share takes that triangle (r = 1: its edge opposite
                // the first corner, the diagonal of a quad), not the next one's first corner
                // (r = 0): one sample on a quad is its centre, not a corner whose shadow rays
                // start in the plane of a neighbouring wall, decided by rounding.
                let u = (j as f64 + 0.5) / s as f64 * total;
                let mut acc = 0.0f64;
                let mut pick = list.len() - 1;
                let mut r = 0.5f64;
                for (k, &(_, a)) in list.iter().enumerate() {
                    if u <= acc + a as f64 || k == list.len() - 1 {
                        pick = k;
                        r = ((u - acc) / (a as f64).max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
                        break;
                    }
                    acc += a as f64;
                }
                let q = (radical_inverse(j as u32) + 0.5 / s as f64).fract();
                let t = list[pick].0;
                let tri = &scene.tris[t];
                let root = r.sqrt();
                let (b1, b2) = ((root * (1.0 - q)) as f32, (root * q) as f32);
                let (a, b, c) = (v(tri, 0), v(tri, 1), v(tri, 2));
                let point = add(a, add(scale(sub(b, a), b1), scale(sub(c, a), b2)));
                let face = scene.tri_face[t] as usize;
                points.push(Sample {
                    point,
                    normal: scene.normals[face],
                });
            }
        }
        let threads = if threads == 0 {
            std::thread::available_parallelism().map_or(1, |p| p.get())
        } else {
            threads
        };
        // The bake's projection of the sky (section SKY_TRANSFER), by original id.
        let sky = file.display.sky_transfer.as_ref().and_then(|t| {
            (t.len() == 9 * n).then(|| {
                let mut by_id = vec![[0.0f32; 9]; n];
                for (s, &id) in file.order.iter().enumerate() {
                    by_id[id as usize].copy_from_slice(&t[9 * s..9 * s + 9]);
                }
                by_id
            })
        });
        Ok(DirectLighting {
            scene,
            samples: points,
            per_element: s,
            threads,
            cache: Vec::new(),
            sky,
        })
    }

    /// Number of elements.
    pub fn n(&self) -> usize {
        self.scene.n()
    }

    /// Sample points per element.
    pub fn samples_per_element(&self) -> u32 {
        self.per_element as u32
    }

    /// The fixed sample points, each with its element's front normal (unit): element `e`'s
    /// (original id) `j`-th at `e · samples_per_element() + j`, the points
    /// [`irradiance`](Self::irradiance) shades, chosen when the pass was made. An element drawn
    /// by no triangle of area has points that are not finite (NaN) with a zero normal: they see
    /// no light. For a twin of the pass that must use the same points (the GPU's, `gpu::GpuDirect`).
    pub fn sample_points(&self) -> impl ExactSizeIterator<Item = ([f32; 3], [f32; 3])> + '_ {
        self.samples.iter().map(|s| (s.point, s.normal))
    }

    /// The checked scene whose BVH the shadow rays traverse (the GPU twin uploads it).
    #[cfg(feature = "gpu")]
    pub(crate) fn scene(&self) -> &RayScene {
        &self.scene
    }

    /// The direct irradiance `H` per element (original ids) of `lights`, written to `h` (n
    /// values): each element's mean over its sample points, each behind a shadow ray. Lights
    /// whose shape (all but the strength) matches the same slot of the last call are not traced
    /// again. An error names a light whose values are bad, or a wrong length.
    pub fn irradiance(
        &mut self,
        lights: &[Light],
        h: &mut [[f32; 3]],
    ) -> Result<DirectReport, RuntimeError> {
        let n = self.n();
        if h.len() != n {
            return Err(input(format!(
                "direct irradiance: {} values for {n} elements",
                h.len()
            )));
        }
        for (i, light) in lights.iter().enumerate() {
            light
                .check()
                .map_err(|p| input(format!("light {i} ({light:?}): {p}")))?;
        }
        let mut report = DirectReport::default();
        self.cache.truncate(lights.len());
        // The lights to trace: neither dark nor where they were in the same slot last frame.
        let mut todo: Vec<(usize, Light)> = Vec::new();
        for (i, light) in lights.iter().enumerate() {
            let shape = light.shape();
            // A slot's cached term counts only when it was traced (a placeholder is empty).
            let cached = self
                .cache
                .get(i)
                .is_some_and(|(s, term)| *s == shape && !term.is_empty());
            if light.strength() == [0.0; 3] || cached {
                report.cached += 1;
            } else {
                todo.push((i, shape));
            }
        }
        if !todo.is_empty() {
            let shapes: Vec<Light> = todo.iter().map(|&(_, l)| l).collect();
            let (terms, rays) = self.trace_lights(&shapes);
            report.traced += todo.len() as u32;
            report.rays += rays;
            for ((i, shape), term) in todo.into_iter().zip(terms) {
                // Slots below i that were dark and never traced hold an empty placeholder.
                while self.cache.len() <= i {
                    self.cache.push((shape, Vec::new()));
                }
                self.cache[i] = (shape, term);
            }
        }
        h.iter_mut().for_each(|x| *x = [0.0; 3]);
        for (light, (_, term)) in lights.iter().zip(&self.cache) {
            let strength = light.strength();
            if strength == [0.0; 3] || term.is_empty() {
                continue;
            }
            for (x, &g) in h.iter_mut().zip(term) {
                *x = add(*x, scale(strength, g));
            }
        }
        Ok(report)
    }

    /// The sky's direct irradiance `H` per element (original ids), written to `h`: `Σ_lm L_lm
    /// T_lm` with the element's transfer `T` (the bake's, section SKY_TRANSFER, when the file
    /// has one; else projected on the first call, the rays counted in the report; then O(9)
    /// per element), clamped at zero (an order-2 product may dip below it
    /// where the sky is dark and mostly hidden).
    pub fn sky_irradiance(
        &mut self,
        sky: &Sky,
        h: &mut [[f32; 3]],
    ) -> Result<DirectReport, RuntimeError> {
        let n = self.n();
        if h.len() != n {
            return Err(input(format!(
                "sky irradiance: {} values for {n} elements",
                h.len()
            )));
        }
        sky.check().map_err(|p| input(format!("the sky: {p}")))?;
        let mut report = DirectReport::default();
        if self.sky.is_some() {
            report.cached = 1;
        } else {
            report.traced = 1;
        }
        let (transfer, rays) = self.sky_transfer();
        report.rays += rays;
        let c = sky.coefficients();
        for (x, t) in h.iter_mut().zip(transfer) {
            let mut sum = [0.0f32; 3];
            for (cl, tl) in c.iter().zip(t) {
                sum = add(sum, scale(*cl, *tl));
            }
            *x = sum.map(|c| c.max(0.0));
        }
        Ok(report)
    }

    /// The sky's transfer per element (original ids): order-2 spherical harmonics
    /// `T_lm = ∫ V(x, ω) max(0, n·ω) Y_lm(ω) dω` averaged over the element's sample points (the
    /// bake's, section SKY_TRANSFER, when the file has one; else projected now, once, through
    /// the file's BVH), and the shadow rays this call cast (0 once it is known). What
    /// [`sky_irradiance`](Self::sky_irradiance) weighs a sky's coefficients with; the GPU's sky
    /// pass uploads it.
    pub fn sky_transfer(&mut self) -> (&[[f32; 9]], u64) {
        let mut rays = 0;
        if self.sky.is_none() {
            let (transfer, cast) = self.project_sky();
            rays = cast;
            self.sky = Some(transfer);
        }
        (self.sky.as_deref().expect("projected above"), rays)
    }

    /// The direct irradiance of `lights` at one surface point `x` with front normal `normal`
    /// (unit), each light behind its own shadow ray (the sky has no per-point value: its
    /// transfer is per element, [`DirectLighting::sky_irradiance`]).
    pub fn at(&self, lights: &[Light], x: [f32; 3], normal: [f32; 3]) -> [f32; 3] {
        at_point(&self.scene, lights, x, normal, &mut 0)
    }

    /// Each light's irradiance per unit strength per element (original ids), and the rays
    /// cast. `threads` workers take chunks of elements from a shared counter; an element's
    /// rays to one light go as a packet of four (`occluded4`) when four samples face it.
    fn trace_lights(&self, lights: &[Light]) -> (Vec<Vec<f32>>, u64) {
        let n = self.n();
        let (done, rays) = self.par_chunks(|range, rays| -> Vec<Vec<f32>> {
            lights
                .iter()
                .map(|light| {
                    range
                        .clone()
                        .map(|e| self.element_term(light, e, rays))
                        .collect()
                })
                .collect()
        });
        let mut terms = vec![vec![0.0f32; n]; lights.len()];
        for (start, values) in done {
            for (term, v) in terms.iter_mut().zip(values) {
                term[start..start + v.len()].copy_from_slice(&v);
            }
        }
        (terms, rays)
    }

    /// One light's irradiance per unit strength over element `e`: the mean over its samples.
    #[inline]
    fn element_term(&self, light: &Light, e: usize, rays: &mut u64) -> f32 {
        let s = self.per_element;
        let eps = self.scene.epsilon;
        let mut sum = 0.0f32;
        let mut packet: [(Ray, f32, f32); 4] = [(Ray::new([0.0; 3], [0.0, 0.0, 1.0]), 0.0, 0.0); 4];
        let mut filled = 0usize;
        let flush = |packet: &[(Ray, f32, f32); 4], filled: usize, sum: &mut f32| {
            if filled == 4 {
                let reach = [packet[0].2, packet[1].2, packet[2].2, packet[3].2];
                let rays = [packet[0].0, packet[1].0, packet[2].0, packet[3].0];
                let blocked = self.scene.occluded4(&rays, 0.0, reach);
                for (p, b) in packet.iter().zip(blocked) {
                    if !b {
                        *sum += p.1;
                    }
                }
            } else {
                for p in &packet[..filled] {
                    if !self.scene.occluded(&p.0, 0.0, p.2) {
                        *sum += p.1;
                    }
                }
            }
        };
        for smp in &self.samples[e * s..(e + 1) * s] {
            if !smp.point[0].is_finite() {
                continue;
            }
            let Some((g, w, dist)) = light.towards(smp.point, smp.normal) else {
                continue;
            };
            *rays += 1;
            let origin = mad(smp.point, smp.normal, eps);
            let reach = if dist.is_finite() {
                dist * (1.0 - 1e-5)
            } else {
                f32::INFINITY
            };
            packet[filled] = (Ray::new(origin, w), g, reach);
            filled += 1;
            if filled == 4 {
                flush(&packet, 4, &mut sum);
                filled = 0;
            }
        }
        flush(&packet, filled, &mut sum);
        sum / s as f32
    }

    /// The sky's transfer per element: `T_lm = ∫ V(x, ω) max(0, n·ω) Y_lm(ω) dω`, averaged over
    /// the element's sample points, from [`SKY_DIRECTIONS`] cosine-weighted directions per
    /// point (fixed, rotated per point by a hash of its index: no pattern shared by
    /// neighbours); a direction counts when its ray leaves the scene.
    fn project_sky(&self) -> (Vec<[f32; 9]>, u64) {
        let s = self.per_element;
        let eps = self.scene.epsilon;
        let m = SKY_DIRECTIONS;
        self.par_map(|e, rays| {
            let mut sum = [0.0f32; 9];
            for (j, smp) in self.samples[e * s..(e + 1) * s].iter().enumerate() {
                if !smp.point[0].is_finite() {
                    continue;
                }
                let (t, b) = basis(smp.normal);
                let origin = mad(smp.point, smp.normal, eps);
                let rotation = unit_hash((e * s + j) as u64);
                for d in 0..m {
                    // Cosine-weighted: a stratified disc point lifted.
                    let u1 = (d as f32 + 0.5) / m as f32;
                    let u2 = (d as f32 * 0.618_034 + rotation).fract();
                    let r = u1.sqrt();
                    let phi = 2.0 * PI * u2;
                    let z = (1.0 - u1).max(0.0).sqrt();
                    let w = add(
                        add(scale(t, r * phi.cos()), scale(b, r * phi.sin())),
                        scale(smp.normal, z),
                    );
                    *rays += 1;
                    if !self
                        .scene
                        .occluded(&Ray::new(origin, w), 0.0, f32::INFINITY)
                    {
                        for (acc, yl) in sum.iter_mut().zip(sh9(w)) {
                            *acc += yl;
                        }
                    }
                }
            }
            // pdf cos/π: each unoccluded direction adds π/M · Y; mean over points.
            let w = PI / (m as f32 * s as f32);
            sum.map(|x| x * w)
        })
    }

    /// `f(element, rays)` for every element (original ids), on [`Self::par_chunks`]; the
    /// values and the rays counted.
    fn par_map<T: Copy + Default + Send>(
        &self,
        f: impl Fn(usize, &mut u64) -> T + Sync,
    ) -> (Vec<T>, u64) {
        let (done, rays) =
            self.par_chunks(|range, rays| -> Vec<T> { range.map(|e| f(e, rays)).collect() });
        let mut out = vec![T::default(); self.n()];
        for (start, values) in done {
            out[start..start + values.len()].copy_from_slice(&values);
        }
        (out, rays)
    }

    /// `f(elements, rays)` for chunks of the elements (original ids) on as many workers as
    /// threads, each taking the next chunk from a shared counter (not a thread per chunk): each
    /// chunk's first element and result, and the rays counted. The results do not depend on
    /// which worker took which chunk.
    fn par_chunks<R: Send>(
        &self,
        f: impl Fn(std::ops::Range<usize>, &mut u64) -> R + Sync,
    ) -> (Vec<(usize, R)>, u64) {
        let n = self.n();
        let chunk = n.div_ceil(self.threads * 8).clamp(1, 256);
        let chunks = n.div_ceil(chunk);
        let next = std::sync::atomic::AtomicUsize::new(0);
        let work = || {
            let mut done = Vec::new();
            let mut rays = 0u64;
            loop {
                let c = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                if c >= chunks {
                    return (done, rays);
                }
                let start = c * chunk;
                done.push((start, f(start..(start + chunk).min(n), &mut rays)));
            }
        };
        let workers = self.threads.min(chunks).max(1);
        let results: Vec<_> = std::thread::scope(|scope| {
            let handles: Vec<_> = (1..workers).map(|_| scope.spawn(work)).collect();
            let mut all = vec![work()];
            all.extend(handles.into_iter().map(|h| h.join().expect("no panic")));
            all
        });
        let mut rays = 0u64;
        let mut done = Vec::with_capacity(chunks);
        for (d, r) in results {
            rays += r;
            done.extend(d);
        }
        (done, rays)
    }
}

/// The direct irradiance of `lights` at `x` (front normal `normal`, unit) in `scene`, each
/// light behind its own shadow ray from just off the surface to just short of the light;
/// `rays` counts them. The tracer's shading and [`DirectLighting::at`] share it.
#[inline]
pub(crate) fn at_point(
    scene: &RayScene,
    lights: &[Light],
    x: V3,
    normal: V3,
    rays: &mut u64,
) -> V3 {
    let origin = mad(x, normal, scene.epsilon);
    let mut sum = [0.0f32; 3];
    for light in lights {
        let strength = light.strength();
        if strength == [0.0; 3] {
            continue;
        }
        let Some((g, w, dist)) = light.towards(x, normal) else {
            continue;
        };
        *rays += 1;
        let reach = if dist.is_finite() {
            dist * (1.0 - 1e-5)
        } else {
            f32::INFINITY
        };
        if !scene.occluded(&Ray::new(origin, w), 0.0, reach) {
            sum = add(sum, scale(strength, g));
        }
    }
    sum
}

#[inline]
fn v(tri: &[f32; 9], i: usize) -> V3 {
    [tri[3 * i], tri[3 * i + 1], tri[3 * i + 2]]
}

/// The base-2 radical inverse of `j` (van der Corput), in [0, 1).
fn radical_inverse(j: u32) -> f64 {
    j.reverse_bits() as f64 / 4_294_967_296.0
}

/// Two unit vectors completing `n` (unit) to an orthonormal frame.
fn basis(n: V3) -> (V3, V3) {
    let a = if n[0].abs() > 0.9 {
        [0.0, 1.0, 0.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let t = normalize(cross(a, n));
    (t, cross(n, t))
}

/// A number in [0, 1) from `i` (SplitMix64's finaliser).
fn unit_hash(i: u64) -> f32 {
    let mut z = i.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 40) as f32 / (1u64 << 24) as f32
}
