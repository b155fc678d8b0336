//! Rendering: the [`Renderer`] that runs the passes on an uploaded scene, and around it
//!
//! - [`passes`]: the GPU passes, one module each;
//! - [`settings`] (what to render), [`memory`] (what it will allocate), [`frame`] (the `Frame`
//!   uniform and camera matrices) and [`sampling`] (the host mirror of the sample sequences);
//! - the frame drivers in [`drivers`]: [`drivers::targets`] (one frame's resources),
//!   [`drivers::burst`] (timed frames), [`drivers::sequence`] and [`drivers::animated`]
//!   (camera sequences and animation), and [`readback`] (the host-visible ring frames copy
//!   their outputs into);
//! - [`denoise`]: the SVGF denoiser of distributed frames (`--denoise`), recorded by the frame
//!   targets between shading and tonemapping;
//! - [`temporal`]: temporal reuse (reprojection, frameless rendering, adaptive sub-sampling),
//!   a multi-frame technique with its own caches and passes, which the sequence driver runs;
//! - [`image`]: host image utilities (PNG/EXR output, labels and charts, FLIP/PSNR);
//! - [`reference`](mod@reference): CPU references of shader code, used only by tests.

pub mod denoise;
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
pub use frame::{CameraSetup, GpuFrame, SceneTraits};
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
    /// The device's largest sampled-image array (`DeviceInfo::max_sampled_image_array`).
    pub texture_limit: u32,
}

/// The least bindless texture array a pass layout gets: 16 combined image samplers in one
/// stage is what every Vulkan device allows.
const MIN_TEXTURE_CAPACITY: u32 = 16;

/// Size of the bindless texture array of `count` textures on a device allowing `limit` in
/// one binding (0: unknown): `count` rounded up to a power of two, at least 16, so that
/// scenes with similar texture counts get the same pipeline layouts and so share compiled
/// pipelines (the context's cache is keyed by layout: a process rendering many scenes would
/// otherwise compile every pass again for each new texture count, seconds each on a CPU
/// device). The binding is partially bound, so the unused tail costs only descriptor memory.
/// Exactly `count` where the rounded size is over the limit.
pub fn texture_capacity(count: usize, limit: u32) -> u32 {
    let count = u32::try_from(count).unwrap_or(u32::MAX).max(1);
    let rounded = count
        .checked_next_power_of_two()
        .unwrap_or(count)
        .max(MIN_TEXTURE_CAPACITY);
    if limit == 0 || rounded > limit {
        count
    } else {
        rounded
    }
}

impl PassContext<'_> {
    /// Size of the bindless texture array binding ([`texture_capacity`]).
    pub fn texture_capacity(&self) -> u32 {
        texture_capacity(self.textures.len(), self.texture_limit)
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
    /// The device's largest sampled-image array (sizes [`PassContext::texture_capacity`]).
    texture_limit: u32,
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
        let renderer = Self::from_parts(ctx, gpu, backend, gpu_textures, textures);
        Ok((renderer, times))
    }

    /// A renderer of an uploaded scene, its backend and textures (`textures` are
    /// `gpu_textures`' descriptors), without an environment.
    pub(crate) fn from_parts(
        ctx: &Context,
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
            texture_limit: ctx.info().max_sampled_image_array,
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
            texture_limit: self.texture_limit,
        }
    }

    /// Diagonal of the scene bounds.
    pub fn scene_scale(&self) -> f32 {
        self.scene_scale
    }

    /// What the frame uniform needs to know of the scene: its scale and whether it has
    /// emissive triangles.
    pub fn scene_traits(&self) -> SceneTraits {
        SceneTraits {
            scale: self.scene_scale,
            emissive_geometry: self.gpu.emissive_geometry,
        }
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

#[cfg(test)]
mod tests {
    use super::texture_capacity;

    #[test]
    fn texture_capacity_buckets_counts_within_the_device_limit() {
        // Every count up to 16 shares one layout; above, powers of two.
        for count in 0..=16 {
            assert_eq!(texture_capacity(count, 1 << 20), 16, "{count} textures");
        }
        assert_eq!(texture_capacity(17, 1 << 20), 32);
        assert_eq!(texture_capacity(33, 1 << 20), 64);
        assert_eq!(texture_capacity(64, 1 << 20), 64);
        // Never over the limit: the exact count where the rounded one would not fit.
        assert_eq!(texture_capacity(600, 1000), 600);
        assert_eq!(texture_capacity(3, 8), 3);
        // An unknown limit (0) keeps the exact count, at least one.
        assert_eq!(texture_capacity(0, 0), 1);
        assert_eq!(texture_capacity(5, 0), 5);
    }
}
