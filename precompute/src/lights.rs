//! The scene's lights that are not surfaces as the bake sees them (DESIGN.md §9): point lights
//! of no light group, spot and directional lights and the sky. The runtime lights the elements
//! with them every frame; the bake only needs to know where their light falls, so that 2MSC's
//! estimates (the probes' coarse solve, the merge and split rules) and the refinement where
//! light changes see it: a scene lit only by a sun has no emitting surface, and without this
//! every estimate is zero and 2MSC merges each surface into one patch.
//!
//! [`SceneLights::irradiance`] is the direct irradiance at a point with a normal, each light
//! behind one ray of the bake's occluder (the same formulas as the runtime's
//! `lrr_runtime::lights::Light`; glTF's spot falloff); the sky by [`SKY_RAYS`] cosine-weighted
//! directions in the point's frame (fixed: the same answer for the same point, any thread
//! count). Its reflected part `ρ H` is the emission the estimates add.

use glam::DVec3;
use lrr_formats::DirectLightKind;

use crate::scene::Scene;
use crate::visibility::Occluder;

/// Cosine-weighted directions per point for the sky.
pub const SKY_RAYS: usize = 16;

/// One light, in f64.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Light {
    Point {
        position: DVec3,
        strength: [f64; 3],
    },
    Spot {
        position: DVec3,
        axis: DVec3,
        strength: [f64; 3],
        cos_inner: f64,
        cos_outer: f64,
    },
    Directional {
        towards: DVec3,
        strength: [f64; 3],
    },
}

/// The sky: `horizon + (zenith − horizon) · max(0, ω·up)` (uniform: both equal).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Sky {
    zenith: [f64; 3],
    horizon: [f64; 3],
    up: DVec3,
}

/// The lights of a scene with the occluder that shadows them.
#[derive(Clone, Copy)]
pub struct SceneLights<'a> {
    lights: &'a LightsOwned,
    occluder: Option<&'a dyn Occluder>,
    /// How far a ray to a directional light or the sky runs: past the scene.
    far: f64,
}

/// The converted lights (owned, so a [`SceneLights`] is a cheap copyable view).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LightsOwned {
    lights: Vec<Light>,
    sky: Option<Sky>,
    /// The scene's extent.
    extent: f64,
}

impl LightsOwned {
    /// The lights of `scene` the runtime's direct pass shades (its point lights of no group,
    /// spot and directional lights, its sky).
    pub fn of(scene: &Scene) -> Self {
        let mut lights: Vec<Light> = scene
            .point_lights
            .iter()
            .filter(|l| l.group.is_none())
            .map(|l| Light::Point {
                position: DVec3::from(l.position),
                strength: l.intensity,
            })
            .collect();
        let mut sky = None;
        for l in &scene.direct_lights {
            let direction = DVec3::from(l.direction).normalize_or_zero();
            match l.kind {
                DirectLightKind::Spot => lights.push(Light::Spot {
                    position: DVec3::from(l.position),
                    axis: direction,
                    strength: l.strength,
                    cos_inner: l.extra[0].cos(),
                    cos_outer: l.extra[1].cos(),
                }),
                DirectLightKind::Directional => lights.push(Light::Directional {
                    towards: -direction,
                    strength: l.strength,
                }),
                DirectLightKind::UniformSky => {
                    sky = Some(Sky {
                        zenith: l.strength,
                        horizon: l.strength,
                        up: DVec3::Y,
                    })
                }
                DirectLightKind::GradientSky => {
                    sky = Some(Sky {
                        zenith: l.strength,
                        horizon: l.extra,
                        up: direction,
                    })
                }
            }
        }
        LightsOwned {
            lights,
            sky,
            extent: scene.extent(),
        }
    }

    /// No light that is not a surface.
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty() && self.sky.is_none()
    }
}

impl<'a> SceneLights<'a> {
    /// `lights` shadowed by `occluder` (`None`: nothing occludes).
    pub fn new(lights: &'a LightsOwned, occluder: Option<&'a dyn Occluder>) -> Self {
        SceneLights {
            lights,
            occluder,
            far: 4.0 * lights.extent.max(f64::MIN_POSITIVE),
        }
    }

    fn owned(&self) -> &LightsOwned {
        self.lights
    }

    /// No light that is not a surface: every irradiance is zero, no ray is cast.
    pub fn is_empty(&self) -> bool {
        self.owned().is_empty()
    }

    /// The direct irradiance per channel at `x` on a surface with front normal `normal`
    /// (unit), shadows included.
    pub fn irradiance(&self, x: DVec3, normal: DVec3) -> [f64; 3] {
        let owned = self.owned();
        let mut h = [0.0f64; 3];
        for light in &owned.lights {
            let (g, to, strength) = match *light {
                Light::Point { position, strength } => {
                    let d = position - x;
                    let r2 = d.length_squared();
                    let cos = normal.dot(d) / r2.sqrt();
                    if r2 <= 0.0 || cos <= 0.0 {
                        continue;
                    }
                    (cos / r2, position, strength)
                }
                Light::Spot {
                    position,
                    axis,
                    strength,
                    cos_inner,
                    cos_outer,
                } => {
                    let d = position - x;
                    let r2 = d.length_squared();
                    let w = d / r2.sqrt();
                    let cos = normal.dot(w);
                    let cos_axis = -axis.dot(w);
                    if r2 <= 0.0 || cos <= 0.0 || cos_axis < cos_outer {
                        continue;
                    }
                    let falloff = if cos_inner <= cos_outer {
                        1.0
                    } else {
                        let t = ((cos_axis - cos_outer) / (cos_inner - cos_outer).max(1e-3))
                            .clamp(0.0, 1.0);
                        t * t
                    };
                    (cos * falloff / r2, position, strength)
                }
                Light::Directional { towards, strength } => {
                    let cos = normal.dot(towards);
                    if cos <= 0.0 {
                        continue;
                    }
                    (cos, x + towards * self.far, strength)
                }
            };
            if self.blocked(x, normal, to) {
                continue;
            }
            for c in 0..3 {
                h[c] += strength[c] * g;
            }
        }
        if let Some(sky) = owned.sky {
            let (t, b) = normal.any_orthonormal_pair();
            let mut sum = [0.0f64; 3];
            for j in 0..SKY_RAYS {
                // A fixed stratified set: rings by cos², spokes by the golden angle.
                let u1 = (j as f64 + 0.5) / SKY_RAYS as f64;
                let phi = j as f64 * 2.399_963_229_728_653;
                let r = u1.sqrt();
                let w = t * (r * phi.cos()) + b * (r * phi.sin()) + normal * (1.0 - u1).sqrt();
                if self.blocked(x, normal, x + w * self.far) {
                    continue;
                }
                let up = w.dot(sky.up).max(0.0);
                for c in 0..3 {
                    sum[c] += sky.horizon[c] + (sky.zenith[c] - sky.horizon[c]) * up;
                }
            }
            for c in 0..3 {
                h[c] += std::f64::consts::PI * sum[c] / SKY_RAYS as f64;
            }
        }
        h
    }

    /// The mean over the channels of [`SceneLights::irradiance`].
    pub fn mean_irradiance(&self, x: DVec3, normal: DVec3) -> f64 {
        if self.is_empty() {
            return 0.0;
        }
        let h = self.irradiance(x, normal);
        (h[0] + h[1] + h[2]) / 3.0
    }

    fn blocked(&self, x: DVec3, normal: DVec3, to: DVec3) -> bool {
        match self.occluder {
            Some(o) => o.occluded(x, normal, to, (x - to).normalize_or_zero()),
            None => false,
        }
    }
}

/// Sample points per element of [`sky_transfer`].
pub const SKY_SAMPLES: usize = 4;
/// Cosine-weighted directions per sample point of [`sky_transfer`] (the runtime's when it
/// projects a file that has none).
pub const SKY_DIRECTIONS: usize = 64;

/// The sky's transfer of each element (its polygons: its own, or the parts it is lit on; in
/// file order): its order-2 spherical
/// harmonic coefficients `T_lm = ∫ V(x, ω) max(0, n·ω) Y_lm(ω) dω` averaged over
/// [`SKY_SAMPLES`] points (equal-area strata of its fan triangles), each from
/// [`SKY_DIRECTIONS`] cosine-weighted directions (stratified, turned per point by a hash of
/// the polygon's index and the point's: fixed, the same bytes for any thread count); a
/// direction counts when nothing of the scene blocks it within 4 extents. What section
/// SKY_TRANSFER stores (`lrr_runtime::lights::DirectLighting` reads it).
pub fn sky_transfer(
    polygons: &[Vec<&crate::geometry::Polygon>],
    occluder: Option<&dyn Occluder>,
    extent: f64,
) -> Vec<f32> {
    use rayon::prelude::*;
    let far = 4.0 * extent.max(f64::MIN_POSITIVE);
    let per: Vec<[f32; 9]> = polygons
        .par_iter()
        .enumerate()
        .map(|(e, polygon)| {
            let normal = polygon[0].normal;
            let (t, b) = normal.any_orthonormal_pair();
            let mut sum = [0.0f64; 9];
            for (j, x) in sample_points(polygon).into_iter().enumerate() {
                let key = (e * SKY_SAMPLES + j) as u64;
                let turn = (crate::geometry::hash::mix(key) >> 11) as f64 / (1u64 << 53) as f64;
                for d in 0..SKY_DIRECTIONS {
                    let u1 = (d as f64 + 0.5) / SKY_DIRECTIONS as f64;
                    let u2 = (d as f64 * 0.618_033_988_749_894_8 + turn).fract();
                    let r = u1.sqrt();
                    let phi = 2.0 * std::f64::consts::PI * u2;
                    let w = t * (r * phi.cos()) + b * (r * phi.sin()) + normal * (1.0 - u1).sqrt();
                    let blocked = occluder.is_some_and(|o| o.occluded(x, normal, x + w * far, -w));
                    if !blocked {
                        for (s, y) in sum.iter_mut().zip(sh9(w)) {
                            *s += y;
                        }
                    }
                }
            }
            let scale = std::f64::consts::PI / (SKY_DIRECTIONS * SKY_SAMPLES) as f64;
            sum.map(|s| (s * scale) as f32)
        })
        .collect();
    per.concat()
}

/// The nine real orthonormal spherical harmonics of order ≤ 2 at unit `w`, in SKY_TRANSFER's
/// order (`lrr_formats::Display::sky_transfer`; the runtime's `lights::sh9` in f32).
fn sh9(w: DVec3) -> [f64; 9] {
    let (x, y, z) = (w.x, w.y, w.z);
    let c1 = 0.5 * (3.0 / std::f64::consts::PI).sqrt();
    let c2 = 0.5 * (15.0 / std::f64::consts::PI).sqrt();
    let c20 = 0.25 * (5.0 / std::f64::consts::PI).sqrt();
    [
        0.5 / std::f64::consts::PI.sqrt(),
        c1 * y,
        c1 * z,
        c1 * x,
        c2 * x * y,
        c2 * y * z,
        c20 * (3.0 * z * z - 1.0),
        c2 * x * z,
        0.5 * c2 * (x * x - y * y),
    ]
}

/// [`SKY_SAMPLES`] points of convex polygons (one element's): equal-area strata along their
/// fan triangles, the van der Corput sequence across (a Hammersley set).
fn sample_points(polygons: &[&crate::geometry::Polygon]) -> Vec<DVec3> {
    let tris: Vec<(DVec3, DVec3, DVec3, f64)> = polygons
        .iter()
        .flat_map(|p| {
            let v = p.vertices();
            (1..v.len() - 1).map(move |i| {
                let (a, b, c) = (v[0], v[i], v[i + 1]);
                (a, b, c, 0.5 * (b - a).cross(c - a).length())
            })
        })
        .collect();
    let total: f64 = tris.iter().map(|t| t.3).sum();
    (0..SKY_SAMPLES)
        .map(|j| {
            let u = (j as f64 + 0.5) / SKY_SAMPLES as f64 * total;
            let mut acc = 0.0;
            let mut pick = (tris.len() - 1, 0.5);
            for (k, t) in tris.iter().enumerate() {
                if u < acc + t.3 || k == tris.len() - 1 {
                    pick = (k, ((u - acc) / t.3.max(f64::MIN_POSITIVE)).clamp(0.0, 1.0));
                    break;
                }
                acc += t.3;
            }
            let q = ((j as u32).reverse_bits() as f64 / 4_294_967_296.0 + 0.5 / SKY_SAMPLES as f64)
                .fract();
            let (a, b, c, _) = tris[pick.0];
            let root = pick.1.sqrt();
            a + (b - a) * (root * (1.0 - q)) + (c - a) * (root * q)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene_with(point: Option<[f64; 3]>, sun: Option<[f64; 3]>, sky: bool) -> LightsOwned {
        let mut lights = Vec::new();
        if let Some(p) = point {
            lights.push(Light::Point {
                position: DVec3::from(p),
                strength: [2.0, 1.0, 0.5],
            });
        }
        if let Some(d) = sun {
            lights.push(Light::Directional {
                towards: -DVec3::from(d).normalize(),
                strength: [3.0; 3],
            });
        }
        LightsOwned {
            lights,
            sky: sky.then_some(Sky {
                zenith: [1.0; 3],
                horizon: [1.0; 3],
                up: DVec3::Z,
            }),
            extent: 10.0,
        }
    }

    #[test]
    fn unoccluded_lights_are_their_closed_forms() {
        let owned = scene_with(Some([0.0, 0.0, 2.0]), Some([1.0, 0.0, -1.0]), true);
        let lights = SceneLights::new(&owned, None);
        let h = lights.irradiance(DVec3::new(1.0, 0.0, 0.0), DVec3::Z);
        let point = 2.0 / 5f64.powf(1.5);
        let sun = 3.0 / 2f64.sqrt();
        let sky = std::f64::consts::PI;
        assert!((h[0] - (2.0 * point + sun + sky)).abs() < 1e-12, "{h:?}");
        assert!((h[2] - (0.5 * point + sun + sky)).abs() < 1e-12, "{h:?}");
        // From behind: nothing but the sky, which is a whole sphere.
        let h = lights.irradiance(DVec3::new(1.0, 0.0, 0.0), -DVec3::Z);
        assert!(h.iter().all(|&c| (c - sky).abs() < 1e-12), "{h:?}");
        assert!(SceneLights::new(&LightsOwned::default(), None).is_empty());
    }

    #[test]
    fn an_open_plane_sees_the_whole_sky() {
        // Unoccluded: T_00 = π Y00 exactly (every direction counts), so a uniform sky L gives
        // π L; the other coefficients are the clamped cosine's, estimated.
        let square = crate::geometry::rectangle(0.0, 1.0, 0.0, 1.0, 0.0, false);
        let t = sky_transfer(&[vec![&square]], None, 1.0);
        let y00 = 0.5 / std::f64::consts::PI.sqrt();
        assert!(
            (f64::from(t[0]) - std::f64::consts::PI * y00).abs() < 1e-6,
            "{t:?}"
        );
        // Y10 along the normal: ∫ cos² Y10-ish = 2π/3 · 0.4886 exactly; the estimate within 1%.
        let normal_axis = if square.normal.z.abs() > 0.5 { 2 } else { 1 };
        let exact = 2.0 * std::f64::consts::PI / 3.0 * 0.488_602_5 * square.normal.z.signum();
        assert!(
            (f64::from(t[normal_axis]) - exact).abs() < 1e-2 * exact.abs(),
            "{t:?} vs {exact}"
        );
    }
}
