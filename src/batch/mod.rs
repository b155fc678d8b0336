//! Rendering many assets in one process: `rqr batch` over a JSON Lines manifest, and the
//! library API under it.
//!
//! The library API is independent of the command line and of files:
//!
//! ```no_run
//! use rqr::batch::{BatchDevice, DeviceOptions, ViewOptions};
//! # fn main() -> Result<(), rqr::Error> {
//! let device = BatchDevice::open(&DeviceOptions::default())?; // once per process
//! let scene = device.load_scene(std::path::Path::new("model.glb"))?; // load + upload + build
//! let cameras = scene.orbit(8, [0.0, 30.0], 40.0, 7, 1.0);
//! let views = scene.render_views(&device, &cameras, &ViewOptions::default())?;
//! let rgba: &[u8] = &views[0].rgba8; // width * height * 4, row 0 = top
//! # Ok(()) }
//! ```
//!
//! Modules: [`manifest`] (the JSONL schema), [`cameras`] (orbit and explicit views),
//! [`shard`] (which lines a process renders), [`runner`] (jobs to files, resume, results).

pub mod cameras;
pub mod manifest;
pub mod runner;
pub mod shard;

use std::path::Path;
use std::time::{Duration, Instant};

use crate::accel::bvh::BvhBuild;
use crate::accel::{Backend, BackendChoice};
use crate::render::passes::draw_list::{self, Draw};
use crate::render::passes::raster_compute::RasterMode;
use crate::render::{
    BuildTimes, FrameTargets, RenderOutput, RenderPath, RenderSettings, Renderer, SamplerKind,
};
use crate::scene::{Camera, LoadOptions, Scene};
use crate::vk::{Context, ContextOptions, DeviceSelector, VkError, DEFAULT_FENCE_TIMEOUT};

/// How to open the batch device.
#[derive(Clone, Debug)]
pub struct DeviceOptions {
    /// Which device (see `rqr probe`; cluster rules are applied by the caller).
    pub device: DeviceSelector,
    /// Ray backend; `Auto` as the autotune cache decides.
    pub backend: BackendChoice,
    /// Fence timeout of each submission.
    pub fence_timeout: Duration,
    /// Directory of the on-disk pipeline cache (`None`: no cache kept).
    pub pipeline_cache_dir: Option<std::path::PathBuf>,
    /// Khronos validation layer; `None`: on when `RQR_VALIDATION=1`.
    pub validation: Option<bool>,
    /// Resolve `auto` choices by measurement on first use of a device ([`crate::device_select::autotune`],
    /// cached on disk); `false`: by the feature rules, measuring nothing.
    pub autotune: bool,
}

impl Default for DeviceOptions {
    fn default() -> Self {
        Self {
            device: DeviceSelector::Auto,
            backend: BackendChoice::Auto,
            fence_timeout: DEFAULT_FENCE_TIMEOUT,
            pipeline_cache_dir: None,
            autotune: true,
            validation: None,
        }
    }
}

/// One opened device with its resolved backend, kept for every scene of the process:
/// pipelines are built once and reused by every job.
pub struct BatchDevice {
    ctx: Context,
    backend: Backend,
    bvh_build: BvhBuild,
    raster: RasterMode,
    options: DeviceOptions,
}

/// Wall-clock milliseconds of getting a scene ready.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct SceneTimes {
    /// Reading and parsing the file, texture decoding included.
    pub load_ms: f64,
    /// Decoding images (part of `load_ms`).
    pub texture_decode_ms: f64,
    /// Upload and acceleration-structure / BVH build.
    pub build: BuildTimes,
}

/// What one view should look like.
#[derive(Clone, Debug)]
pub struct ViewOptions {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Samples per pixel (Halton placement above 1).
    pub spp: u32,
    /// Rendering path.
    pub mode: RenderPath,
    /// Also read back the primary-hit AOVs ([`RenderOutput::aov`]).
    pub aovs: bool,
}

impl Default for ViewOptions {
    fn default() -> Self {
        Self {
            width: 512,
            height: 512,
            spp: 1,
            mode: RenderPath::RayTraced,
            aovs: false,
        }
    }
}

impl ViewOptions {
    /// The render settings of these views (the defaults of `rqr render` otherwise).
    pub fn settings(&self) -> RenderSettings {
        RenderSettings {
            width: self.width,
            height: self.height,
            spp: self.spp,
            sampler: match self.spp {
                1 => SamplerKind::Center,
                _ => SamplerKind::Halton,
            },
            ..Default::default()
        }
    }
}

/// A loaded, uploaded scene with its acceleration structures: render any number of cameras
/// from it. Drop it to free its device memory.
pub struct LoadedScene {
    /// The host scene (bounds, cameras, materials).
    pub scene: Scene,
    renderer: Renderer,
    draws: Vec<Draw>,
    /// How long loading and building took.
    pub times: SceneTimes,
}

impl BatchDevice {
    /// Opens the device and resolves the backend once.
    pub fn open(options: &DeviceOptions) -> crate::Result<Self> {
        let mut ctx = Context::new(&ContextOptions {
            device: options.device.clone(),
            validation: options.validation,
            sync_validation: None,
            fence_timeout: options.fence_timeout,
        })?;
        if let Some(dir) = &options.pipeline_cache_dir {
            // A cache that cannot be used costs compile time, not correctness.
            if let Err(e) = ctx.use_pipeline_cache_dir(dir) {
                log::warn!("pipeline cache in '{}' unavailable: {e}", dir.display());
            }
        }
        let decision = match options.autotune {
            true => crate::device_select::autotune::decision(&ctx),
            false => crate::device_select::autotune::rule(ctx.info(), "autotune off"),
        };
        let backend = match options.backend {
            BackendChoice::Auto => decision.backend,
            choice => choice.resolve(ctx.info())?.0,
        };
        Ok(Self {
            ctx,
            backend,
            bvh_build: decision.bvh_build,
            raster: decision.raster,
            options: options.clone(),
        })
    }

    /// Closes the device and opens it again (after a lost device or a submission that never
    /// finished); every [`LoadedScene`] of the old device must be dropped first.
    pub fn reopen(&mut self) -> crate::Result<()> {
        let fresh = Self::open(&self.options)?;
        *self = fresh;
        Ok(())
    }

    /// The Vulkan context.
    pub fn context(&self) -> &Context {
        &self.ctx
    }

    /// Mutable context (fence timeout).
    pub fn context_mut(&mut self) -> &mut Context {
        &mut self.ctx
    }

    /// The ray backend in use.
    pub fn backend(&self) -> Backend {
        self.backend
    }

    /// The fence timeout the device was opened with.
    pub fn default_fence_timeout(&self) -> Duration {
        self.options.fence_timeout
    }

    /// Loads a glTF file and uploads it.
    pub fn load_scene(&self, path: &Path) -> crate::Result<LoadedScene> {
        let start = Instant::now();
        let (scene, decode_ms) = crate::scene::load_timed(path, &LoadOptions::default())?;
        let load_ms = start.elapsed().as_secs_f64() * 1e3;
        self.upload(scene, load_ms, decode_ms)
    }

    /// Uploads a scene loaded elsewhere; `load_ms` and `decode_ms` are recorded in its times.
    pub fn upload(&self, scene: Scene, load_ms: f64, decode_ms: f64) -> crate::Result<LoadedScene> {
        // Skinned or morphed scenes render in their bind pose at t = 0, as `rqr render` does.
        let scene = match scene.is_animated() {
            true => {
                let animations = scene.select_animations(&Default::default())?;
                scene.posed(&animations, 0.0)
            }
            false => scene,
        };
        let (renderer, build) =
            Renderer::with_build_times(&self.ctx, &scene, self.backend, self.bvh_build)?;
        Ok(LoadedScene {
            draws: draw_list::draws(&scene),
            scene,
            renderer,
            times: SceneTimes {
                load_ms,
                texture_decode_ms: decode_ms,
                build,
            },
        })
    }
}

/// One rendered view and how long its stages took.
pub struct RenderedView {
    /// The image (tonemapped RGBA8, linear RGBA32F, AOVs when asked for) and its GPU pass
    /// times.
    pub output: RenderOutput,
    /// GPU milliseconds of the frame (sum of its passes, from GPU timestamps).
    pub gpu_ms: f64,
    /// Host milliseconds reading it back.
    pub readback_ms: f64,
    /// Host milliseconds from submission to readback done.
    pub wall_ms: f64,
}

impl std::ops::Deref for RenderedView {
    type Target = RenderOutput;
    fn deref(&self) -> &RenderOutput {
        &self.output
    }
}

impl LoadedScene {
    /// Lights the scene with `map` (prepared through the on-disk cache), or with none.
    pub fn set_environment(
        &mut self,
        device: &BatchDevice,
        map: Option<&crate::environment::EnvironmentMap>,
    ) -> crate::Result<Option<crate::environment::gpu::PrepareTiming>> {
        let Some(map) = map else {
            self.renderer.set_environment(&device.ctx, None)?;
            return Ok(None);
        };
        let env = crate::environment::GpuEnvironment::prepare_with_user_cache(&device.ctx, map)?;
        let timing = env.timing;
        self.renderer.set_environment(&device.ctx, Some(env))?;
        Ok(Some(timing))
    }

    /// Lights the scene with an environment prepared earlier (for another scene of the same
    /// device, handed back by [`Self::take_environment`]): no map to load, no preparation.
    pub fn set_prepared_environment(
        &mut self,
        device: &BatchDevice,
        environment: crate::environment::GpuEnvironment,
    ) -> crate::Result<()> {
        self.renderer
            .set_environment(&device.ctx, Some(environment))
    }

    /// Removes the scene's environment and hands it back, to light the next scene of the same
    /// device with it ([`Self::set_prepared_environment`]).
    pub fn take_environment(
        &mut self,
        device: &BatchDevice,
    ) -> crate::Result<Option<crate::environment::GpuEnvironment>> {
        self.renderer.take_environment(&device.ctx)
    }

    /// `n` orbit cameras around the scene (see [`cameras::Orbit`]).
    pub fn orbit(
        &self,
        n: u32,
        elevation_deg: [f32; 2],
        fov_y_deg: f32,
        seed: u64,
        aspect: f32,
    ) -> Vec<Camera> {
        let orbit = cameras::Orbit {
            n,
            elevation_deg,
            fov_y_deg,
            seed,
        };
        cameras::orbit_cameras(&orbit, &self.scene.bounds, aspect)
    }

    /// Renders every camera, handing each view to `each` as soon as it is read back (so the
    /// caller can encode view k while view k + 1 renders). Render targets are allocated
    /// once for all the cameras. With a `deadline`, submissions time out at it and no view
    /// starts after it.
    pub fn render_each(
        &self,
        device: &BatchDevice,
        cameras: &[Camera],
        options: &ViewOptions,
        deadline: Option<Instant>,
        mut each: impl FnMut(usize, RenderedView) -> crate::Result<()>,
    ) -> crate::Result<()> {
        let ctx = &device.ctx;
        let settings = RenderSettings {
            raster: device.raster,
            ..options.settings()
        };
        settings.validate(ctx.info().max_image_dimension_2d)?;
        let mut targets = FrameTargets::new(
            ctx,
            &self.renderer,
            options.mode,
            &settings,
            &self.draws,
            options.aovs,
        )?;
        for (k, camera) in cameras.iter().enumerate() {
            if let Some(d) = deadline {
                if Instant::now() >= d {
                    return Err(VkError::Timeout {
                        pass: format!("view {k} (job time limit reached)"),
                        timeout_ms: 0,
                    }
                    .into());
                }
            }
            let start = Instant::now();
            let output = targets.render(ctx, camera)?;
            let view = RenderedView {
                gpu_ms: output.total_ms(),
                readback_ms: targets.last_readback_ms(),
                wall_ms: start.elapsed().as_secs_f64() * 1e3,
                output,
            };
            each(k, view)?;
        }
        Ok(())
    }

    /// Renders every camera into memory.
    pub fn render_views(
        &self,
        device: &BatchDevice,
        cameras: &[Camera],
        options: &ViewOptions,
    ) -> crate::Result<Vec<RenderedView>> {
        let mut views = Vec::with_capacity(cameras.len());
        self.render_each(device, cameras, options, None, |_, v| {
            views.push(v);
            Ok(())
        })?;
        Ok(views)
    }
}
