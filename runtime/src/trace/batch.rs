//! Rays in batches, by kind, for `lrr bench render`: the camera rays of a view, the closest
//! hits of a batch, the shadow rays from hits to the point lights and the mirror reflections
//! of hits, each traced on the calling thread: shadow rays by the renderer's any-hit loop,
//! closest hits eight consecutive rays at a time as packets where the CPU has AVX2
//! (`rays/bvh4/packet8.rs`), else four (`rays/bvh4/packet.rs`), as the renderer traces camera
//! rays; the same answers as ray by ray.

use super::camera::View;
use super::scene::TraceScene;
use crate::rays::{Hit, Ray, V3, dot, length, mad, normalize, scale, sub};

/// Rays: origins, unit directions and the far end of each (`f32::INFINITY`: unbounded).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RayBatch {
    /// Origins.
    pub origins: Vec<[f32; 3]>,
    /// Unit directions.
    pub dirs: Vec<[f32; 3]>,
    /// Far ends.
    pub t_max: Vec<f32>,
}

impl RayBatch {
    /// Number of rays.
    pub fn len(&self) -> usize {
        self.origins.len()
    }

    /// No rays.
    pub fn is_empty(&self) -> bool {
        self.origins.is_empty()
    }

    fn push(&mut self, origin: V3, dir: V3, t_max: f32) {
        self.origins.push(origin);
        self.dirs.push(dir);
        self.t_max.push(t_max);
    }
}

/// A closest hit: the distance and the display triangle's id (see `lrr_formats::display`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TraceHit {
    /// Distance along the unit direction.
    pub t: f32,
    /// Display triangle id.
    pub triangle: u32,
    /// Leaf-order index (internal: what the shading reads).
    pub(crate) leaf: u32,
}

/// The camera rays of `view` on a `width × height` image in blocks of 4 × 2 pixels (the
/// blocks row by row, each block's top row first; a last odd row or narrow column as single
/// pixels after the blocks of its rows), so that the packets of eight (and four) rays of
/// [`closest`] are neighbours in both directions: `lrr bench render` measured primary rays
/// ×1.1 over whole rows (docs/PERFORMANCE.md, round 4).
pub(crate) fn primary(view: &View, width: u32, height: u32) -> RayBatch {
    let mut batch = RayBatch::default();
    let mut push = |x: u32, y: u32| {
        batch.push(
            view.eye(),
            view.direction(x, y, width, height),
            f32::INFINITY,
        )
    };
    for y in (0..height).step_by(2) {
        let rows = (height - y).min(2);
        let blocks = if rows == 2 { width / 4 } else { 0 };
        for x in (0..4 * blocks).step_by(4) {
            for (dx, dy) in (0..8).map(|j| (j % 4, j / 4)) {
                push(x + dx, y + dy);
            }
        }
        for dy in 0..rows {
            for x in 4 * blocks..width {
                push(x, y + dy);
            }
        }
    }
    batch
}

/// The closest hit of each ray, eight consecutive rays at a time as a packet with AVX2, else
/// four (neighbouring camera rays share most of their traversal; the answers are those ray by
/// ray).
pub(crate) fn closest(
    scene: &TraceScene,
    triangle_ids: &[u32],
    batch: &RayBatch,
) -> Vec<Option<TraceHit>> {
    let hit = |h: Hit| TraceHit {
        t: h.t,
        triangle: triangle_ids[h.tri as usize],
        leaf: h.tri,
    };
    let one = |ray: &Ray, t_max| scene.rays.closest_hit(ray, 0.0, t_max).map(hit);
    if scene.rays.packets_of_eight() {
        in_packets(
            batch,
            |rays: &[Ray; 8], t_max| {
                scene
                    .rays
                    .closest_hit8(rays, 0.0, t_max)
                    .map(|h| h.map(hit))
            },
            one,
        )
    } else {
        in_packets(
            batch,
            |rays: &[Ray; 4], t_max| {
                scene
                    .rays
                    .closest_hit4(rays, 0.0, t_max)
                    .map(|h| h.map(hit))
            },
            one,
        )
    }
}

/// Whether each ray is blocked before its far end, four consecutive rays at a time as a
/// packet (shadow rays of neighbouring pixels towards one light share most of their
/// traversal; the answers are those ray by ray).
pub(crate) fn any(scene: &TraceScene, batch: &RayBatch) -> Vec<bool> {
    in_packets(
        batch,
        |rays: &[Ray; 4], t_max| scene.rays.occluded4(rays, 0.0, t_max),
        |ray, t_max| scene.rays.occluded(ray, 0.0, t_max),
    )
}

/// `many` on each run of `N` consecutive rays of `batch`, `one` on the rest, in order.
fn in_packets<T, const N: usize>(
    batch: &RayBatch,
    many: impl Fn(&[Ray; N], [f32; N]) -> [T; N],
    one: impl Fn(&Ray, f32) -> T,
) -> Vec<T> {
    let ray = |i: usize| Ray::new(batch.origins[i], batch.dirs[i]);
    let mut out = Vec::with_capacity(batch.len());
    let packets = batch.len() / N;
    for p in 0..packets {
        let rays = std::array::from_fn(|j| ray(N * p + j));
        let t_max = std::array::from_fn(|j| batch.t_max[N * p + j]);
        out.extend(many(&rays, t_max));
    }
    for i in N * packets..batch.len() {
        out.push(one(&ray(i), batch.t_max[i]));
    }
    out
}

/// The hit point and the normal facing the ray.
fn surface(scene: &TraceScene, batch: &RayBatch, i: usize, hit: &TraceHit) -> (V3, V3) {
    let d = batch.dirs[i];
    let p = mad(batch.origins[i], d, hit.t);
    let n = scene.rays.normals[scene.rays.tri_face[hit.leaf as usize] as usize];
    (p, if dot(d, n) < 0.0 { n } else { scale(n, -1.0) })
}

/// From every hit, a shadow ray to every point light in front of the surface, light by light
/// (all of the first light's rays in the hits' order, then the next light's), so that
/// consecutive rays head for one light and [`any`]'s packets of four share their traversal.
pub(crate) fn shadow(scene: &TraceScene, batch: &RayBatch, hits: &[Option<TraceHit>]) -> RayBatch {
    let surfaces: Vec<Option<(V3, V3)>> = hits
        .iter()
        .enumerate()
        .map(|(i, hit)| {
            let (p, n_f) = surface(scene, batch, i, hit.as_ref()?);
            Some((mad(p, n_f, scene.rays.epsilon), n_f))
        })
        .collect();
    let mut out = RayBatch::default();
    for light in &scene.lights {
        for &(origin, n_f) in surfaces.iter().flatten() {
            let to = sub(light.position, origin);
            let dist = length(to);
            if dist > 0.0 && dot(to, n_f) > 0.0 {
                out.push(origin, scale(to, 1.0 / dist), dist * (1.0 - 1e-5));
            }
        }
    }
    out
}

/// From every hit, the mirror reflection.
pub(crate) fn reflected(
    scene: &TraceScene,
    batch: &RayBatch,
    hits: &[Option<TraceHit>],
) -> RayBatch {
    let mut out = RayBatch::default();
    for (i, hit) in hits.iter().enumerate() {
        let Some(hit) = hit else { continue };
        let (p, n_f) = surface(scene, batch, i, hit);
        let d = batch.dirs[i];
        let r = normalize(mad(d, n_f, -2.0 * dot(d, n_f)));
        out.push(mad(p, n_f, scene.rays.epsilon), r, f32::INFINITY);
    }
    out
}
