//! Simulate only what the scene calls for: which effects a frame needs, decided from the
//! materials, the point lights, this frame's light-group intensities and the camera, and why.
//!
//! - *secondary rays* (mirror reflection, refraction with Fresnel weights): only when some
//!   material has a mirror reflectance or a transmission filter, and some triangle of it lies
//!   in the camera's view (`View::pyramid`: not wholly outside one side of the
//!   view's pyramid). Without them only camera rays are traced, so a mirror out of view is
//!   never hit.
//! - *highlights* (the Phong term, one shadow ray per point light at every hit of a specular
//!   material): only when some material has a specular colour, some point light shines this
//!   frame (non-zero intensity, its group's intensity non-zero), and a specular triangle lies
//!   in view or secondary rays are on (a mirror may show it). The radiosity already holds the
//!   diffuse light, so without highlights a point light changes nothing and no shadow ray is
//!   cast.
//! - *smooth*: the radiosity at the hit point by the smooth reconstruction
//!   ([`Reconstruction::at`](crate::Reconstruction::at): smooth-vertex values once per frame,
//!   mean value coordinates per hit), when the file holds the weights (section SMOOTH) and the
//!   caller did not ask for flat shading; otherwise the element's flat value.
//!
//! The render loop is monomorphised over these three switches (const generics), so a scene
//! without them runs a loop with no light loop, no ray stack and no reconstruction in it: a
//! diffuse scene costs one closest hit and one load per pixel.

use std::fmt::Write as _;

use super::View;
use super::scene::TraceScene;

/// Default limit of the ray tree: a primary ray and up to 8 bounces of reflection or
/// refraction below it.
pub const DEFAULT_MAX_DEPTH: u32 = 8;
/// Largest depth limit (sizes the explicit ray stack).
pub const MAX_DEPTH_LIMIT: u32 = 16;

/// What a frame simulates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Effects {
    /// Phong highlights from the point lights, each behind a shadow ray.
    pub highlights: bool,
    /// Mirror reflection and refraction rays (a ray tree up to `max_depth`).
    pub secondary: bool,
    /// Smooth reconstruction of the radiosity at hit points.
    pub smooth: bool,
    /// Bounces below a primary ray, at most [`MAX_DEPTH_LIMIT`].
    pub max_depth: u32,
}

impl Effects {
    /// Every effect on (for measuring what the decision saves; the image is the same).
    pub fn all() -> Self {
        Effects {
            highlights: true,
            secondary: true,
            smooth: true,
            max_depth: DEFAULT_MAX_DEPTH,
        }
    }
}

/// The decision and the reasons, one line per effect.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Decision {
    /// What the frame simulates.
    pub effects: Effects,
    /// Why, for `lrr render --explain`.
    pub reasons: Vec<String>,
}

impl Decision {
    /// The reasons as text, one effect a line.
    pub fn text(&self) -> String {
        let mut s = String::new();
        for r in &self.reasons {
            let _ = writeln!(s, "{r}");
        }
        s
    }
}

/// Names of the materials for which `pick` holds (at most 4, then a count).
fn named(scene: &TraceScene, pick: impl Fn(usize) -> bool) -> (usize, String) {
    let names: Vec<String> = (0..scene.optics.len())
        .filter(|&i| pick(i))
        .map(|i| match scene.material_names[i].as_str() {
            "" => format!("#{i}"),
            s => format!("'{s}'"),
        })
        .collect();
    let shown = names.iter().take(4).cloned().collect::<Vec<_>>().join(", ");
    let more = names.len().saturating_sub(4);
    let text = if more > 0 {
        format!("{shown} and {more} more")
    } else {
        shown
    };
    (names.len(), text)
}

/// Which kinds of non-diffuse triangles `view` may see: (specular, mirror, transmissive).
fn in_view(scene: &TraceScene, view: &View) -> (bool, bool, bool) {
    let pyramid = view.pyramid();
    // Kinds the scene has none of count as seen, so the scan stops once the others are.
    let has = |p: fn(&super::scene::Optics) -> bool| scene.optics.iter().any(p);
    let mut seen = (
        !has(|o| o.has_highlight()),
        !has(|o| o.reflects()),
        !has(|o| o.transmits()),
    );
    if seen == (true, true, true) {
        return (false, false, false);
    }
    let none = seen;
    for &t in &scene.special {
        let o = scene.optics_of(scene.rays.tri_face[t as usize]);
        let wanted = (o.has_highlight() && !seen.0)
            || (o.reflects() && !seen.1)
            || (o.transmits() && !seen.2);
        if wanted && pyramid.may_see(&scene.rays.tris[t as usize]) {
            seen.0 |= o.has_highlight();
            seen.1 |= o.reflects();
            seen.2 |= o.transmits();
            if seen == (true, true, true) {
                break;
            }
        }
    }
    // A kind the scene lacks is not in view.
    (seen.0 && !none.0, seen.1 && !none.1, seen.2 && !none.2)
}

/// The effects of a frame of `scene` seen through `view` whose point lights shine at `light_scale` times their intensity (one factor per light); `smooth`: the
/// caller's choice of the smooth reconstruction (kept only when the file has SMOOTH weights).
pub(crate) fn decide(
    scene: &TraceScene,
    view: &View,
    light_scale: &[f32],
    max_depth: u32,
    smooth: bool,
) -> Decision {
    let mut reasons = Vec::new();
    let (specular, specular_names) = named(scene, |i| scene.optics[i].has_highlight());
    let (mirrors, mirror_names) = named(scene, |i| scene.optics[i].reflects());
    let (glass, glass_names) = named(scene, |i| scene.optics[i].transmits());
    let (specular_seen, mirror_seen, glass_seen) = in_view(scene, view);
    let mirror_seen = mirrors > 0 && mirror_seen;
    let glass_seen = glass > 0 && glass_seen;
    let secondary = mirror_seen || glass_seen;
    let lit = scene
        .lights
        .iter()
        .zip(light_scale)
        .filter(|(l, s)| **s > 0.0 && l.intensity.iter().any(|&c| c > 0.0))
        .count();
    let specular_shown = specular_seen || secondary;
    let highlights = specular > 0 && lit > 0 && specular_shown;
    reasons.push(match (specular, lit) {
        (0, _) => "highlights and shadow rays: off (no material has a specular colour Ks)".into(),
        _ if !specular_shown => format!(
            "highlights and shadow rays: off (specular {specular_names}, but none of it is in \
             the camera's view and no mirror or glass is)"
        ),
        (_, 0) if scene.lights.is_empty() => format!(
            "highlights and shadow rays: off (specular {specular_names}, but the file has no \
             point lights)"
        ),
        (_, 0) => format!(
            "highlights and shadow rays: off (specular {specular_names}, but none of the {} \
             point lights shines this frame)",
            scene.lights.len()
        ),
        _ => format!(
            "highlights and shadow rays: on (specular {specular_names}; {lit} point light(s) \
             shining, one shadow ray each per specular hit)"
        ),
    });
    reasons.push(if secondary {
        let mut what = Vec::new();
        if mirror_seen {
            what.push(format!("mirror {mirror_names}"));
        }
        if glass_seen {
            what.push(format!("transmissive {glass_names} (Fresnel, refraction)"));
        }
        format!(
            "secondary rays: on ({} in view; ray tree up to depth {max_depth})",
            what.join("; ")
        )
    } else if mirrors + glass > 0 {
        let mut what = Vec::new();
        if mirrors > 0 {
            what.push(format!("mirror {mirror_names}"));
        }
        if glass > 0 {
            what.push(format!("transmissive {glass_names}"));
        }
        format!(
            "secondary rays: off ({}, but out of the camera's view: camera rays cannot hit it)",
            what.join("; ")
        )
    } else {
        "secondary rays: off (no material has a mirror reflectance or a transmission filter)".into()
    });
    reasons.push(match (scene.has_smooth, smooth) {
        (true, true) => "smooth radiosity: on (the file's SMOOTH weights: smooth-vertex values \
                         once per frame, mean value coordinates at each hit)"
            .into(),
        (true, false) => "smooth radiosity: off (flat asked for; flat element values)".into(),
        (false, _) => {
            "smooth radiosity: off (the file has no SMOOTH section; flat element values)".into()
        }
    });
    let smooth = smooth && scene.has_smooth;
    Decision {
        effects: Effects {
            highlights,
            secondary,
            smooth,
            max_depth,
        },
        reasons,
    }
}
