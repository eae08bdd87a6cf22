//! The radiance along one camera ray: a Whitted ray tree walked with an explicit stack.
//!
//! At a hit on a display face of element `e` at point `p` (direction `d`, the face's geometric
//! normal `n` turned towards the ray, `n_f`):
//!
//! ```text
//! L = B_e / π                                         the radiosity, a Lambertian radiance
//!   + Σ_lights Ks (s + 2) / (2π) max(0, r·v)^s · I s_g max(0, n_f·l) / |x_l - p|²   (visible)
//!   + w_r L(reflected ray) + w_t L(refracted ray)
//! ```
//!
//! The highlight is the normalised Phong lobe (energy conserving: its albedo at normal
//! incidence is at most Ks) lit by the point light's irradiance; `s_g` is the frame intensity
//! of the light's group (1 for a fixed light); a shadow ray to the light must be free.
//! Opaque surfaces reflect with `w_r = mirror`. A surface with a transmission filter is a
//! dielectric of index `ior` (outside: vacuum; inside: where the ray leaves through the
//! normal's side): the Fresnel reflectance `F` of unpolarised light (exact, with total
//! internal reflection past the critical angle giving `F = 1`) weights the two rays,
//! `w_r = F · mirror`, `w_t = (1 - F) · transmission` (so the mirror colour tints the
//! reflection of glass and zero turns it off). Rays missing the scene see black.
//!
//! Every ray carries its weight (the product of the weights above it), so the tree is a stack
//! of independent rays whose contributions add: no recursion, a fixed-size stack (a WGSL
//! function may not recurse either). A branch stops at the depth limit or when its weight is
//! zero.

use std::f32::consts::FRAC_1_PI;

use super::effects::MAX_DEPTH_LIMIT;
use super::scene::{Optics, TraceScene};
use crate::lights::{Light, at_point};
use crate::rays::{Hit, Ray, V3, add, dot, length, mad, max_component, mul, normalize, scale, sub};
use crate::smooth::Reconstruction;

/// A frame's lighting as the tracer reads it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct FrameInput<'a> {
    /// Radiosity per element, original ids.
    pub radiosity: &'a [[f32; 3]],
    /// Per point light: its intensity times its group's frame intensity.
    pub light_intensity: &'a [V3],
    /// When the frame shades smooth: the reconstruction and this frame's smooth-vertex values
    /// ([`Reconstruction::vertex_values`] of `radiosity`).
    pub smooth: Option<(Reconstruction<'a>, &'a [[f32; 3]])>,
    /// Lights that are not surfaces and the reflectance per element (original ids): their
    /// direct light at the hit point, `ρ H(x) / π`, is added to the radiosity's radiance.
    pub direct: Option<(&'a [Light], &'a [[f32; 3]])>,
}

/// Rays cast, by kind.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RayCounts {
    /// Camera rays (closest hit).
    pub primary: u64,
    /// Rays to point lights for highlights, and to the frame's lights that are not surfaces
    /// (any hit).
    pub shadow: u64,
    /// Reflected and refracted rays (closest hit).
    pub secondary: u64,
}

impl RayCounts {
    pub(crate) fn add(&mut self, other: &RayCounts) {
        self.primary += other.primary;
        self.shadow += other.shadow;
        self.secondary += other.secondary;
    }
}

/// A pending ray of the tree.
#[derive(Debug, Clone, Copy)]
struct Pending {
    origin: V3,
    dir: V3,
    weight: V3,
    depth: u32,
}

/// The stack holds the pending siblings of one path: at most one per level, plus the ray
/// being pushed.
const STACK: usize = MAX_DEPTH_LIMIT as usize + 2;

/// The radiosity of the hit point `p` on display face `f` as a radiance, `B / π`: smooth,
/// [`Reconstruction::at`] from the frame's smooth-vertex values; flat (or when the frame has no
/// smooth values), the value of the face's element. Plus the frame's direct light at `p`,
/// `ρ H(p) / π`, on the face's front (`direct::at_point`, its shadow rays counted).
#[inline(always)]
fn diffuse<const SMOOTH: bool>(
    scene: &TraceScene,
    frame: &FrameInput,
    f: u32,
    p: V3,
    counts: &mut RayCounts,
) -> V3 {
    let element = scene.rays.face_id[f as usize] as usize;
    let b = if SMOOTH && let Some((reconstruction, vertices)) = &frame.smooth {
        reconstruction.at(vertices, f as usize, p)
    } else {
        frame.radiosity[element]
    };
    let mut b = b;
    if let Some((lights, rho)) = frame.direct {
        let h = at_point(
            &scene.rays,
            lights,
            p,
            scene.rays.normals[f as usize],
            &mut counts.shadow,
        );
        b = add(b, mul(rho[element], h));
    }
    scale(b, FRAC_1_PI)
}

/// The Phong highlights at `p` seen along `d` (unit), behind shadow rays.
#[inline(always)]
fn highlights(
    scene: &TraceScene,
    frame: &FrameInput,
    optics: &Optics,
    p: V3,
    n_f: V3,
    d: V3,
    counts: &mut RayCounts,
) -> V3 {
    let mut sum = [0.0f32; 3];
    let norm = (optics.shininess + 2.0) * (0.5 * FRAC_1_PI);
    let reflected = mad(d, n_f, -2.0 * dot(d, n_f));
    let origin = mad(p, n_f, scene.rays.epsilon);
    for (light, intensity) in scene.lights.iter().zip(frame.light_intensity) {
        if max_component(*intensity) <= 0.0 {
            continue;
        }
        let to = sub(light.position, p);
        let dist = length(to);
        if dist <= 0.0 {
            continue;
        }
        let l = scale(to, 1.0 / dist);
        let cos_l = dot(n_f, l);
        if cos_l <= 0.0 {
            continue;
        }
        // The shadow ray leaves from just off the surface and stops just short of the light.
        counts.shadow += 1;
        let to_light = sub(light.position, origin);
        let reach = length(to_light);
        let shadow = Ray::new(origin, scale(to_light, 1.0 / reach));
        if scene.rays.occluded(&shadow, 0.0, reach * (1.0 - 1e-5)) {
            continue;
        }
        let lobe = dot(reflected, l).max(0.0).powf(optics.shininess) * norm;
        let e = scale(*intensity, cos_l / (dist * dist));
        sum = add(sum, scale(mul(optics.specular, e), lobe));
    }
    sum
}

/// Unpolarised Fresnel reflectance of a dielectric interface for `cos_i` (incident side,
/// `> 0`) and relative index `eta = n_i / n_t`; 1 past the critical angle. Also returns the
/// cosine of the refracted ray.
#[inline(always)]
pub(crate) fn fresnel(cos_i: f32, eta: f32) -> (f32, f32) {
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t >= 1.0 {
        return (1.0, 0.0);
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    // With n_i = eta, n_t = 1 (only the ratio matters).
    let rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    (0.5 * (rs * rs + rp * rp), cos_t)
}

/// The radiance arriving at `origin` from direction `-dir` (`dir` unit), with the effects the
/// const parameters switch on; `primary` is the closest hit of that ray in `(0, ∞)` (the
/// caller traces camera rays as packets).
#[inline(always)]
pub(crate) fn radiance<const HIGHLIGHTS: bool, const SECONDARY: bool, const SMOOTH: bool>(
    scene: &TraceScene,
    frame: &FrameInput,
    (origin, dir): (V3, V3),
    primary: Option<Hit>,
    max_depth: u32,
    counts: &mut RayCounts,
) -> V3 {
    if !HIGHLIGHTS && !SECONDARY {
        // The diffuse loop: one closest hit, one load.
        counts.primary += 1;
        return match primary {
            Some(hit) => {
                let f = scene.rays.tri_face[hit.tri as usize];
                diffuse::<SMOOTH>(scene, frame, f, mad(origin, dir, hit.t), counts)
            }
            None => [0.0; 3],
        };
    }
    let mut total = [0.0f32; 3];
    let mut stack = [Pending {
        origin,
        dir,
        weight: [1.0; 3],
        depth: 0,
    }; STACK];
    let mut sp = 1usize;
    while sp > 0 {
        sp -= 1;
        let ray = stack[sp];
        if ray.depth == 0 {
            counts.primary += 1;
        } else {
            counts.secondary += 1;
        }
        let hit = if ray.depth == 0 {
            primary
        } else {
            scene
                .rays
                .closest_hit(&Ray::new(ray.origin, ray.dir), 0.0, f32::INFINITY)
        };
        let Some(hit) = hit else {
            continue;
        };
        let f = scene.rays.tri_face[hit.tri as usize];
        let p = mad(ray.origin, ray.dir, hit.t);
        let local = diffuse::<SMOOTH>(scene, frame, f, p, counts);
        let optics = scene.optics_of(f);
        let n = scene.rays.normals[f as usize];
        let cos_n = dot(ray.dir, n);
        let n_f = if cos_n < 0.0 { n } else { scale(n, -1.0) };
        let mut local = local;
        if HIGHLIGHTS && optics.has_highlight() {
            let h = highlights(scene, frame, optics, p, n_f, ray.dir, counts);
            local = add(local, h);
        }
        total = add(total, mul(ray.weight, local));
        if !SECONDARY || ray.depth >= max_depth {
            continue;
        }
        let cos_i = -dot(ray.dir, n_f);
        let (mut w_r, mut w_t) = (mul(ray.weight, optics.mirror), [0.0f32; 3]);
        let mut refracted = [0.0f32; 3];
        if optics.transmits() {
            // Entering when the ray meets the normal's front side.
            let eta = if cos_n < 0.0 {
                1.0 / optics.ior
            } else {
                optics.ior
            };
            let (f, cos_t) = fresnel(cos_i, eta);
            w_r = scale(w_r, f);
            w_t = scale(mul(ray.weight, optics.transmission), 1.0 - f);
            refracted = normalize(mad(scale(ray.dir, eta), n_f, eta * cos_i - cos_t));
        }
        let depth = ray.depth + 1;
        if max_component(w_t) > 0.0 {
            stack[sp] = Pending {
                origin: mad(p, n_f, -scene.rays.epsilon),
                dir: refracted,
                weight: w_t,
                depth,
            };
            sp += 1;
        }
        if max_component(w_r) > 0.0 {
            stack[sp] = Pending {
                origin: mad(p, n_f, scene.rays.epsilon),
                dir: normalize(mad(ray.dir, n_f, 2.0 * cos_i)),
                weight: w_r,
                depth,
            };
            sp += 1;
        }
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresnel_at_normal_incidence_is_the_closed_form() {
        for ior in [1.1f32, 1.5, 2.4] {
            let expected = ((ior - 1.0) / (ior + 1.0)).powi(2);
            let (entering, cos_t) = fresnel(1.0, 1.0 / ior);
            let (leaving, _) = fresnel(1.0, ior);
            assert!(
                (entering - expected).abs() < 1e-6,
                "{entering} vs {expected}"
            );
            assert!((leaving - expected).abs() < 1e-6);
            assert_eq!(cos_t, 1.0);
        }
    }

    #[test]
    fn fresnel_is_total_past_the_critical_angle_and_partial_before() {
        let ior = 1.5f32;
        let critical = (1.0 / ior).asin();
        let (inside, _) = fresnel((critical + 0.01).cos(), ior);
        let (before, _) = fresnel((critical - 0.01).cos(), ior);
        assert_eq!(inside, 1.0);
        assert!(before < 1.0 && before > 0.04, "{before}");
    }
}
