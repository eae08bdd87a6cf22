//! The [`Tracer`]: a file's display data, checked once, and frames rendered in tiles by std
//! threads.
//!
//! The image is cut into bands of [`TILE_ROWS`] rows; scoped threads take the next band from a
//! shared queue until none is left (a thread the OS preempts holds up only its band). Every
//! pixel depends only on its own ray tree, so the image is the same bytes for any thread count.

use std::sync::Mutex;

use lrr_formats::{Camera, OperatorFile, PointLight};

use super::batch::{self, RayBatch, TraceHit};
use super::camera::View;
use super::effects::{self, Decision, Effects, MAX_DEPTH_LIMIT};
use super::scene::TraceScene;
use super::shade::{FrameInput, RayCounts, radiance};
use crate::error::{RuntimeError, input};
use crate::lights::Light;
use crate::rays::{Hit, Ray, V3, scale};
use crate::smooth::Reconstruction;

/// Rows of pixels per work item.
pub const TILE_ROWS: usize = 8;

/// A rendered image: linear RGB radiance, rows top to bottom.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` pixels, row-major from the top left.
    pub pixels: Vec<[f32; 3]>,
}

impl Image {
    /// The pixel at column `x`, row `y` (from the top).
    pub fn at(&self, x: u32, y: u32) -> [f32; 3] {
        self.pixels[y as usize * self.width as usize + x as usize]
    }
}

/// A frame's lighting: the radiosity the evaluator computed and the light groups' intensities
/// (which scale the point lights of each group), and the lights that are not surfaces whose
/// direct light is added at every shaded point.
#[derive(Debug, Clone, Copy, Default)]
pub struct Lighting<'a> {
    /// Radiosity per element, original ids (what [`Evaluator::evaluate`](crate::Evaluator)
    /// writes); with [`Lighting::direct`], without the lights' reflected direct light (`B − ρ ⊙
    /// H` per element, `H` from
    /// [`DirectLighting::irradiance`](crate::lights::DirectLighting)): the bounced light, which
    /// the shaded point's own direct light completes.
    pub radiosity: &'a [[f32; 3]],
    /// One intensity per light group of the file (1 = as baked); a point light of group `g`
    /// shines at `intensities[g]` times its intensity.
    pub group_intensities: &'a [f32],
    /// Lights that are not surfaces, shaded per point: `ρ(x) H(x) / π` added at every hit, each
    /// light behind its own shadow ray (DESIGN.md §9); `None`: none.
    pub direct: Option<DirectShading<'a>>,
}

/// The lights a frame adds at every shaded point, and the reflectance they are reflected with.
#[derive(Debug, Clone, Copy)]
pub struct DirectShading<'a> {
    /// The lights (the frame's, as
    /// [`DirectLighting::irradiance`](crate::lights::DirectLighting) took them).
    pub lights: &'a [Light],
    /// Reflectance per element, original ids ([`Operator::reflectance`](crate::Operator)).
    pub reflectance: &'a [[f32; 3]],
}

/// What a render produced besides the image.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderReport {
    /// The effects simulated and why.
    pub decision: Decision,
    /// Rays cast, by kind.
    pub rays: RayCounts,
}

/// A ray tracer over an operator file's display data (fan triangles of the display faces, the
/// file's BVH, materials, point lights, cameras). See the [module docs](super).
#[derive(Debug, Clone)]
pub struct Tracer {
    scene: TraceScene,
    cameras: Vec<Camera>,
    max_depth: u32,
    /// Shade with the smooth reconstruction when the file has SMOOTH weights.
    smooth: bool,
}

impl Tracer {
    /// The tracer of `file`: an error when the file has no BVH (re-bake it) or its display data
    /// does not fit together.
    pub fn new(file: &OperatorFile) -> Result<Self, RuntimeError> {
        Ok(Tracer {
            scene: TraceScene::new(file)?,
            cameras: file.display.cameras.clone(),
            max_depth: effects::DEFAULT_MAX_DEPTH,
            smooth: true,
        })
    }

    /// Chooses the reconstruction of the radiosity at hit points: smooth (the default when the
    /// file has SMOOTH weights; an error when it has none) or flat (each element's value).
    pub fn set_smooth(&mut self, smooth: bool) -> Result<(), RuntimeError> {
        if smooth && !self.scene.has_smooth {
            return Err(input(
                "smooth shading needs the smooth weights (section SMOOTH, format 1.2) that \
                 this file lacks; re-bake it with this lrr, or shade flat",
            ));
        }
        self.smooth = smooth;
        Ok(())
    }

    /// Sets the depth limit of the ray tree (bounces below a primary ray), at most
    /// [`MAX_DEPTH_LIMIT`].
    pub fn set_max_depth(&mut self, depth: u32) -> Result<(), RuntimeError> {
        if depth > MAX_DEPTH_LIMIT {
            return Err(input(format!(
                "the ray depth limit is at most {MAX_DEPTH_LIMIT}, got {depth}"
            )));
        }
        self.max_depth = depth;
        Ok(())
    }

    /// The file's cameras.
    pub fn cameras(&self) -> &[Camera] {
        &self.cameras
    }

    /// The file's point lights.
    pub fn point_lights(&self) -> &[PointLight] {
        &self.scene.lights
    }

    /// Number of display triangles.
    pub fn triangle_count(&self) -> usize {
        self.scene.rays.tris.len()
    }

    /// The camera rays of `view` on a `width × height` image, in blocks of 4 × 2 pixels
    /// (benchmarks: the order in which [`Tracer::closest_hits`] packs them best).
    pub fn primary_rays(&self, view: &View, width: u32, height: u32) -> RayBatch {
        batch::primary(view, width, height)
    }

    /// The closest hit of every ray of `rays`, on this thread (the renderer's traversal).
    pub fn closest_hits(&self, rays: &RayBatch) -> Vec<Option<TraceHit>> {
        batch::closest(&self.scene, &self.scene.rays.tri_id, rays)
    }

    /// Whether each ray of `rays` is blocked before its far end, on this thread (the shadow
    /// rays' any-hit traversal).
    pub fn occluded(&self, rays: &RayBatch) -> Vec<bool> {
        batch::any(&self.scene, rays)
    }

    /// From every hit of `rays`, a shadow ray to each point light in front of the surface,
    /// light by light (the first light's rays in the hits' order, then the next light's).
    pub fn shadow_rays(&self, rays: &RayBatch, hits: &[Option<TraceHit>]) -> RayBatch {
        batch::shadow(&self.scene, rays, hits)
    }

    /// From every hit of `rays`, its mirror reflection.
    pub fn reflected_rays(&self, rays: &RayBatch, hits: &[Option<TraceHit>]) -> RayBatch {
        batch::reflected(&self.scene, rays, hits)
    }

    /// The effects a frame with these lights through `view` needs, and why (`lrr render
    /// --explain`).
    pub fn decide(&self, view: &View, lighting: &Lighting) -> Result<Decision, RuntimeError> {
        let scales = self.light_intensities(lighting)?;
        Ok(self.decision(view, &scales))
    }

    fn decision(&self, view: &View, intensities: &[V3]) -> Decision {
        let scales: Vec<f32> = intensities
            .iter()
            .map(|i| i[0].max(i[1]).max(i[2]))
            .collect();
        effects::decide(&self.scene, view, &scales, self.max_depth, self.smooth)
    }

    /// Renders `view` at `width × height` with `threads` threads (0: one per available core),
    /// simulating what the scene needs.
    pub fn render(
        &self,
        view: &View,
        lighting: &Lighting,
        width: u32,
        height: u32,
        threads: usize,
    ) -> Result<(Image, RenderReport), RuntimeError> {
        let intensities = self.light_intensities(lighting)?;
        let decision = self.decision(view, &intensities);
        let effects = decision.effects;
        let (image, rays) = self.render_effects(
            view,
            lighting,
            &intensities,
            effects,
            width,
            height,
            threads,
        )?;
        Ok((image, RenderReport { decision, rays }))
    }

    /// [`render`](Self::render) with the effects forced (e.g. [`Effects::all`] to measure what
    /// the decision saves; an effect the scene cannot show changes nothing in the image).
    pub fn render_with(
        &self,
        view: &View,
        lighting: &Lighting,
        effects: Effects,
        width: u32,
        height: u32,
        threads: usize,
    ) -> Result<(Image, RayCounts), RuntimeError> {
        if effects.max_depth > MAX_DEPTH_LIMIT {
            return Err(input(format!(
                "the ray depth limit is at most {MAX_DEPTH_LIMIT}, got {}",
                effects.max_depth
            )));
        }
        let intensities = self.light_intensities(lighting)?;
        self.render_effects(
            view,
            lighting,
            &intensities,
            effects,
            width,
            height,
            threads,
        )
    }

    /// Per point light: intensity times its group's intensity; checks the lighting's sizes.
    fn light_intensities(&self, lighting: &Lighting) -> Result<Vec<V3>, RuntimeError> {
        let n = self.scene.n();
        if lighting.radiosity.len() != n {
            return Err(input(format!(
                "radiosity: {} values for {n} elements",
                lighting.radiosity.len()
            )));
        }
        if let Some(i) = lighting
            .radiosity
            .iter()
            .position(|b| b.iter().any(|c| !c.is_finite()))
        {
            return Err(input(format!("radiosity of element {i} is not finite")));
        }
        self.group_light_intensities(lighting.group_intensities)
    }

    /// Per point light: intensity times its group's intensity; checks the group intensities.
    fn group_light_intensities(&self, groups: &[f32]) -> Result<Vec<V3>, RuntimeError> {
        if groups.len() != self.scene.groups {
            return Err(input(format!(
                "light group intensities: {} values for the file's {} groups",
                groups.len(),
                self.scene.groups
            )));
        }
        if let Some(g) = groups.iter().position(|a| !(a.is_finite() && *a >= 0.0)) {
            return Err(input(format!(
                "light group intensity {g} is {}; intensities must be finite and >= 0",
                groups[g]
            )));
        }
        Ok(self
            .scene
            .lights
            .iter()
            .map(|l| match l.group {
                PointLight::FIXED => l.intensity,
                g => scale(l.intensity, groups[g as usize]),
            })
            .collect())
    }

    #[allow(clippy::too_many_arguments)]
    fn render_effects(
        &self,
        view: &View,
        lighting: &Lighting,
        intensities: &[V3],
        effects: Effects,
        width: u32,
        height: u32,
        threads: usize,
    ) -> Result<(Image, RayCounts), RuntimeError> {
        let pixels = (width as usize)
            .checked_mul(height as usize)
            .filter(|&p| p > 0 && p <= 1 << 28)
            .ok_or_else(|| {
                input(format!(
                    "image size {width}x{height}: need at least 1 and at most 2^28 pixels"
                ))
            })?;
        // Smooth: the smooth-vertex values once per frame, then per hit `Reconstruction::at`.
        let reconstruction = match (&self.scene.smooth, effects.smooth) {
            (Some((geometry, weights)), true) => Some(Reconstruction::from_parts(
                geometry,
                weights,
                &self.scene.element_id,
            )?),
            _ => None,
        };
        let mut vertices = Vec::new();
        if let Some(r) = &reconstruction {
            vertices = vec![[0.0f32; 3]; r.vertex_count()];
            r.vertex_values(lighting.radiosity, &mut vertices)?;
        }
        if let Some(d) = &lighting.direct {
            if d.reflectance.len() != self.scene.n() {
                return Err(input(format!(
                    "direct shading: {} reflectances for {} elements",
                    d.reflectance.len(),
                    self.scene.n()
                )));
            }
            for (i, light) in d.lights.iter().enumerate() {
                light
                    .check()
                    .map_err(|p| input(format!("light {i} ({light:?}): {p}")))?;
            }
        }
        let frame = FrameInput {
            radiosity: lighting.radiosity,
            light_intensity: intensities,
            smooth: reconstruction.map(|r| (r, vertices.as_slice())),
            direct: lighting
                .direct
                .filter(|d| !d.lights.is_empty())
                .map(|d| (d.lights, d.reflectance)),
        };
        let mut image = Image {
            width,
            height,
            pixels: vec![[0.0; 3]; pixels],
        };
        let band = TILE_ROWS * width as usize;
        let threads = match threads {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
            t => t,
        }
        .min(pixels.div_ceil(band));
        let queue = Mutex::new(image.pixels.chunks_mut(band).enumerate());
        let job = Job {
            scene: &self.scene,
            frame,
            view,
            width,
            height,
            effects,
        };
        let counts = std::thread::scope(|s| {
            let workers: Vec<_> = (1..threads)
                .map(|_| s.spawn(|| job.take_tiles(&queue)))
                .collect();
            let mut counts = job.take_tiles(&queue);
            for w in workers {
                match w.join() {
                    Ok(c) => counts.add(&c),
                    Err(panic) => std::panic::resume_unwind(panic),
                }
            }
            counts
        });
        Ok((image, counts))
    }
}

/// One frame's work, shared by the threads.
struct Job<'a> {
    scene: &'a TraceScene,
    frame: FrameInput<'a>,
    view: &'a View,
    width: u32,
    height: u32,
    effects: Effects,
}

type Tiles<'p> = std::iter::Enumerate<std::slice::ChunksMut<'p, [f32; 3]>>;

impl Job<'_> {
    /// Takes bands from `queue` until it is empty.
    fn take_tiles(&self, queue: &Mutex<Tiles<'_>>) -> RayCounts {
        let mut counts = RayCounts::default();
        loop {
            let next = queue.lock().unwrap_or_else(|p| p.into_inner()).next();
            let Some((band, pixels)) = next else {
                return counts;
            };
            let y0 = band * TILE_ROWS;
            let e = self.effects;
            let f = match (e.highlights, e.secondary, e.smooth) {
                (false, false, false) => Self::tile::<false, false, false>,
                (false, false, true) => Self::tile::<false, false, true>,
                (false, true, false) => Self::tile::<false, true, false>,
                (false, true, true) => Self::tile::<false, true, true>,
                (true, false, false) => Self::tile::<true, false, false>,
                (true, false, true) => Self::tile::<true, false, true>,
                (true, true, false) => Self::tile::<true, true, false>,
                (true, true, true) => Self::tile::<true, true, true>,
            };
            f(self, y0, pixels, &mut counts);
        }
    }

    /// The pixels of the band starting at row `y0`, with the effects fixed at compile time.
    fn tile<const HIGHLIGHTS: bool, const SECONDARY: bool, const SMOOTH: bool>(
        &self,
        y0: usize,
        pixels: &mut [[f32; 3]],
        counts: &mut RayCounts,
    ) {
        // Camera rays eight pixels at a time as a packet where the CPU has AVX2
        // (`rays/bvh4/packet8.rs`), else four (`rays/bvh4/packet.rs`): the same hits as ray by
        // ray, up to the rounding case `rays/bvh4.rs` names, which depends on the order of
        // visits. The pixels go in the band's order, a packet running on into the next row:
        // blocks of 4 × 2 pixels (as `batch.rs` orders camera rays) changed one pixel of
        // `gpu_trace.rs`'s diffuse room against the binary traversal's image, so not here.
        if self.scene.rays.packets_of_eight() {
            let packet =
                |rays: &[Ray; 8]| self.scene.rays.closest_hit8(rays, 0.0, [f32::INFINITY; 8]);
            self.camera_packets::<8, HIGHLIGHTS, SECONDARY, SMOOTH>(y0, pixels, counts, packet);
        } else {
            let packet =
                |rays: &[Ray; 4]| self.scene.rays.closest_hit4(rays, 0.0, [f32::INFINITY; 4]);
            self.camera_packets::<4, HIGHLIGHTS, SECONDARY, SMOOTH>(y0, pixels, counts, packet);
        }
    }

    /// [`Self::tile`] with the camera rays `N` pixels at a time through `packet`, then each
    /// pixel's ray tree.
    fn camera_packets<
        const N: usize,
        const HIGHLIGHTS: bool,
        const SECONDARY: bool,
        const SMOOTH: bool,
    >(
        &self,
        y0: usize,
        pixels: &mut [[f32; 3]],
        counts: &mut RayCounts,
        packet: impl Fn(&[Ray; N]) -> [Option<Hit>; N],
    ) {
        let w = self.width as usize;
        let eye = self.view.eye();
        let dir = |i: usize| {
            let (x, y) = ((i % w) as u32, (y0 + i / w) as u32);
            self.view.direction(x, y, self.width, self.height)
        };
        for (c, chunk) in pixels.chunks_mut(N).enumerate() {
            let dirs: [V3; N] = std::array::from_fn(|j| dir(N * c + j.min(chunk.len() - 1)));
            let hits = if chunk.len() == N {
                packet(&dirs.map(|d| Ray::new(eye, d)))
            } else {
                dirs.map(|d| {
                    self.scene
                        .rays
                        .closest_hit(&Ray::new(eye, d), 0.0, f32::INFINITY)
                })
            };
            for (j, px) in chunk.iter_mut().enumerate() {
                *px = radiance::<HIGHLIGHTS, SECONDARY, SMOOTH>(
                    self.scene,
                    &self.frame,
                    (eye, dirs[j]),
                    hits[j],
                    self.effects.max_depth,
                    counts,
                );
            }
        }
    }
}

// What the GPU twin (runtime/src/gpu/trace.rs) reads of a checked tracer: its scene, and a frame's light intensities and decision when the radiosity stays on the GPU.
#[cfg(feature = "gpu")]
impl Tracer {
    pub(crate) fn scene(&self) -> &TraceScene {
        &self.scene
    }

    /// The point lights' intensities this frame and the effects it needs through `view`, from
    /// the group intensities alone.
    pub(crate) fn frame_lights(
        &self,
        view: &View,
        group_intensities: &[f32],
    ) -> Result<(Vec<V3>, Decision), RuntimeError> {
        let intensities = self.group_light_intensities(group_intensities)?;
        let decision = self.decision(view, &intensities);
        Ok((intensities, decision))
    }
}
