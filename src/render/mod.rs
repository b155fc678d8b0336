//! Render passes (one module each) and the [`Renderer`] that runs them on an uploaded scene.

pub mod frame;
pub mod output;
pub mod raytraced;
pub mod tonemap;

use ash::vk;
use bytemuck::{Pod, Zeroable};

use crate::accel::{Backend, RayBackend};
use crate::scene::gpu::GpuScene;
use crate::scene::{Camera, Scene};
use crate::vk::{memory_barrier, Context, DescriptorSet, GpuProfiler};
pub use frame::{CameraSetup, FilterKind, GpuFrame, RenderSettings, SamplerKind, Tonemap};

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
    textures: Vec<(vk::ImageView, vk::Sampler)>,
    scene_scale: f32,
}

impl Renderer {
    /// Uploads `scene` and builds the chosen backend.
    pub fn new(ctx: &Context, scene: &Scene, backend: Backend) -> crate::Result<Self> {
        let gpu = GpuScene::upload(ctx, scene)?;
        let backend = RayBackend::build(ctx, scene, &gpu, backend)?;
        Ok(Self {
            scene_scale: gpu.refs_data.scene_scale,
            gpu,
            backend,
            textures: Vec::new(),
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

    /// Renders one image with the pure ray-traced path.
    pub fn render_rt(
        &self,
        ctx: &Context,
        settings: &RenderSettings,
        camera: &Camera,
        write_aov: bool,
    ) -> crate::Result<RenderOutput> {
        settings
            .validate(ctx.info().max_image_dimension_2d)
            .map_err(|e| crate::vk::VkError::Limit(e.to_string()))?;
        let setup = CameraSetup::new(camera, settings.width, settings.height, self.scene_scale);
        let frame = GpuFrame::new(settings, &setup, self.scene_scale);
        let pass = raytraced::RaytracedPass::new(ctx, &self.pass_context(), frame)?;
        let pixels = settings.width * settings.height;
        let tonemap = tonemap::TonemapPass::new(ctx, &pass.color, pixels)?;
        let mut profiler = GpuProfiler::new(ctx, 8).ok();
        ctx.run("ray-traced frame", |cmd| {
            if let Some(p) = profiler.as_mut() {
                p.reset(cmd);
            }
            pass.record(ctx, cmd, profiler.as_mut(), write_aov);
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
