//! The frame arena: every buffer, image and descriptor set one frame of a path
//! needs, created once per resolution and sample count and reused by every frame and sample
//! of `rqr render`, `rqr compare` and `rqr render --frames`.
//!
//! A frame is *recorded* into the caller's command buffer, not submitted: drivers record
//! frames back to back into one submission (a burst), so no host work separates them and the
//! GPU clock stays up. The frame's camera goes in with the commands (`vkCmdUpdateBuffer`),
//! never through memory the previous frame may still read, and its outputs (counters,
//! tonemapped and linear colour, AOVs) are copied into a host-visible readback buffer by the
//! frame's own commands, so reading them costs no extra submission and no allocation.

use ash::vk;

use crate::render::denoise::{self, Denoiser};
use crate::render::frame::{
    CameraSetup, FilterKind, GpuFrame, RenderPath, RenderSettings, SceneTraits,
};
use crate::render::passes::draw_list::Draw;
use crate::render::passes::gbuffer::GbufferPass;
use crate::render::passes::hybrid::{HybridPass, HYBRID_FIRST_SAMPLE, HYBRID_WRITE_AOV};
use crate::render::passes::raytrace::{ray_counts, RaytracedPass, COUNTER_WORDS};
use crate::render::passes::tonemap::TonemapPass;
use crate::render::readback::{FrameRing, RingContents, RingSources};
use crate::render::settings::SettingsError;
use crate::render::{merge_scopes, sampling, Aov, RenderOutput, Renderer};
use crate::scene::Camera;
use crate::vk::{memory_barrier, Buffer, Context, GpuProfiler, MemoryLocation, VkResult};

/// Timestamp scopes one frame of either path records per sample (raster, shading), plus
/// tonemap and the frame itself.
const SCOPES_PER_SAMPLE: u32 = 2;
const AOV_BYTES: u64 = std::mem::size_of::<Aov>() as u64;

/// One sample of the hybrid path: its jittered frame uniform, raster pass and shading pass.
struct HybridSample {
    frame: Buffer,
    gbuffer: GbufferPass,
    shading: HybridPass,
    jitter: [f32; 2],
    weight: f32,
}

/// What a path's frame writes and where (beyond the passes' own resources).
#[allow(clippy::large_enum_variant)] // one per FrameTargets, never moved in a hot loop
enum PathPasses {
    RayTraced(Box<RaytracedPass>),
    Hybrid {
        samples: Vec<HybridSample>,
        accum: Buffer,
        aov: Buffer,
        counters: Buffer,
        draws: Vec<Draw>,
    },
}

/// The resources of one path at one resolution and sample count, reused by every frame.
pub struct FrameTargets {
    path: RenderPath,
    settings: RenderSettings,
    scene_scale: f32,
    /// Whether the renderer's scene has emissive triangles (the frame uniform's flags).
    emissive_geometry: bool,
    passes: PathPasses,
    tonemap: TonemapPass,
    /// One slot: what [`Self::render`] reads back.
    readback: FrameRing,
    /// Whether frames copy their AOVs out (the passes also write them for a denoiser).
    write_aov: bool,
    /// The denoiser of distributed frames (`--denoise`), recorded before tonemapping.
    denoiser: Option<Denoiser>,
    /// Timestamps of single frames ([`Self::render`]); bursts bring their own.
    profiler: Option<GpuProfiler>,
    /// Host milliseconds [`Self::render`] last spent reading its image back.
    last_readback_ms: f64,
}

impl FrameTargets {
    /// Allocates everything frames of `path` at `settings` need, after checking that it fits
    /// the device ([`RenderSettings::check_device`]). `draws` are the scene's raster draws
    /// (hybrid path; ignored by the ray-traced one). With `write_aov` frames also write the
    /// primary-hit AOVs (80 bytes per pixel).
    pub fn new(
        ctx: &Context,
        renderer: &Renderer,
        path: RenderPath,
        settings: &RenderSettings,
        draws: &[Draw],
        write_aov: bool,
    ) -> crate::Result<Self> {
        Self::with_denoiser(ctx, renderer, path, settings, draws, write_aov, None)
    }

    /// Allocates targets for a changed scene (`renderer` as updated in place, its raster
    /// `draws`) at the same path and settings, keeping the denoiser and its history.
    pub fn rebuild(
        &mut self,
        ctx: &Context,
        renderer: &Renderer,
        draws: &[Draw],
    ) -> crate::Result<()> {
        let denoiser = self.denoiser.take();
        if let Some(d) = &denoiser {
            d.bind_scene(&renderer.pass_context());
        }
        let settings = self.settings.clone();
        *self = Self::with_denoiser(
            ctx,
            renderer,
            self.path,
            &settings,
            draws,
            self.write_aov,
            denoiser,
        )?;
        Ok(())
    }

    fn with_denoiser(
        ctx: &Context,
        renderer: &Renderer,
        path: RenderPath,
        settings: &RenderSettings,
        draws: &[Draw],
        write_aov: bool,
        denoiser: Option<Denoiser>,
    ) -> crate::Result<Self> {
        settings.check_device(ctx.info(), path, write_aov, ctx.allocated_bytes())?;
        let pass = renderer.pass_context();
        let denoiser = match denoiser {
            Some(d) => Some(d),
            None if settings.denoise.enabled() => Some(Denoiser::new(
                ctx,
                &pass,
                settings,
                path == RenderPath::Hybrid,
                renderer.scene_scale(),
            )?),
            None => None,
        };
        // The denoiser reads the AOVs even when the caller does not.
        let shader_aov = write_aov || denoiser.is_some();
        let pixels = settings.pixels();
        let none = vk::BufferUsageFlags::empty();
        let frame_uniform = |name: &str| {
            Buffer::new(
                ctx,
                name,
                std::mem::size_of::<GpuFrame>() as u64,
                vk::BufferUsageFlags::UNIFORM_BUFFER,
                MemoryLocation::GpuOnly,
            )
        };
        let scale = renderer.scene_scale();
        let passes = match path {
            RenderPath::RayTraced => {
                let mut rt = RaytracedPass::new(
                    ctx,
                    &pass,
                    settings,
                    frame_uniform("rt frame")?,
                    shader_aov,
                )?;
                if let Some(d) = &denoiser {
                    rt.write_guide(&d.guide);
                }
                PathPasses::RayTraced(Box::new(rt))
            }
            RenderPath::Hybrid => {
                let positions = hybrid_sample_positions(settings)?;
                let accum = Buffer::new(
                    ctx,
                    "hybrid accumulation",
                    pixels * 16,
                    none,
                    MemoryLocation::GpuOnly,
                )?;
                // Per-pixel AOVs only when asked for; else a placeholder (hybrid.comp writes
                // AOVs only under HYBRID_WRITE_AOV).
                let aov = Buffer::new(
                    ctx,
                    if shader_aov {
                        "hybrid aov"
                    } else {
                        "hybrid aov placeholder"
                    },
                    if shader_aov { pixels } else { 1 } * AOV_BYTES,
                    none,
                    MemoryLocation::GpuOnly,
                )?;
                let counters = Buffer::new(
                    ctx,
                    "hybrid counters",
                    COUNTER_WORDS as u64 * 4,
                    none,
                    MemoryLocation::GpuOnly,
                )?;
                let extent = vk::Extent2D {
                    width: settings.width,
                    height: settings.height,
                };
                let mut samples = Vec::with_capacity(positions.len());
                for u in positions {
                    let (jitter, weight) = sample_jitter(settings.filter, u);
                    let frame = frame_uniform("hybrid frame")?;
                    let gbuffer = GbufferPass::with_raster(
                        ctx,
                        &pass,
                        &frame,
                        extent,
                        settings.gbuffer,
                        settings.raster,
                        draws,
                    )?;
                    let shading = HybridPass::new(
                        ctx,
                        &pass,
                        settings.shading,
                        &frame,
                        &accum,
                        &aov,
                        &counters,
                        &gbuffer,
                    )?;
                    samples.push(HybridSample {
                        frame,
                        gbuffer,
                        shading,
                        jitter,
                        weight,
                    });
                }
                PathPasses::Hybrid {
                    samples,
                    accum,
                    aov,
                    counters,
                    draws: draws.to_vec(),
                }
            }
        };
        let color = match (&denoiser, &passes) {
            (Some(d), _) => &d.output,
            (None, PathPasses::RayTraced(rt)) => &rt.color,
            (None, PathPasses::Hybrid { accum, .. }) => accum,
        };
        let tonemap = TonemapPass::new(ctx, color, pixels as u32)?;
        let readback = FrameRing::new(
            ctx,
            "frame readback",
            1,
            pixels,
            RingContents {
                rgba8: true,
                color: true,
                aov: write_aov,
                states: false,
            },
        )?;
        let samples = match &passes {
            PathPasses::RayTraced(_) => 1,
            PathPasses::Hybrid { samples, .. } => samples.len() as u32,
        };
        let denoise_scopes = if denoiser.is_some() {
            denoise::SCOPES
        } else {
            0
        };
        let profiler =
            GpuProfiler::new(ctx, Self::scopes_per_frame_for(samples) + denoise_scopes).ok();
        Ok(Self {
            path,
            settings: settings.clone(),
            scene_scale: scale,
            emissive_geometry: renderer.scene_traits().emissive_geometry,
            passes,
            tonemap,
            readback,
            write_aov,
            denoiser,
            profiler,
            last_readback_ms: 0.0,
        })
    }

    /// Host milliseconds the last [`Self::render`] spent reading its image back (mapping
    /// and copying out of the readback buffer).
    pub fn last_readback_ms(&self) -> f64 {
        self.last_readback_ms
    }

    fn scopes_per_frame_for(samples: u32) -> u32 {
        SCOPES_PER_SAMPLE * samples + 2
    }

    /// Timestamp scopes one frame records (the frame itself included): size a burst's
    /// profiler with this times the frames.
    pub fn scopes_per_frame(&self) -> u32 {
        Self::scopes_per_frame_for(match &self.passes {
            PathPasses::RayTraced(_) => 1,
            PathPasses::Hybrid { samples, .. } => samples.len() as u32,
        }) + if self.denoiser.is_some() {
            denoise::SCOPES
        } else {
            0
        }
    }

    /// The denoiser, when the settings ask for one.
    pub fn denoiser(&self) -> Option<&Denoiser> {
        self.denoiser.as_ref()
    }

    /// Forgets the denoiser's history (nothing without one): the next frame is filtered alone.
    pub fn reset_history(&self) {
        if let Some(d) = &self.denoiser {
            d.reset();
        }
    }

    /// The path these targets render.
    pub fn path(&self) -> RenderPath {
        self.path
    }

    /// The settings these targets were made for.
    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// The frame uniform for `camera` at these targets' settings.
    pub fn gpu_frame(&self, camera: &Camera) -> GpuFrame {
        let s = &self.settings;
        let setup = CameraSetup::new(camera, s.width, s.height, self.scene_scale);
        let scene = SceneTraits {
            scale: self.scene_scale,
            emissive_geometry: self.emissive_geometry,
        };
        GpuFrame::new(s, &setup, scene)
    }

    /// The frame uniform for frame `number` of a sequence through `camera`: its camera
    /// samples are numbered after the earlier frames' (`number` × spp on), so the distributed
    /// model draws new random numbers every frame.
    pub fn sequence_frame(&self, camera: &Camera, number: u32) -> GpuFrame {
        let mut frame = self.gpu_frame(camera);
        frame.sample_base = number.wrapping_mul(self.settings.spp);
        frame
    }

    /// Records one frame seen through `frame` into `cmd`: a barrier against the previous
    /// frame's work, the passes, tonemapping, and, with `out`, the copies of its outputs into
    /// that ring slot ([`Self::output`] reads them once the submission has completed).
    /// Timestamp scopes go to `profiler` (the caller brackets frames with
    /// `begin_frame`/`end_frame`).
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        frame: &GpuFrame,
        mut profiler: Option<&mut GpuProfiler>,
        out: Option<(&FrameRing, u32)>,
    ) {
        let device = ctx.device();
        // Write-after-read against the previous frame in the same command buffer (its
        // passes still read the uniform and the counters this frame resets).
        memory_barrier(device, cmd);
        match &self.passes {
            PathPasses::RayTraced(rt) => {
                rt.record(ctx, cmd, frame, profiler.as_deref_mut());
                memory_barrier(device, cmd);
            }
            PathPasses::Hybrid {
                samples, counters, ..
            } => {
                let sequence_jitter = frame.flags & crate::interface::FLAG_SEQUENCE_JITTER != 0;
                let mut weights = Vec::with_capacity(samples.len());
                for (i, s) in (0u32..).zip(samples) {
                    let mut f = *frame;
                    f.jitter = s.jitter;
                    f.sample_base = frame.sample_base + i;
                    let mut weight = s.weight;
                    if sequence_jitter {
                        // As the ray-traced pass places sample sample_base + i (same sampler).
                        let st = &self.settings;
                        if let Some(u) = sampling::pixel_independent_sample(
                            st.sampler,
                            f.sample_base,
                            st.spp,
                            st.seed,
                        ) {
                            (f.jitter, weight) = sample_jitter(st.filter, u);
                        }
                    }
                    weights.push(weight);
                    s.frame.record_update(device, cmd, bytemuck::bytes_of(&f));
                }
                // SAFETY: recording command buffer; the counters buffer is ours.
                unsafe { device.cmd_fill_buffer(cmd, counters.raw(), 0, vk::WHOLE_SIZE, 0) };
                memory_barrier(device, cmd);
                let camera_pos = glam::Vec3::from(frame.camera_pos);
                let draws = match &self.passes {
                    PathPasses::Hybrid { draws, .. } => draws.as_slice(),
                    PathPasses::RayTraced(_) => &[],
                };
                let extent = vk::Extent2D {
                    width: self.settings.width,
                    height: self.settings.height,
                };
                for (i, s) in samples.iter().enumerate() {
                    s.gbuffer
                        .record(ctx, cmd, draws, camera_pos, profiler.as_deref_mut());
                    let mut flags = 0;
                    if i == 0 {
                        flags |= HYBRID_FIRST_SAMPLE;
                        if self.write_aov || self.denoiser.is_some() {
                            flags |= HYBRID_WRITE_AOV;
                        }
                    }
                    let guide = self.denoiser.as_ref().map_or(0, |d| d.guide.address());
                    s.shading.record(
                        cmd,
                        extent,
                        flags,
                        weights[i],
                        guide,
                        profiler.as_deref_mut(),
                    );
                    memory_barrier(device, cmd);
                }
            }
        }
        if let Some(d) = &self.denoiser {
            let (color, aov) = self.shaded_color_and_aov();
            d.record(ctx, cmd, frame, color, aov, profiler.as_deref_mut());
        }
        let s = &self.settings;
        self.tonemap.record(cmd, profiler, s.tonemap, s.exposure);
        if let Some((ring, slot)) = out {
            memory_barrier(device, cmd);
            self.record_copy(device, cmd, ring, slot);
        }
    }

    /// The shading passes' colour (the hybrid path's weighted accumulation) and AOV buffers.
    fn shaded_color_and_aov(&self) -> (&Buffer, &Buffer) {
        match &self.passes {
            PathPasses::RayTraced(rt) => (&rt.color, &rt.aov),
            PathPasses::Hybrid { accum, aov, .. } => (accum, aov),
        }
    }

    /// Records copies of the last recorded frame's outputs into `ring`'s slot `slot`.
    pub fn record_copy(
        &self,
        device: &ash::Device,
        cmd: vk::CommandBuffer,
        ring: &FrameRing,
        slot: u32,
    ) {
        let (color, counters, aov) = match &self.passes {
            PathPasses::RayTraced(rt) => (&rt.color, &rt.counters, &rt.aov),
            PathPasses::Hybrid {
                accum,
                counters,
                aov,
                ..
            } => (accum, counters, aov),
        };
        let color = self.denoiser.as_ref().map_or(color, |d| &d.output);
        ring.record_copy(
            device,
            cmd,
            slot,
            &RingSources {
                counters,
                rgba8: &self.tonemap.output,
                color,
                aov: self.write_aov.then_some(aov),
                states: None,
            },
        );
    }

    /// The image, AOVs and ray counts a frame copied into `ring`'s slot `slot`, after its
    /// submission completed (`gpu_ms` is left empty: timing belongs to the caller).
    pub fn output(&self, ring: &FrameRing, slot: u32) -> VkResult<RenderOutput> {
        let (rays, samples) = ray_counts(&ring.counters(slot)?);
        let rgba8 = ring.rgba8(slot)?;
        let color = ring.color(slot)?;
        let aov = ring.aov(slot)?;
        let color = match self.path {
            RenderPath::RayTraced => color,
            // The hybrid accumulation holds Σ weight·colour and Σ weight.
            RenderPath::Hybrid => color
                .iter()
                .map(|v| {
                    if v[3] > 0.0 {
                        [v[0] / v[3], v[1] / v[3], v[2] / v[3], 1.0]
                    } else {
                        [v[0], v[1], v[2], 1.0]
                    }
                })
                .collect(),
        };
        Ok(RenderOutput {
            width: self.settings.width,
            height: self.settings.height,
            color,
            rgba8,
            aov,
            rays,
            samples,
            gpu_ms: Vec::new(),
        })
    }

    /// The one-slot ring [`Self::render`] reads back through; record into it with
    /// `Some((targets.readback_ring(), 0))` and read with [`Self::read`].
    pub fn readback_ring(&self) -> &FrameRing {
        &self.readback
    }

    /// The hybrid path's G-buffer image `image` (`GBUFFER_*`, a `R32G32B32A32_SFLOAT` one)
    /// of the first sample, as the last frame left it: e.g. `GBUFFER_BARY`'s barycentrics and
    /// motion vectors. `None` on the ray-traced path or without that image.
    pub fn hybrid_gbuffer(&self, ctx: &Context, image: u32) -> VkResult<Option<Vec<[f32; 4]>>> {
        let PathPasses::Hybrid { samples, .. } = &self.passes else {
            return Ok(None);
        };
        let Some(image) = samples
            .first()
            .and_then(|s| s.gbuffer.images.get(image as usize))
        else {
            return Ok(None);
        };
        image.read_rgba32f(ctx, vk::ImageLayout::GENERAL).map(Some)
    }

    /// [`Self::output`] of [`Self::readback_ring`].
    pub fn read(&self) -> VkResult<RenderOutput> {
        self.output(&self.readback, 0)
    }

    /// Renders one frame through `camera` in its own submission and reads it back, with GPU
    /// times per pass (scopes of the same name, one per sample, summed).
    pub fn render(&mut self, ctx: &Context, camera: &Camera) -> crate::Result<RenderOutput> {
        let frame = self.gpu_frame(camera);
        let mut profiler = self.profiler.take();
        let name = match self.path {
            RenderPath::RayTraced => "ray-traced frame",
            RenderPath::Hybrid => "hybrid frame",
        };
        let recorded = ctx.run(name, |cmd| {
            if let Some(p) = profiler.as_mut() {
                p.reset(cmd);
            }
            self.record(
                ctx,
                cmd,
                &frame,
                profiler.as_mut(),
                Some((&self.readback, 0)),
            );
            Ok(())
        });
        self.profiler = profiler;
        recorded?;
        let readback_start = std::time::Instant::now();
        let mut out = self.output(&self.readback, 0)?;
        self.last_readback_ms = readback_start.elapsed().as_secs_f64() * 1e3;
        if let Some(p) = &self.profiler {
            out.gpu_ms = merge_scopes(p.results()?);
        }
        Ok(out)
    }
}

/// The raster jitter (sample position − pixel centre) and filter weight of a sample at `u` in
/// the pixel: the tent filter's samples spread over [-1, 1) around the centre.
fn sample_jitter(filter: FilterKind, u: [f32; 2]) -> ([f32; 2], f32) {
    match filter {
        FilterKind::Box => ([u[0] - 0.5, u[1] - 0.5], 1.0),
        FilterKind::Tent => {
            let o = [u[0] * 2.0 - 1.0, u[1] * 2.0 - 1.0];
            (o, sampling::tent_weight(o[0], o[1]))
        }
    }
}

/// The sub-pixel position of every sample of the hybrid path (one raster pass each): the
/// samplers that place sample s at the same offset in every pixel.
fn hybrid_sample_positions(settings: &RenderSettings) -> crate::Result<Vec<[f32; 2]>> {
    (0..settings.spp)
        .map(|s| {
            sampling::pixel_independent_sample(settings.sampler, s, settings.spp, settings.seed)
        })
        .collect::<Option<_>>()
        .ok_or_else(|| {
            SettingsError::new(
                "--sampler",
                format!(
                    "--sampler {:?} varies per pixel (or is adaptive); the hybrid path rasterizes one jittered pass per sample and supports center, grid, halton and sobol",
                    settings.sampler
                )
                .to_lowercase(),
            )
            .into()
        })
}
