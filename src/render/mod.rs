//! Rendering: the [`Renderer`] that runs the passes on an uploaded scene, and around it
//!
//! - [`passes`]: the GPU passes, one module each;
//! - [`settings`] (what to render), [`memory`] (what it will allocate), [`frame`] (the `Frame`
//!   uniform and camera matrices) and [`sampling`] (the host mirror of the sample sequences);
//! - the frame drivers in [`drivers`]: [`drivers::targets`] (one frame's resources),
//!   [`drivers::burst`] (timed frames), [`drivers::sequence`] and [`drivers::animated`]
//!   (camera sequences and animation), and [`readback`] (the host-visible ring frames copy
//!   their outputs into);
//! - [`temporal`]: temporal reuse (reprojection, frameless rendering, adaptive sub-sampling),
//!   a multi-frame technique with its own caches and passes, which the sequence driver runs;
//! - [`image`]: host image utilities (PNG/EXR output, labels and charts, FLIP/PSNR);
//! - [`reference`](mod@reference): CPU references of shader code, used only by tests.

pub mod drivers;
pub mod frame;
pub mod image;
pub mod memory;
pub mod passes;
pub mod readback;
pub mod reference;
pub mod sampling;
pub mod settings;
pub mod temporal;

use ash::vk;

use crate::accel::{Backend, RayBackend};
use crate::scene::gpu::GpuScene;
use crate::scene::{Camera, Scene};
use crate::vk::{Context, DescriptorSet};
pub use drivers::targets::FrameTargets;
pub use frame::{CameraSetup, GpuFrame};
pub use settings::{FilterKind, RenderPath, RenderSettings, SamplerKind, Shading, Tonemap};

pub use crate::interface::Aov;

impl Aov {
    /// Hit distance along the unit primary ray (0 on a miss).
    pub fn depth(&self) -> f32 {
        self.normal_depth[3]
    }
    /// Whether the primary ray hit a surface.
    pub fn hit(&self) -> bool {
        self.instance != crate::interface::AOV_NO_ID
    }
    /// Instance index, -1 on a miss (the GPU's `uint` reinterpreted: exact at any scene size).
    pub fn instance(&self) -> i32 {
        self.instance as i32
    }
    /// Primitive index, -1 on a miss (the GPU's `uint` reinterpreted, as for the instance).
    pub fn primitive(&self) -> i32 {
        self.primitive as i32
    }
    /// World-space shading normal (after normal mapping, towards the camera; 0 on a miss).
    pub fn shading_normal(&self) -> glam::Vec3 {
        glam::Vec3::from_slice(&self.normal_depth[..3])
    }
    /// World-space geometric normal of the glTF front face (0 on a miss).
    pub fn geometric_normal(&self) -> glam::Vec3 {
        glam::Vec3::from_slice(&self.geometric_samples[..3])
    }
    /// World-space hit position (0 on a miss).
    pub fn world_position(&self) -> glam::Vec3 {
        glam::Vec3::from_slice(&self.position[..3])
    }
    /// Linear base colour of the hit, clamped to [0, 1] (0 on a miss).
    pub fn albedo_rgb(&self) -> glam::Vec3 {
        glam::Vec3::from_slice(&self.albedo[..3])
    }
    /// Camera samples traced for the pixel.
    pub fn samples(&self) -> f32 {
        self.geometric_samples[3]
    }
}

/// GPU timestamp scopes of the single-frame passes: their names key `RenderOutput::gpu_ms`,
/// reports and the CLI's tables, so code that looks a pass up uses these instead of strings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PassScope {
    /// The ray-traced pass (`raytrace.comp`).
    RayTraced,
    /// The raster G-buffer or visibility pass.
    Gbuffer,
    /// The hybrid shading pass.
    HybridShading,
    /// The tonemap pass.
    Tonemap,
}

impl PassScope {
    /// The scope's name in timings.
    pub const fn name(self) -> &'static str {
        match self {
            Self::RayTraced => "rt",
            Self::Gbuffer => "gbuffer",
            Self::HybridShading => "hybrid shading",
            Self::Tonemap => "tonemap",
        }
    }

    /// The scope that shades the image on `path`.
    pub const fn shading(path: RenderPath) -> Self {
        match path {
            RenderPath::RayTraced => Self::RayTraced,
            RenderPath::Hybrid => Self::HybridShading,
        }
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
    /// Diffuse rays (distributed model; the Whitted model traces none).
    pub diffuse: u64,
}

impl std::ops::Add for RayCounts {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self {
            primary: self.primary + o.primary,
            shadow: self.shadow + o.shadow,
            reflection: self.reflection + o.reflection,
            refraction: self.refraction + o.refraction,
            diffuse: self.diffuse + o.diffuse,
        }
    }
}

impl RayCounts {
    /// All rays.
    pub fn total(&self) -> u64 {
        self.primary + self.shadow + self.reflection + self.refraction + self.diffuse
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

    /// Writes the set-0 bindings of the scene, the textures and the ray backend.
    pub fn bind_scene(&self, set: &DescriptorSet) {
        self.scene.bind(set);
        set.sampled_images(crate::interface::BINDING_TEXTURES, self.textures);
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

/// Wall-clock milliseconds of [`Renderer::with_build_times`]' two stages.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct BuildTimes {
    /// Textures and scene buffers to the device.
    pub upload_ms: f64,
    /// Acceleration structures (hardware backend) or the compute BVH.
    pub accel_build_ms: f64,
}

/// An uploaded scene with its ray backend, ready to render.
pub struct Renderer {
    /// Scene buffers.
    pub gpu: GpuScene,
    /// Ray backend.
    pub backend: RayBackend,
    _textures: crate::scene::textures::GpuTextures,
    textures: Vec<(vk::ImageView, vk::Sampler)>,
    /// How many entries of `textures` are the scene's (the environment's follow).
    scene_texture_count: usize,
    environment: Option<crate::environment::GpuEnvironment>,
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
        Self::with_build_times(ctx, scene, backend, bvh_build).map(|(r, _)| r)
    }

    /// [`Self::with_bvh_build`], also returning how long the upload and the acceleration
    /// structure (or BVH) build took.
    pub fn with_build_times(
        ctx: &Context,
        scene: &Scene,
        backend: Backend,
        bvh_build: crate::accel::bvh::BvhBuild,
    ) -> crate::Result<(Self, BuildTimes)> {
        let start = std::time::Instant::now();
        let gpu_textures = crate::scene::textures::GpuTextures::upload(ctx, scene)?;
        let textures = gpu_textures.descriptors();
        let gpu = GpuScene::upload(ctx, scene, textures.len() as u32)?;
        let uploaded = std::time::Instant::now();
        let backend = RayBackend::build(ctx, scene, &gpu, backend, bvh_build)?;
        let times = BuildTimes {
            upload_ms: (uploaded - start).as_secs_f64() * 1e3,
            accel_build_ms: uploaded.elapsed().as_secs_f64() * 1e3,
        };
        let renderer = Self::from_parts(gpu, backend, gpu_textures, textures);
        Ok((renderer, times))
    }

    /// A renderer of an uploaded scene, its backend and textures (`textures` are
    /// `gpu_textures`' descriptors), without an environment.
    pub(crate) fn from_parts(
        gpu: GpuScene,
        backend: RayBackend,
        gpu_textures: crate::scene::textures::GpuTextures,
        textures: Vec<(vk::ImageView, vk::Sampler)>,
    ) -> Self {
        Self {
            scene_scale: gpu.refs_data.scene_scale,
            gpu,
            backend,
            _textures: gpu_textures,
            scene_texture_count: textures.len(),
            textures,
            environment: None,
        }
    }

    /// Lights the scene with `environment` (or with none): its textures join the bindless
    /// array after the scene's and `SceneRefs::environment` points at them. Passes and frame
    /// targets made afterwards see it; the renderer keeps the environment alive.
    pub fn set_environment(
        &mut self,
        ctx: &Context,
        environment: Option<crate::environment::GpuEnvironment>,
    ) -> crate::Result<()> {
        self.textures.truncate(self.scene_texture_count);
        let first = match &environment {
            Some(env) => {
                let first = self.textures.len() as i32;
                self.textures.extend(env.descriptors());
                first
            }
            None => -1,
        };
        self.gpu.set_environment(ctx, first)?;
        self.environment = environment;
        Ok(())
    }

    /// Removes the environment (the scene is then lit without one) and hands it back.
    pub fn take_environment(
        &mut self,
        ctx: &Context,
    ) -> crate::Result<Option<crate::environment::GpuEnvironment>> {
        self.textures.truncate(self.scene_texture_count);
        self.gpu.set_environment(ctx, -1)?;
        Ok(self.environment.take())
    }

    /// The environment lighting the scene, if any.
    pub fn environment(&self) -> Option<&crate::environment::GpuEnvironment> {
        self.environment.as_ref()
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
    /// [`RenderOutput::aov`], which takes an 80-byte-per-pixel buffer (checked against the
    /// device's `maxStorageBufferRange` and heap first); without, no such buffer is allocated.
    /// Allocates the frame's resources for this one image: frame loops keep a
    /// [`FrameTargets`] instead.
    pub fn render_rt(
        &self,
        ctx: &Context,
        settings: &RenderSettings,
        camera: &Camera,
        write_aov: bool,
    ) -> crate::Result<RenderOutput> {
        FrameTargets::new(ctx, self, RenderPath::RayTraced, settings, &[], write_aov)?
            .render(ctx, camera)
    }

    /// Renders one image with the hybrid path: per sample, a raster G-buffer pass jittered to
    /// the sample position, then the shading pass (shadow, reflection, refraction rays).
    /// `write_aov` as in [`Self::render_rt`].
    pub fn render_hybrid(
        &self,
        ctx: &Context,
        scene_draws: &[passes::draw_list::Draw],
        settings: &RenderSettings,
        camera: &Camera,
        write_aov: bool,
    ) -> crate::Result<RenderOutput> {
        FrameTargets::new(
            ctx,
            self,
            RenderPath::Hybrid,
            settings,
            scene_draws,
            write_aov,
        )?
        .render(ctx, camera)
    }
}

/// Sums scopes of the same name (one per sample) keeping first-seen order.
pub fn merge_scopes(scopes: Vec<(String, f64)>) -> Vec<(String, f64)> {
    let mut out: Vec<(String, f64)> = Vec::new();
    for (name, ms) in scopes {
        match out.iter_mut().find(|(n, _)| *n == name) {
            Some(e) => e.1 += ms,
            None => out.push((name, ms)),
        }
    }
    out
}
