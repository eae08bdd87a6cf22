//! [`GpuDirect`]: the direct pass of lights that are not surfaces on the GPU
//! (`direct_pass.wgsl` of `lrr-shaders`), feeding the [`GpuEvaluator`]'s frame without a
//! readback: the twin of the CPU's [`DirectLighting::irradiance`] followed by
//! [`reflected`](crate::lights::reflected) and [`Evaluator::evaluate`](crate::Evaluator::evaluate).
//!
//! [`GpuDirect::new`] takes a CPU [`DirectLighting`] of the file (so both shade the same fixed
//! sample points, chosen when that pass was made, and every index the shader follows was checked
//! by its scene) and uploads once its sample points (per element, original ids), the file's
//! BVH (nodes and leaf-order triangles, as [`GpuTracer`](super::GpuTracer) uploads them) and the
//! reflectance per element. A frame ([`submit`](GpuDirect::submit),
//! [`submit_groups`](GpuDirect::submit_groups), or [`evaluate`](GpuDirect::evaluate) and
//! [`evaluate_groups`](GpuDirect::evaluate_groups) with `B` read back):
//!
//! 1. checks the lights as the CPU pass does (the same messages) and uploads the shining ones as
//!    `DirectLight` records (`Light::gpu_record`, dark lights left out: they add nothing);
//! 2. writes the base emission into the evaluator's next upload slot (the caller's emission, or
//!    for light-group intensities the groups' emission computed on the GPU and copied there);
//! 3. runs `direct_pass` over the elements, in dispatches of at most
//!    [`chunk_rays`](GpuDirect::chunk_rays) shadow rays (none long enough for a driver's
//!    watchdog): per element, each light's irradiance per unit strength averaged over the
//!    element's samples, each behind an any-hit shadow ray through the BVH, `H` summed over the
//!    lights, and `E = base + ρ ⊙ H` written over the slot's emission (`H` itself into
//!    [`irradiance_buffer`](GpuDirect::irradiance_buffer));
//! 4. submits the evaluator's frame from that slot (segment sums over the whole emission, core
//!    product, gather), leaving `B` in [`GpuEvaluator::radiosity_buffer`].
//!
//! A sky ([`set_sky`](GpuDirect::set_sky)) adds its light after step 3: `sky.wgsl` writes
//! `ρ ⊙ max(0, Σ L_lm T_lm)` over the slot, per element, from the element's order-2 transfer
//! `T` (uploaded once: the bake's section SKY_TRANSFER, or the CPU pass's projection) and the
//! frame's coefficients `L` ([`Sky::coefficients`]); no ray, and not part of `H`
//! ([`irradiance_buffer`](GpuDirect::irradiance_buffer)), as on the CPU.
//!
//! A frame without shining lights and without a sky (or a scene without triangles, whose
//! samples see nothing, and no sky) runs no pass: it is the evaluator's own
//! [`submit`](GpuEvaluator::submit) or [`submit_groups`](GpuEvaluator::submit_groups).
//!
//! Like the CPU pass, a light is traced only when it is new or something but its strength
//! changed since the frame that traced it in the same slot (its index in the frame's lights):
//! the pass stores each light's mean term per element on the GPU (n f32 per slot, as many slots
//! as fit one storage binding; a light past them is traced every frame) and a still light's
//! `H` comes from it with no ray, in the same f32 operations ([`GpuDirectReport::traced`]).
//! `H` may be infinite where a light sits on a sample point; the CPU
//! evaluator refuses such an emission, the GPU cannot see it without a readback, and its `B` is
//! then not finite.
//!
//! ```no_run
//! use lrr_runtime::gpu::{Gpu, GpuDirect, GpuEvaluator, GpuOptions};
//! use lrr_runtime::lights::{DEFAULT_SAMPLES, DirectLighting, Light};
//! use lrr_runtime::{Operator, Rgb};
//!
//! let op = Operator::load("cornell.lrr".as_ref())?;
//! let gpu = Gpu::new(&GpuOptions::default())?;
//! let mut eval = GpuEvaluator::new(&gpu, &op)?;
//! let cpu_pass = DirectLighting::new(op.file(), DEFAULT_SAMPLES, 0)?;
//! let mut direct = GpuDirect::new(&gpu, &cpu_pass, &op.reflectance())?;
//! let lights = [Light::Point { position: [0.0, 1.5, 0.0], intensity: [5.0; 3] }];
//! let base = vec![[0.0f32; 3]; op.n()];
//! direct.submit(&mut eval, &lights, Rgb::triples(&base))?; // B stays on the GPU
//! let radiosity = eval.radiosity_buffer();
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::collections::HashMap;
use std::time::Instant;

use lrr_shaders::{
    DIRECT_ENTRY, DIRECT_LANES, DIRECT_LIGHT_BYTES, DIRECT_LIGHT_CACHE_WORD, DIRECT_PASS,
    DIRECT_SAMPLE_BYTES, DirectConstants, DirectParams, SKY_ENTRY, SKY_LANES, SKY_PASS, SkyParams,
    direct_cache_word, direct_sample, workgroups,
};

use super::buffers::{storage, zeros};
use super::common::{GpuError, bytes_of, bytes_of_mut};
use super::device::Gpu;
use super::evaluator::{GpuEvaluator, map};
use crate::error::input;
use crate::lights::{DirectLighting, Light, Sky};
use crate::rgb::{Rgb, RgbMut};

/// Default bound on the shadow rays of one dispatch: 2²⁴ (a few milliseconds of any-hit rays
/// on a datacenter GPU); a frame with more is cut into dispatches of whole workgroups of
/// elements.
pub const DEFAULT_CHUNK_RAYS: u64 = 1 << 24;

/// What one frame of [`GpuDirect`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct GpuDirectReport {
    /// The frame's shining lights (0: no pass ran, the frame was the evaluator's own).
    pub lights: u32,
    /// Of those, the lights traced this frame (new, or moved since the frame that stored their
    /// term); the others' terms came from the cache, with no ray.
    pub traced: u32,
    /// Dispatches of the pass (0 when it did not run).
    pub dispatches: u32,
    /// Shadow rays cast (the CPU's [`DirectReport::rays`](crate::lights::DirectReport::rays) for
    /// the same frame: only the traced lights cast any), when counting is on
    /// ([`set_count_rays`](GpuDirect::set_count_rays)) and the frame was read back
    /// ([`evaluate`](GpuDirect::evaluate), [`evaluate_groups`](GpuDirect::evaluate_groups));
    /// `None` otherwise.
    pub rays: Option<u64>,
    /// Whether the sky pass ran (a sky is set: [`GpuDirect::set_sky`]).
    pub sky: bool,
}

/// Where a frame's base emission comes from.
#[derive(Clone, Copy)]
enum Base<'a> {
    Emission(Rgb<'a>),
    Groups(&'a [f32]),
}

/// The file's BVH on the GPU (absent for a scene without triangles).
struct Bvh {
    nodes: wgpu::Buffer,
    tris: wgpu::Buffer,
}

/// The sky pass (`sky.wgsl`): made with the first sky.
struct SkyPass {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    /// The frame's sky: 9 order-2 coefficients × 3 channels.
    coefficients: wgpu::Buffer,
    /// The transfer, 9 f32 per element, original ids.
    transfer: wgpu::Buffer,
    /// Whether the frames have a sky.
    on: bool,
}

/// The direct pass on the GPU. See the [module docs](self).
pub struct GpuDirect {
    gpu: Gpu,
    n: u32,
    samples_per_element: u32,
    epsilon: f32,
    layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    module: wgpu::ShaderModule,
    pipelines: HashMap<DirectConstants, wgpu::ComputePipeline>,
    params: wgpu::Buffer,
    bvh: Option<Bvh>,
    samples: wgpu::Buffer,
    /// The frame's shining lights (`DirectLight` records), and how many it holds (made again,
    /// larger, when a frame has more; one zero record until then).
    direct_lights: wgpu::Buffer,
    direct_capacity: usize,
    reflectance: wgpu::Buffer,
    /// `H` of the last frame, 3 f32 per element, original ids.
    irradiance: wgpu::Buffer,
    /// Whether `irradiance` may hold a nonzero value (cleared when a frame has no pass).
    irradiance_written: bool,
    /// Shadow rays per element of the last counted frame (the first n words), then n f32 per
    /// cache slot: each stored light's mean term per element (binding `terms`).
    terms: wgpu::Buffer,
    /// Slots `terms` holds.
    slots: u32,
    /// Per slot (the light's index in a frame's lights): the shape whose term the slot holds,
    /// `None` where none is stored.
    cache: Vec<Option<Light>>,
    count_rays: bool,
    chunk_rays: u64,
    /// At most this many cache slots (tests; `u32::MAX`: as many as fit one binding).
    slot_cap: u32,
    sky: Option<SkyPass>,
}

impl std::fmt::Debug for GpuDirect {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "GpuDirect({} elements, {} samples each, {})",
            self.n,
            self.samples_per_element,
            self.gpu.adapter_name()
        )
    }
}

impl GpuDirect {
    /// Uploads the sample points and the BVH of `pass` (the CPU pass of the file the evaluators
    /// this pass feeds were made from) and `reflectance` (one RGB value per element, original
    /// ids, finite and non-negative: the operator's [`reflectance`](crate::Operator::reflectance)
    /// for the frame the CPU's [`reflected`](crate::lights::reflected) computes) to `gpu`. Errors
    /// name a bad reflectance, or a buffer over the adapter's binding limit.
    pub fn new(
        gpu: &Gpu,
        pass: &DirectLighting,
        reflectance: &[[f32; 3]],
    ) -> Result<Self, GpuError> {
        let scene = pass.scene();
        let n = scene.n();
        check_reflectance(reflectance, n)?;
        let none = wgpu::BufferUsages::empty();
        let samples: Vec<u32> = pass
            .sample_points()
            .flat_map(|(p, normal)| direct_sample(p, normal))
            .collect();
        let nodes: Vec<u32> = scene
            .nodes
            .iter()
            .flat_map(|node| {
                let [a, b, c] = node.min.map(f32::to_bits);
                let [d, e, f] = node.max.map(f32::to_bits);
                [a, b, c, node.count, d, e, f, node.first]
            })
            .collect();
        let tris: Vec<f32> = scene.tris.iter().flatten().copied().collect();
        let storage_bindings = lrr_shaders::DIRECT_BINDINGS.len() - 1;
        let limit = gpu.limits.max_storage_buffers_per_shader_stage;
        if (limit as usize) < storage_bindings {
            return Err(GpuError::Device(format!(
                "GPU: the direct pass binds {storage_bindings} storage buffers, {} allows {limit} \
                 per shader stage; run the direct pass on the CPU (DirectLighting)",
                gpu.adapter_name()
            )));
        }
        check_fits(
            gpu,
            &[
                ("BVH nodes", 4 * nodes.len() as u64),
                ("triangles", 4 * tris.len() as u64),
                (
                    "sample points",
                    (samples.len() / (DIRECT_SAMPLE_BYTES / 4) * DIRECT_SAMPLE_BYTES) as u64,
                ),
                ("emission", 12 * n as u64),
            ],
        )?;
        let bvh = (!scene.nodes.is_empty()).then(|| Bvh {
            nodes: storage(gpu, "direct bvh nodes", &nodes, none),
            tris: storage(gpu, "direct triangles", &tris, none),
        });
        let layout = bind_group_layout(gpu);
        let pipeline_layout = gpu
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(DIRECT_ENTRY),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
        let flat: Vec<f32> = reflectance.iter().flatten().copied().collect();
        Ok(GpuDirect {
            module: shader_module(gpu),
            pipelines: HashMap::new(),
            params: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("direct params"),
                size: DirectParams::SIZE as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            bvh,
            samples: storage(gpu, "direct samples", &samples, none),
            direct_lights: storage(
                gpu,
                "direct lights",
                &[0u32; DIRECT_LIGHT_BYTES / 4],
                wgpu::BufferUsages::COPY_DST,
            ),
            direct_capacity: 1,
            reflectance: storage(
                gpu,
                "direct reflectance",
                &flat,
                wgpu::BufferUsages::COPY_DST,
            ),
            irradiance: zeros(
                gpu,
                "direct irradiance",
                3 * n,
                wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            ),
            irradiance_written: false,
            terms: zeros(
                gpu,
                "direct terms",
                n,
                wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            ),
            slots: 0,
            cache: Vec::new(),
            count_rays: false,
            chunk_rays: DEFAULT_CHUNK_RAYS,
            slot_cap: u32::MAX,
            sky: None,
            n: n as u32,
            samples_per_element: pass.samples_per_element(),
            epsilon: scene.epsilon,
            layout,
            pipeline_layout,
            gpu: gpu.clone(),
        })
    }

    /// Number of elements.
    pub fn n(&self) -> usize {
        self.n as usize
    }

    /// Sample points per element (the CPU pass's).
    pub fn samples_per_element(&self) -> u32 {
        self.samples_per_element
    }

    /// Changes the reflectance the pass reflects `H` with (one RGB value per element, original
    /// ids, finite and non-negative), e.g. after an albedo edit of the evaluator
    /// ([`GpuEvaluator::set_reflectance`], which does not reach this pass).
    pub fn set_reflectance(&mut self, reflectance: &[[f32; 3]]) -> Result<(), GpuError> {
        check_reflectance(reflectance, self.n as usize)?;
        let flat: Vec<f32> = reflectance.iter().flatten().copied().collect();
        if !flat.is_empty() {
            self.gpu
                .queue
                .write_buffer(&self.reflectance, 0, bytes_of(&flat));
        }
        Ok(())
    }

    /// Counts the shadow rays per element (atomics-free: one count per element), reported by
    /// the frames read back. Off by default (timed frames).
    pub fn set_count_rays(&mut self, on: bool) {
        self.count_rays = on;
    }

    /// The most shadow rays one dispatch may cast (an upper bound from the samples and the
    /// shining lights, whole workgroups of elements at least).
    pub fn chunk_rays(&self) -> u64 {
        self.chunk_rays
    }

    /// Sets [`chunk_rays`](Self::chunk_rays), at least 1 (tests use small chunks to cross
    /// dispatch boundaries; a slow adapter under a short watchdog may need them).
    pub fn set_chunk_rays(&mut self, rays: u64) -> Result<(), GpuError> {
        if rays == 0 {
            return Err(input("direct pass: chunks of 0 shadow rays; give at least 1").into());
        }
        self.chunk_rays = rays;
        Ok(())
    }

    /// Lights the frames that follow with `sky` too (`None`: no sky), the twin of the CPU's
    /// [`sky_irradiance`](DirectLighting::sky_irradiance) + [`reflected`](crate::lights::reflected):
    /// per element `ρ ⊙ max(0, Σ L_lm T_lm)` is added to the frame's emission, no ray. The
    /// first sky uploads the transfer `T` of `pass`, the CPU pass of the same file
    /// ([`DirectLighting::sky_transfer`]: the bake's section SKY_TRANSFER, else projected now
    /// on the CPU); returns the shadow rays that projection cast (0 after). The sky's light is
    /// not part of [`irradiance_buffer`](Self::irradiance_buffer): like the CPU's, it has no
    /// per-point value and stays in the bounced part a renderer shows. Errors name a bad sky,
    /// a pass of another file, or a transfer over the binding limit.
    pub fn set_sky(
        &mut self,
        pass: &mut DirectLighting,
        sky: Option<&Sky>,
    ) -> Result<u64, GpuError> {
        let Some(sky) = sky else {
            if let Some(s) = &mut self.sky {
                s.on = false;
            }
            return Ok(0);
        };
        sky.check()
            .map_err(|p| GpuError::from(input(format!("the sky: {p}"))))?;
        if pass.n() != self.n as usize {
            return Err(input(format!(
                "sky: the CPU pass has {} elements, this pass {}; use the passes of one file",
                pass.n(),
                self.n
            ))
            .into());
        }
        let mut rays = 0;
        if self.sky.is_none() {
            let (transfer, cast) = pass.sky_transfer();
            rays = cast;
            let flat: Vec<f32> = transfer.iter().flatten().copied().collect();
            check_fits(&self.gpu, &[("sky transfer", 4 * flat.len() as u64)])?;
            let device = &self.gpu.device;
            let layout =
                super::common::bind_group_layout(device, SKY_ENTRY, lrr_shaders::SKY_BINDINGS);
            let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(SKY_ENTRY),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
            #[allow(unsafe_code)]
            // SAFETY: sky.wgsl reads transfer[9 e + l] (l < 9), reflectance and emission
            // [3 e + c] (c < 3) and coefficients[3 l + c] for e < first_element +
            // element_count = n (the one dispatch of `frame`): the transfer holds 9 n f32
            // (checked above: `pass` has n elements), reflectance and the evaluator's emission
            // slot 3 n, the coefficients 27. Its one loop ends at 9.
            let module = unsafe {
                super::common::shader_module(
                    device,
                    SKY_ENTRY,
                    SKY_PASS,
                    self.gpu.options.bounds_checks,
                )
            };
            let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(SKY_ENTRY),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(SKY_ENTRY),
                compilation_options: Default::default(),
                cache: None,
            });
            let none = wgpu::BufferUsages::empty();
            self.sky = Some(SkyPass {
                pipeline,
                layout,
                params: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("sky params"),
                    size: SkyParams::SIZE as u64,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
                coefficients: storage(
                    &self.gpu,
                    "sky coefficients",
                    &[0.0f32; 27],
                    wgpu::BufferUsages::COPY_DST,
                ),
                transfer: storage(&self.gpu, "sky transfer", &flat, none),
                on: false,
            });
        }
        let s = self.sky.as_mut().expect("made above");
        let c: Vec<f32> = sky.coefficients().iter().flatten().copied().collect();
        self.gpu
            .queue
            .write_buffer(&s.coefficients, 0, bytes_of(&c));
        s.on = true;
        Ok(rays)
    }

    /// `H`, the lights' direct irradiance per element of the last frame (3 f32 per element,
    /// original ids; zero after a frame without lights), usage `STORAGE | COPY_SRC`: for a
    /// renderer that shades the direct light per point and needs the bounced part alone
    /// (`B − ρ ⊙ H`).
    pub fn irradiance_buffer(&self) -> &wgpu::Buffer {
        &self.irradiance
    }

    /// Waits for the submitted work and reads [`irradiance_buffer`](Self::irradiance_buffer)
    /// back (tests and tools; a frame never needs it).
    pub fn read_irradiance(&self) -> Result<Vec<[f32; 3]>, GpuError> {
        let words = read_buffer(&self.gpu, &self.irradiance, 12 * u64::from(self.n))?;
        Ok(words.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
    }

    /// A frame lit by `base` (the baked or any emission, per element, original ids, checked as
    /// [`GpuEvaluator::submit`] checks it) plus `lights`' reflected direct light, its `B` left in
    /// [`GpuEvaluator::radiosity_buffer`]; returns once the work is submitted. `eval` must be an
    /// evaluator of the same file on the same [`Gpu`]. Errors name a light whose values are bad
    /// (the CPU pass's messages), a bad emission, or a mismatched evaluator; nothing is
    /// submitted then.
    pub fn submit(
        &mut self,
        eval: &mut GpuEvaluator,
        lights: &[Light],
        base: Rgb<'_>,
    ) -> Result<GpuDirectReport, GpuError> {
        self.frame(eval, lights, Base::Emission(base), None)
    }

    /// [`submit`](Self::submit) with the base emission of light-group intensities (one per
    /// light group, checked as [`GpuEvaluator::submit_groups`] checks them): the groups'
    /// emission is computed on the GPU and the lights' reflected direct light added to it.
    pub fn submit_groups(
        &mut self,
        eval: &mut GpuEvaluator,
        lights: &[Light],
        intensities: &[f32],
    ) -> Result<GpuDirectReport, GpuError> {
        self.frame(eval, lights, Base::Groups(intensities), None)
    }

    /// [`submit`](Self::submit) with `B` read back into `out` (interleaved or planar, as
    /// [`GpuEvaluator::evaluate`]); the report counts the shadow rays when counting is on.
    pub fn evaluate(
        &mut self,
        eval: &mut GpuEvaluator,
        lights: &[Light],
        base: Rgb<'_>,
        out: RgbMut<'_>,
    ) -> Result<GpuDirectReport, GpuError> {
        self.frame(eval, lights, Base::Emission(base), Some(out))
    }

    /// [`submit_groups`](Self::submit_groups) with `B` read back into `out`.
    pub fn evaluate_groups(
        &mut self,
        eval: &mut GpuEvaluator,
        lights: &[Light],
        intensities: &[f32],
        out: RgbMut<'_>,
    ) -> Result<GpuDirectReport, GpuError> {
        self.frame(eval, lights, Base::Groups(intensities), Some(out))
    }

    fn frame(
        &mut self,
        eval: &mut GpuEvaluator,
        lights: &[Light],
        base: Base<'_>,
        out: Option<RgbMut<'_>>,
    ) -> Result<GpuDirectReport, GpuError> {
        let start = Instant::now();
        if eval.gpu().device != self.gpu.device {
            return Err(input(
                "direct pass: the evaluator is on another GPU device; make both from one Gpu",
            )
            .into());
        }
        if eval.n() != self.n {
            return Err(input(format!(
                "direct pass: made for {} elements, the evaluator's operator has {}; use the \
                 pass and the evaluator of one file",
                self.n,
                eval.n()
            ))
            .into());
        }
        for (i, light) in lights.iter().enumerate() {
            light
                .check()
                .map_err(|p| input(format!("light {i} ({light:?}): {p}")))?;
        }
        // The cache as the CPU's: slots past this frame's lights are forgotten.
        self.cache.truncate(lights.len());
        let slots = (lights.len() as u64).min(self.max_slots()) as u32;
        // Each shining light's record with its cache word; the slots this frame stores.
        let mut records: Vec<u32> = Vec::with_capacity(lights.len() * DIRECT_LIGHT_BYTES / 4);
        let mut stored: Vec<(usize, Light)> = Vec::new();
        let mut traced = 0u32;
        for (i, light) in lights.iter().enumerate() {
            if light.strength() == [0.0; 3] {
                continue;
            }
            let shape = light.shape();
            let slot = (i < slots as usize).then_some(i as u32);
            let trace = slot.is_none() || self.cache.get(i) != Some(&Some(shape));
            if trace {
                traced += 1;
                if slot.is_some() {
                    stored.push((i, shape));
                }
            }
            let mut record = light.gpu_record();
            record[DIRECT_LIGHT_CACHE_WORD] = direct_cache_word(slot, trace);
            records.extend(record);
        }
        let count = records.len() / (DIRECT_LIGHT_BYTES / 4);
        let bvh = (self.bvh.as_ref())
            .filter(|_| count > 0)
            .map(|b| (b.nodes.clone(), b.tris.clone()));
        let sky_on = self.sky.as_ref().is_some_and(|s| s.on);
        if bvh.is_none() && !sky_on {
            // Nothing shines on anything: the evaluator's own frame, no pass.
            match (base, out) {
                (Base::Emission(e), None) => eval.submit(e)?,
                (Base::Groups(g), None) => eval.submit_groups(g)?,
                (Base::Emission(e), Some(out)) => eval.evaluate(e, out)?,
                (Base::Groups(g), Some(out)) => eval.evaluate_groups(g, out)?,
            }
            self.clear_irradiance();
            return Ok(GpuDirectReport::default());
        }
        if bvh.is_some() {
            check_fits(
                &self.gpu,
                &[("direct lights", (count * DIRECT_LIGHT_BYTES) as u64)],
            )?;
        }
        if let Some(out) = &out {
            out.check(self.n as usize, "output")?;
        }
        // Everything is checked: stage the base emission (the evaluator checks it first).
        let device = self.gpu.device.clone();
        let mut encoder = device.create_command_encoder(&Default::default());
        let slot = match base {
            Base::Emission(e) => eval.stage_emission(&e)?,
            Base::Groups(g) => eval.stage_groups(g, &mut encoder)?,
        };
        let mut report = GpuDirectReport {
            sky: sky_on,
            ..GpuDirectReport::default()
        };
        let counted = self.count_rays && out.is_some() && bvh.is_some();
        if let Some((nodes, tris)) = bvh {
            report.lights = count as u32;
            report.traced = traced;
            self.reserve_slots(slots, &mut encoder);
            report.dispatches = self.lights_pass(
                (&nodes, &tris),
                (&records, traced),
                eval.slot_emission(slot),
                &mut encoder,
            );
            self.irradiance_written = true;
            // The terms are written by the work submitted: the cache holds them from now on.
            for (i, shape) in stored {
                if self.cache.len() <= i {
                    self.cache.resize(i + 1, None);
                }
                self.cache[i] = Some(shape);
            }
        } else {
            self.clear_irradiance();
        }
        if sky_on {
            self.sky_pass(eval.slot_emission(slot), &mut encoder);
        }
        self.gpu.queue.submit([encoder.finish()]);
        eval.run_slot(slot, out.is_some());
        if let Some(mut out) = out {
            eval.finish(&mut out, start)?;
            if counted {
                let words = read_buffer(&self.gpu, &self.terms, 4 * u64::from(self.n))?;
                report.rays = Some(words.iter().map(|w| u64::from(w.to_bits())).sum());
            }
        }
        Ok(report)
    }

    /// Records `sky.wgsl` over every element in `encoder`: `ρ ⊙ max(0, Σ L_lm T_lm)` added to
    /// `emission` (the evaluator's slot), after what `encoder` holds.
    fn sky_pass(&self, emission: &wgpu::Buffer, encoder: &mut wgpu::CommandEncoder) {
        let sky = self.sky.as_ref().expect("a sky is set");
        let params = SkyParams {
            first_element: 0,
            element_count: self.n,
            ..SkyParams::default()
        };
        self.gpu
            .queue
            .write_buffer(&sky.params, 0, &params.to_bytes());
        let buffers: [&wgpu::Buffer; 5] = [
            &sky.params,
            &sky.coefficients,
            &sky.transfer,
            &self.reflectance,
            emission,
        ];
        let entries = super::common::buffer_entries(&buffers);
        let bind_group = self
            .gpu
            .device
            .create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(SKY_ENTRY),
                layout: &sky.layout,
                entries: &entries,
            });
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(SKY_ENTRY),
            timestamp_writes: None,
        });
        pass.set_pipeline(&sky.pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        let [x, y, z] = workgroups(self.n.div_ceil(SKY_LANES));
        pass.dispatch_workgroups(x, y, z);
    }

    /// The most cache slots `terms` may hold: (1 + slots) n words in one storage binding.
    fn max_slots(&self) -> u64 {
        let words = self.gpu.max_binding_bytes() / 4;
        (words / u64::from(self.n.max(1)))
            .saturating_sub(1)
            .min(u64::from(lrr_shaders::DIRECT_NO_SLOT))
            .min(u64::from(self.slot_cap))
    }

    /// Keeps at most `slots` lights' terms (the first `slots` of a frame's lights; the others
    /// are traced every frame): what a binding too small for every light's terms leaves, for
    /// tests. Forgets what was stored.
    #[doc(hidden)]
    pub fn set_cache_slots(&mut self, slots: u32) {
        self.slot_cap = slots;
        self.cache.clear();
    }

    /// Makes `terms` hold at least `slots` slots, copying what the old buffer held (in
    /// `encoder`, before the pass that reads it).
    fn reserve_slots(&mut self, slots: u32, encoder: &mut wgpu::CommandEncoder) {
        if slots <= self.slots {
            return;
        }
        let words = (1 + slots as usize) * self.n as usize;
        let terms = zeros(
            &self.gpu,
            "direct terms",
            words,
            wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        );
        encoder.copy_buffer_to_buffer(&self.terms, 0, &terms, 0, self.terms.size());
        self.terms = terms;
        self.slots = slots;
    }

    /// Zeroes [`irradiance_buffer`](Self::irradiance_buffer) after a frame whose lights did not
    /// run (their `H` is zero), once.
    fn clear_irradiance(&mut self) {
        if self.irradiance_written {
            let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
            encoder.clear_buffer(&self.irradiance, 0, None);
            self.gpu.queue.submit([encoder.finish()]);
            self.irradiance_written = false;
        }
    }

    /// Uploads the shining lights' `records` (with their cache words; `traced` of them to trace)
    /// and runs `direct_pass` over the elements in dispatches of at most
    /// [`chunk_rays`](Self::chunk_rays) shadow rays, the first in `encoder` after what it holds,
    /// each submitted on its own (the next dispatch's uniform is written after it); leaves a
    /// fresh `encoder`. Returns the dispatches.
    fn lights_pass(
        &mut self,
        (nodes, tris): (&wgpu::Buffer, &wgpu::Buffer),
        (records, traced): (&[u32], u32),
        emission: &wgpu::Buffer,
        encoder: &mut wgpu::CommandEncoder,
    ) -> u32 {
        let device = self.gpu.device.clone();
        let count = records.len() / (DIRECT_LIGHT_BYTES / 4);
        if count > self.direct_capacity {
            self.direct_lights = storage(
                &self.gpu,
                "direct lights",
                records,
                wgpu::BufferUsages::COPY_DST,
            );
            self.direct_capacity = count;
        } else {
            self.gpu
                .queue
                .write_buffer(&self.direct_lights, 0, bytes_of(records));
        }
        let constants = DirectConstants {
            count_rays: self.count_rays,
        };
        let pipeline = self.pipeline(constants);
        let bind_group = self.bind_group((nodes, tris), emission);
        // Whole workgroups of elements per dispatch, at most chunk_rays shadow rays each (an
        // upper bound: every sample facing every traced light).
        let per_element = u64::from(self.samples_per_element) * u64::from(traced.max(1));
        let lanes = u64::from(DIRECT_LANES);
        let chunk = ((self.chunk_rays / per_element) / lanes * lanes)
            .clamp(lanes, u64::from(self.n).max(lanes)) as u32;
        let mut params = DirectParams {
            samples_per_element: self.samples_per_element,
            light_count: count as u32,
            epsilon: self.epsilon,
            n: self.n,
            ..DirectParams::default()
        };
        let mut dispatches = 0u32;
        let mut first = 0u32;
        while first < self.n {
            let elements = chunk.min(self.n - first);
            params.first_element = first;
            params.element_count = elements;
            self.gpu
                .queue
                .write_buffer(&self.params, 0, &params.to_bytes());
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(DIRECT_ENTRY),
                    timestamp_writes: None,
                });
                pass.set_pipeline(&pipeline);
                pass.set_bind_group(0, &bind_group, &[]);
                let [x, y, z] = workgroups(elements.div_ceil(DIRECT_LANES));
                pass.dispatch_workgroups(x, y, z);
            }
            // One submission per dispatch: the next dispatch's uniform is written after it.
            let done =
                std::mem::replace(encoder, device.create_command_encoder(&Default::default()));
            self.gpu.queue.submit([done.finish()]);
            dispatches += 1;
            first += elements;
        }
        dispatches
    }

    fn pipeline(&mut self, constants: DirectConstants) -> wgpu::ComputePipeline {
        let (gpu, module, layout) = (&self.gpu, &self.module, &self.pipeline_layout);
        self.pipelines
            .entry(constants)
            .or_insert_with(|| {
                let values = constants.constants();
                gpu.device
                    .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                        label: Some(DIRECT_ENTRY),
                        layout: Some(layout),
                        module,
                        entry_point: Some(DIRECT_ENTRY),
                        compilation_options: wgpu::PipelineCompilationOptions {
                            constants: &values,
                            zero_initialize_workgroup_memory: false,
                        },
                        cache: None,
                    })
            })
            .clone()
    }

    fn bind_group(
        &self,
        (nodes, tris): (&wgpu::Buffer, &wgpu::Buffer),
        emission: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        let buffers: [&wgpu::Buffer; 9] = [
            &self.params,
            nodes,
            tris,
            &self.samples,
            &self.direct_lights,
            &self.reflectance,
            emission,
            &self.irradiance,
            &self.terms,
        ];
        let entries = super::common::buffer_entries(&buffers);
        self.gpu
            .device
            .create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(DIRECT_ENTRY),
                layout: &self.layout,
                entries: &entries,
            })
    }
}

/// One RGB value per element, each finite and non-negative.
fn check_reflectance(reflectance: &[[f32; 3]], n: usize) -> Result<(), GpuError> {
    if reflectance.len() != n {
        return Err(input(format!(
            "direct pass: {} reflectances for {n} elements",
            reflectance.len()
        ))
        .into());
    }
    if let Some(i) = reflectance
        .iter()
        .position(|r| !r.iter().all(|c| c.is_finite() && *c >= 0.0))
    {
        return Err(input(format!(
            "direct pass: the reflectance of element {i} is {:?}; it must be finite and >= 0 \
             per channel",
            reflectance[i]
        ))
        .into());
    }
    Ok(())
}

/// The nine bindings of `direct_pass.wgsl` (`lrr_shaders::DIRECT_BINDINGS`), explicit so that
/// both specialisations share one layout.
fn bind_group_layout(gpu: &Gpu) -> wgpu::BindGroupLayout {
    super::common::bind_group_layout(&gpu.device, DIRECT_ENTRY, lrr_shaders::DIRECT_BINDINGS)
}

fn shader_module(gpu: &Gpu) -> wgpu::ShaderModule {
    #[allow(unsafe_code)]
    // SAFETY: every index direct_pass.wgsl follows was checked by `RayScene::new` (through
    // `DirectLighting::new`: the BVH's children and leaf ranges, its depth against the fixed
    // stacks) and by `GpuDirect` (the pass runs only over a scene with triangles; a dispatch's
    // elements first_element + element_count <= n; n samples_per_element sample records, 3 f32
    // of reflectance, emission (the evaluator's slot, 3 n f32) and irradiance per element;
    // terms of (1 + slots) n words, every record's slot below `slots` (`frame` gives slots only
    // to lights of index < slots, after `reserve_slots`) or DIRECT_NO_SLOT, which the shader
    // never indexes with; light_count records in the lights' buffer); the argument is in the
    // header of direct_pass.wgsl and bvh.wgsl. Its loops end: samples_per_element <= 64,
    // light_count records, and the traversal visits each node at most once.
    unsafe {
        super::common::shader_module(
            &gpu.device,
            DIRECT_ENTRY,
            DIRECT_PASS,
            gpu.options.bounds_checks,
        )
    }
}

/// Refuses buffers that do not fit one storage binding (wgpu would abort).
fn check_fits(gpu: &Gpu, buffers: &[(&str, u64)]) -> Result<(), GpuError> {
    let limit = gpu.max_binding_bytes();
    match buffers.iter().find(|(_, bytes)| *bytes > limit) {
        None => Ok(()),
        Some((name, bytes)) => Err(GpuError::Device(format!(
            "GPU: the direct pass's {name} buffer needs {bytes} bytes, over the {limit}-byte \
             limit of one storage binding on {}; run the direct pass on the CPU (DirectLighting)",
            gpu.adapter_name()
        ))),
    }
}

/// Waits for the submitted work and copies the first `bytes` of `buffer` (usage `COPY_SRC`) out
/// as f32 words.
fn read_buffer(gpu: &Gpu, buffer: &wgpu::Buffer, bytes: u64) -> Result<Vec<f32>, GpuError> {
    let bytes = bytes.next_multiple_of(4).max(4);
    let staging = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("direct readback"),
        size: bytes,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, bytes.min(buffer.size()));
    gpu.queue.submit([encoder.finish()]);
    map(gpu, &staging)?;
    let mut out = vec![0.0f32; (bytes / 4) as usize];
    {
        let view = staging
            .get_mapped_range(..)
            .map_err(|e| GpuError::Device(format!("GPU: reading the direct pass back: {e}")))?;
        bytes_of_mut(&mut out).copy_from_slice(&view);
    }
    staging.unmap();
    Ok(out)
}
