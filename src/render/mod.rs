//! Render passes (one module each) and the [`Renderer`] that runs them on an uploaded scene.

pub mod compare;
pub mod frame;
pub mod gbuffer;
pub mod hybrid;
pub mod label;
pub mod optics;
pub mod output;
pub mod raybench;
pub mod raytraced;
pub mod reproject;
pub mod sampling;
pub mod sequence;
pub mod tonemap;

use ash::vk;
use bytemuck::{Pod, Zeroable};

use crate::accel::{Backend, RayBackend};
use crate::scene::gpu::GpuScene;
use crate::scene::{Camera, Scene};
use crate::vk::{memory_barrier, Context, DescriptorSet, GpuProfiler};
pub use frame::{CameraSetup, FilterKind, GpuFrame, RenderSettings, SamplerKind, Tonemap};
pub use reproject::RenderPath;

/// Per-pixel arbitrary output variables of the primary hit (`raytrace.comp`'s `Aov`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Aov {
    /// xyz: geometric world normal of the glTF front face; w: hit distance (0 on a miss).
    pub normal_depth: [f32; 4],
    /// xyz: world position; w: instance index (-1 on a miss).
    pub position_inst: [f32; 4],
    /// xy: barycentrics; z: primitive index (-1 on a miss); w: samples traced for the pixel.
    pub bary_prim: [f32; 4],
}

impl Aov {
    /// Hit distance along the unit primary ray (0 on a miss).
    pub fn depth(&self) -> f32 {
        self.normal_depth[3]
    }
    /// Instance index, -1 on a miss.
    pub fn instance(&self) -> i32 {
        self.position_inst[3] as i32
    }
    /// Primitive index, -1 on a miss.
    pub fn primitive(&self) -> i32 {
        self.bary_prim[2] as i32
    }
}

/// Rays traced, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct RayCounts {
    /// Camera rays (including the adaptive sampler's extra ones).
    pub primary: u64,
    /// Shadow rays.
    pub shadow: u64,
    /// Reflection rays.
    pub reflection: u64,
    /// Refraction (and alpha-blend continuation) rays.
    pub refraction: u64,
}

impl RayCounts {
    /// All rays.
    pub fn total(&self) -> u64 {
        self.primary + self.shadow + self.reflection + self.refraction
    }
}

/// What a pass needs of the scene: its buffers, textures and ray backend.
pub struct PassContext<'a> {
    /// Uploaded scene.
    pub scene: &'a GpuScene,
    /// Ray backend.
    pub backend: &'a RayBackend,
    /// Bindless textures in texture-index order.
    pub textures: &'a [(vk::ImageView, vk::Sampler)],
}

impl PassContext<'_> {
    /// Size of the bindless texture array binding.
    pub fn texture_capacity(&self) -> u32 {
        (self.textures.len() as u32).max(1)
    }

    /// Writes set-0 bindings 0 (scene), 1 (textures) and 2 (ray backend).
    pub fn bind_scene(&self, set: &DescriptorSet) {
        self.scene.bind(set);
        set.sampled_images(1, self.textures);
        self.backend.bind(set);
    }
}

/// A rendered image with its statistics.
pub struct RenderOutput {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Linear HDR colour (RGBA, alpha 1), row 0 = top.
    pub color: Vec<[f32; 4]>,
    /// Tonemapped sRGB RGBA8.
    pub rgba8: Vec<u8>,
    /// Primary-hit AOVs (empty unless requested).
    pub aov: Vec<Aov>,
    /// Rays traced by kind.
    pub rays: RayCounts,
    /// Samples traced (camera samples, adaptive ones included).
    pub samples: u64,
    /// GPU milliseconds per pass.
    pub gpu_ms: Vec<(String, f64)>,
}

impl RenderOutput {
    /// Mean samples per pixel actually traced.
    pub fn mean_spp(&self) -> f64 {
        self.samples as f64 / (f64::from(self.width) * f64::from(self.height)).max(1.0)
    }

    /// Sum of all pass times.
    pub fn total_ms(&self) -> f64 {
        self.gpu_ms.iter().map(|p| p.1).sum()
    }
}

/// An uploaded scene with its ray backend, ready to render.
pub struct Renderer {
    /// Scene buffers.
    pub gpu: GpuScene,
    /// Ray backend.
    pub backend: RayBackend,
    _textures: crate::scene::textures::GpuTextures,
    textures: Vec<(vk::ImageView, vk::Sampler)>,
    scene_scale: f32,
}

impl Renderer {
    /// Uploads `scene` and builds the chosen backend (the compute BVH where `--bvh-build auto`
    /// puts it).
    pub fn new(ctx: &Context, scene: &Scene, backend: Backend) -> crate::Result<Self> {
        let (bvh_build, _) = crate::accel::bvh::BvhBuildChoice::Auto.resolve(ctx.info());
        Self::with_bvh_build(ctx, scene, backend, bvh_build)
    }

    /// Uploads `scene` and builds the chosen backend, the compute BVH with `bvh_build`.
    pub fn with_bvh_build(
        ctx: &Context,
        scene: &Scene,
        backend: Backend,
        bvh_build: crate::accel::bvh::BvhBuild,
    ) -> crate::Result<Self> {
        let gpu_textures = crate::scene::textures::GpuTextures::upload(ctx, scene)?;
        let textures = gpu_textures.descriptors();
        let gpu = GpuScene::upload(ctx, scene, textures.len() as u32)?;
        let backend = RayBackend::build(ctx, scene, &gpu, backend, bvh_build)?;
        Ok(Self {
            scene_scale: gpu.refs_data.scene_scale,
            gpu,
            backend,
            _textures: gpu_textures,
            textures,
        })
    }

    /// The set-0 inputs of every pass.
    pub fn pass_context(&self) -> PassContext<'_> {
        PassContext {
            scene: &self.gpu,
            backend: &self.backend,
            textures: &self.textures,
        }
    }

    /// Diagonal of the scene bounds.
    pub fn scene_scale(&self) -> f32 {
        self.scene_scale
    }

    /// Renders one image with the pure ray-traced path. With `write_aov` it also fills
    /// [`RenderOutput::aov`], which takes a 48-byte-per-pixel buffer (checked against the
    /// device's `maxStorageBufferRange` and heap first); without, no such buffer is allocated.
    pub fn render_rt(
        &self,
        ctx: &Context,
        settings: &RenderSettings,
        camera: &Camera,
        write_aov: bool,
    ) -> crate::Result<RenderOutput> {
        settings
            .check_device(
                ctx.info(),
                RenderPath::RayTraced,
                write_aov,
                ctx.allocated_bytes(),
            )
            .map_err(|e| crate::vk::VkError::Limit(e.to_string()))?;
        let setup = CameraSetup::new(camera, settings.width, settings.height, self.scene_scale);
        let frame = GpuFrame::new(settings, &setup, self.scene_scale);
        let pass = raytraced::RaytracedPass::new(ctx, &self.pass_context(), frame, write_aov)?;
        let pixels = settings.width * settings.height;
        let tonemap = tonemap::TonemapPass::new(ctx, &pass.color, pixels)?;
        let mut profiler = GpuProfiler::new(ctx, 8).ok();
        ctx.run("ray-traced frame", |cmd| {
            if let Some(p) = profiler.as_mut() {
                p.reset(cmd);
            }
            pass.record(ctx, cmd, profiler.as_mut());
            memory_barrier(ctx.device(), cmd);
            tonemap.record(cmd, profiler.as_mut(), settings.tonemap, settings.exposure);
            Ok(())
        })?;
        let gpu_ms = match &profiler {
            Some(p) => p.results()?,
            None => Vec::new(),
        };
        let counters: Vec<u32> = pass.counters.read(ctx)?;
        let color: Vec<[f32; 4]> = pass.color.read(ctx)?;
        let rgba8: Vec<u8> = tonemap.output.read(ctx)?;
        let aov = if write_aov {
            pass.aov.read(ctx)?
        } else {
            Vec::new()
        };
        Ok(RenderOutput {
            width: settings.width,
            height: settings.height,
            color: color[..pixels as usize].to_vec(),
            rgba8: rgba8[..pixels as usize * 4].to_vec(),
            aov: aov.into_iter().take(pixels as usize).collect(),
            rays: RayCounts {
                primary: u64::from(counters[0]),
                shadow: u64::from(counters[1]),
                reflection: u64::from(counters[2]),
                refraction: u64::from(counters[3]),
            },
            samples: u64::from(counters[4]),
            gpu_ms,
        })
    }
}

impl Renderer {
    /// Renders one image with the hybrid path: per sample, a raster G-buffer pass jittered to
    /// the sample position, then the shading pass (shadow, reflection, refraction rays).
    /// `write_aov` as in [`Self::render_rt`].
    pub fn render_hybrid(
        &self,
        ctx: &Context,
        scene_draws: &[gbuffer::Draw],
        settings: &RenderSettings,
        camera: &Camera,
        write_aov: bool,
    ) -> crate::Result<RenderOutput> {
        settings
            .check_device(
                ctx.info(),
                RenderPath::Hybrid,
                write_aov,
                ctx.allocated_bytes(),
            )
            .map_err(|e| crate::vk::VkError::Limit(e.to_string()))?;
        let positions: Vec<[f32; 2]> = (0..settings.spp)
            .map(|s| sampling::pixel_independent_sample(settings.sampler, s, settings.spp, settings.seed))
            .collect::<Option<_>>()
            .ok_or_else(|| {
                crate::vk::VkError::Limit(format!(
                    "--sampler {:?} varies per pixel (or is adaptive); the hybrid path rasterizes one jittered pass per sample and supports center, grid, halton and sobol",
                    settings.sampler
                ).to_lowercase())
            })?;
        let setup = CameraSetup::new(camera, settings.width, settings.height, self.scene_scale);
        let frame = GpuFrame::new(settings, &setup, self.scene_scale);
        let extent = vk::Extent2D {
            width: settings.width,
            height: settings.height,
        };
        let pixels = u64::from(settings.width) * u64::from(settings.height);
        let none = vk::BufferUsageFlags::empty();
        use crate::vk::{Buffer, MemoryLocation};
        let frames: Vec<Buffer> = positions
            .iter()
            .map(|_| {
                Buffer::new(
                    ctx,
                    "hybrid frame",
                    std::mem::size_of::<GpuFrame>() as u64,
                    vk::BufferUsageFlags::UNIFORM_BUFFER,
                    MemoryLocation::CpuToGpu,
                )
            })
            .collect::<Result<_, _>>()?;
        let accum = Buffer::new(
            ctx,
            "hybrid accumulation",
            pixels * 16,
            none,
            MemoryLocation::GpuOnly,
        )?;
        // Per-pixel AOVs only when asked for; else a placeholder (hybrid.comp writes AOVs
        // only under HYBRID_WRITE_AOV).
        let aov = Buffer::new(
            ctx,
            if write_aov {
                "hybrid aov"
            } else {
                "hybrid aov placeholder"
            },
            if write_aov { pixels } else { 1 } * std::mem::size_of::<Aov>() as u64,
            none,
            MemoryLocation::GpuOnly,
        )?;
        let counters = Buffer::new(
            ctx,
            "hybrid counters",
            raytraced::COUNTER_SLOTS as u64 * 4,
            none,
            MemoryLocation::GpuOnly,
        )?;
        let pass_ctx = self.pass_context();
        let mut passes = Vec::with_capacity(positions.len());
        let mut weights = Vec::with_capacity(positions.len());
        for (buf, u) in frames.into_iter().zip(&positions) {
            let (jitter, weight) = match settings.filter {
                FilterKind::Box => ([u[0] - 0.5, u[1] - 0.5], 1.0),
                FilterKind::Tent => {
                    let o = [u[0] * 2.0 - 1.0, u[1] * 2.0 - 1.0];
                    (o, sampling::tent_weight(o[0], o[1]))
                }
            };
            let mut f = frame;
            f.jitter = jitter;
            let mut buf = buf;
            buf.write(bytemuck::bytes_of(&f))?;
            let g = gbuffer::GbufferPass::new(ctx, &pass_ctx, &buf, extent, settings.gbuffer)?;
            let h = hybrid::HybridPass::new(ctx, &pass_ctx, &buf, &accum, &aov, &counters, &g)?;
            passes.push((buf, g, h));
            weights.push(weight);
        }
        let tonemap = tonemap::TonemapPass::new(ctx, &accum, pixels as u32)?;
        let mut profiler = GpuProfiler::new(ctx, 4 * positions.len() as u32 + 4).ok();
        ctx.run("hybrid frame", |cmd| {
            if let Some(p) = profiler.as_mut() {
                p.reset(cmd);
            }
            // SAFETY: recording command buffer; the counters buffer is ours.
            unsafe {
                ctx.device()
                    .cmd_fill_buffer(cmd, counters.raw(), 0, vk::WHOLE_SIZE, 0)
            };
            memory_barrier(ctx.device(), cmd);
            for (i, ((_, g, h), w)) in passes.iter().zip(&weights).enumerate() {
                g.record(
                    ctx,
                    cmd,
                    scene_draws,
                    setup.camera_to_world.w_axis.truncate(),
                    profiler.as_mut(),
                );
                let mut flags = 0;
                if i == 0 {
                    flags |= hybrid::HYBRID_FIRST_SAMPLE;
                    if write_aov {
                        flags |= hybrid::HYBRID_WRITE_AOV;
                    }
                }
                h.record(cmd, extent, flags, *w, profiler.as_mut());
                memory_barrier(ctx.device(), cmd);
            }
            tonemap.record(cmd, profiler.as_mut(), settings.tonemap, settings.exposure);
            Ok(())
        })?;
        let gpu_ms = match &profiler {
            Some(p) => merge_scopes(p.results()?),
            None => Vec::new(),
        };
        let c: Vec<u32> = counters.read(ctx)?;
        let color: Vec<[f32; 4]> = accum.read(ctx)?;
        let rgba8: Vec<u8> = tonemap.output.read(ctx)?;
        let aov = if write_aov {
            aov.read(ctx)?
        } else {
            Vec::new()
        };
        let n = pixels as usize;
        Ok(RenderOutput {
            width: settings.width,
            height: settings.height,
            color: color[..n]
                .iter()
                .map(|v| {
                    if v[3] > 0.0 {
                        [v[0] / v[3], v[1] / v[3], v[2] / v[3], 1.0]
                    } else {
                        [v[0], v[1], v[2], 1.0]
                    }
                })
                .collect(),
            rgba8: rgba8[..n * 4].to_vec(),
            aov: aov.into_iter().take(n).collect(),
            rays: RayCounts {
                primary: u64::from(c[0]),
                shadow: u64::from(c[1]),
                reflection: u64::from(c[2]),
                refraction: u64::from(c[3]),
            },
            samples: u64::from(c[4]),
            gpu_ms,
        })
    }
}

/// Sums scopes of the same name (one per sample) keeping first-seen order.
fn merge_scopes(scopes: Vec<(String, f64)>) -> Vec<(String, f64)> {
    let mut out: Vec<(String, f64)> = Vec::new();
    for (name, ms) in scopes {
        match out.iter_mut().find(|(n, _)| *n == name) {
            Some(e) => e.1 += ms,
            None => out.push((name, ms)),
        }
    }
    out
}
