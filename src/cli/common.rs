//! Arguments shared by the rendering commands, and the steps they share: loading the scene,
//! opening the device, choosing the camera, checking outputs before any GPU work.

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{bail, Context as _, Result};
use clap::Args;
use glam::Vec3;
use rqr::accel::bvh::{BvhBuild, BvhBuildChoice};
use rqr::accel::{Backend, BackendChoice};
use rqr::environment::{EnvironmentMap, EnvironmentSource, GpuEnvironment};
use rqr::render::denoise::DenoiseMode;
use rqr::render::passes::gbuffer::GbufferLayout;
use rqr::render::passes::raster_compute::{RasterChoice, RasterMode};
use rqr::render::{FilterKind, RenderSettings, SamplerKind, Shading, Tonemap};
use rqr::scene::{AnimationSelection, Camera, LoadOptions, Scene, TextureFormat};
use rqr::vk::{Context, ContextOptions, DeviceSelector};

use super::usage;

/// Largest image side accepted before a device is opened (the device limit is checked after).
pub const MAX_SIDE: u32 = 16384;

/// Scene selection.
#[derive(Args, Debug, Clone)]
pub struct SceneArgs {
    /// glTF 2.0 file (.gltf or .glb); omitted: the built-in Cornell-style scene.
    pub scene: Option<PathBuf>,
    /// Scene index inside the file (default: the file's default scene, else 0).
    #[arg(long = "scene")]
    pub scene_index: Option<usize>,
    /// KHR_materials_variants variant to render (`rqr info` lists them); default: the
    /// file's default materials.
    #[arg(long, value_name = "NAME")]
    pub variant: Option<String>,
    /// Animation to play: index, name, `all` (every animation at once) or `none` (rest
    /// pose); default: the file's first animation.
    #[arg(long, value_name = "N|NAME|all|none")]
    pub animation: Option<AnimationSelection>,
    /// Pose animated scenes at T seconds (default 0; sequences sample frame k at k/--fps).
    #[arg(long, value_name = "T")]
    pub time: Option<f32>,
    /// How KTX2 (KHR_texture_basisu) textures reach the GPU: `block` transcodes them to BC7
    /// (else ASTC 4x4) where the device samples it, else RGBA8; `rgba8` uploads the RGBA8
    /// decoded at load (four times the memory, but faster to sample on CPU devices); `auto`
    /// the faster of the two on this device, measured once per device and driver (`rqr
    /// probe` shows the numbers).
    #[arg(long, value_enum, default_value_t = TextureFormat::Auto)]
    pub texture_format: TextureFormat,
}

impl SceneArgs {
    /// Loads the scene, posed at `--time` (default 0) of the chosen animations when it is
    /// animated, skinned or morphed.
    pub fn load(&self) -> Result<Scene> {
        let (scene, animations) = self.load_rest()?;
        if !scene.is_animated() {
            return Ok(scene);
        }
        Ok(scene.posed(&animations, self.time.unwrap_or(0.0)))
    }

    /// Loads the scene in its rest pose, with the indices of the animations `--animation`
    /// selects (see [`Scene::posed`]).
    pub fn load_rest(&self) -> Result<(Scene, Vec<usize>)> {
        if let Some(t) = self.time {
            if !t.is_finite() {
                usage!("--time", "--time {t} must be a finite number of seconds");
            }
        }
        let scene = self.load_file()?;
        let animations = scene.select_animations(&self.animation.clone().unwrap_or_default())?;
        Ok((scene, animations))
    }

    fn load_file(&self) -> Result<Scene> {
        match &self.scene {
            None => {
                if self.scene_index.is_some_and(|i| i > 0) {
                    usage!("--scene", "--scene: the built-in scene has only scene 0");
                }
                if let Some(v) = &self.variant {
                    usage!(
                        "--variant",
                        "--variant {v}: the built-in scene has no material variants"
                    );
                }
                Ok(rqr::scene::load_default()?)
            }
            Some(path) => Ok(rqr::scene::load(
                path,
                &LoadOptions {
                    scene: self.scene_index,
                    variant: self.variant.clone(),
                    texture_format: self.texture_format,
                    ..Default::default()
                },
            )?),
        }
    }

    /// Resolves `--texture-format` on the opened device and applies it to `scenes` (one
    /// file's scenes: its rest pose, posed copies): RGBA8 drops their KTX2 files, so the
    /// upload takes the RGBA8 levels decoded at load; the block format keeps them. `auto`
    /// asks the autotune measurement ([`rqr::device_select::autotune`]) only where a scene has KTX2
    /// images; `None` when there was nothing to decide. Returns the format and why.
    pub fn apply_texture_format(
        &self,
        ctx: &Context,
        scenes: &mut [&mut Scene],
    ) -> Option<(TextureFormat, String)> {
        let ktx2 = scenes.iter().any(|s| s.ktx2_image_count() > 0);
        let (format, reason) = match self.texture_format {
            TextureFormat::Auto if !ktx2 => return None,
            TextureFormat::Auto => {
                let d = rqr::device_select::autotune::decision(ctx);
                (d.texture_format, d.texture_format_reason)
            }
            TextureFormat::Block => match rqr::scene::textures::block_format_name(ctx.info()) {
                Some(name) => (
                    TextureFormat::Block,
                    format!("forced by --texture-format block ({name})"),
                ),
                None => (
                    TextureFormat::Rgba8,
                    "--texture-format block, but the device samples no block format: RGBA8".into(),
                ),
            },
            TextureFormat::Rgba8 => (
                TextureFormat::Rgba8,
                "forced by --texture-format rgba8".into(),
            ),
        };
        if format == TextureFormat::Rgba8 {
            for scene in scenes.iter_mut() {
                scene.drop_ktx2_files();
            }
        }
        log::info!("KTX2 textures: {} ({reason})", format.as_str());
        Some((format, reason))
    }

    /// A short name for reports.
    pub fn name(&self) -> String {
        self.scene
            .as_ref()
            .map(|p| p.display().to_string())
            .unwrap_or_else(|| "built-in".into())
    }
}

/// Device and backend selection.
#[derive(Args, Debug, Clone)]
pub struct DeviceArgs {
    /// Vulkan device: auto, index, name substring or uuid:GPU-… (see `rqr probe`); under
    /// auto, CUDA_VISIBLE_DEVICES / NVIDIA_VISIBLE_DEVICES pick it (docs/batch.md).
    #[arg(long, default_value = "auto")]
    pub device: DeviceSelector,
    /// Ray backend: hardware ray queries, the compute-shader BVH, or auto.
    #[arg(long, value_enum, default_value_t = BackendChoice::Auto)]
    pub backend: BackendChoice,
    /// Where the compute BVH (`--backend bvh`) is built: on the host, in compute shaders, or
    /// auto (GPU build on discrete/integrated GPUs, host build on CPU devices like lavapipe).
    #[arg(long, value_enum, default_value_t = BvhBuildChoice::Auto)]
    pub bvh_build: BvhBuildChoice,
    /// GPU fence timeout per submission, in milliseconds.
    #[arg(long, default_value_t = 120_000, value_parser = clap::value_parser!(u64).range(1..))]
    pub timeout_ms: u64,
}

impl DeviceArgs {
    /// Opens the device (validation per `RQR_VALIDATION`); under `--device auto`,
    /// `CUDA_VISIBLE_DEVICES` / `NVIDIA_VISIBLE_DEVICES` choose it ([`rqr::device_select`]).
    pub fn open(&self) -> Result<Context> {
        let device =
            rqr::device_select::resolve(&self.device).map_err(anyhow::Error::from_boxed)?;
        Ok(Context::new(&ContextOptions {
            device,
            validation: None,
            sync_validation: None,
            fence_timeout: Duration::from_millis(self.timeout_ms),
        })?)
    }

    /// Resolves `--bvh-build` on the opened device: `auto` by measurement.
    pub fn bvh_build(&self, ctx: &Context) -> BvhBuild {
        let (build, reason) = if self.bvh_build == BvhBuildChoice::Auto {
            let d = rqr::device_select::autotune::decision(ctx);
            (d.bvh_build, d.bvh_build_reason)
        } else {
            self.bvh_build.resolve(ctx.info())
        };
        log::info!("BVH build: {} ({reason})", build.as_str());
        build
    }

    /// Resolves `--backend` on the opened device: `auto` by measurement ([`rqr::device_select::autotune`]).
    pub fn backend(&self, ctx: &Context) -> Result<(Backend, String)> {
        if self.backend == BackendChoice::Auto {
            let d = rqr::device_select::autotune::decision(ctx);
            return Ok((d.backend, d.backend_reason));
        }
        Ok(self.backend.resolve(ctx.info())?)
    }
}

fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>().map_err(|e| format!("'{p}': {e}")))
        .collect::<Result<_, _>>()?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(Vec3::new(*x, *y, *z)),
        [c] if c.is_finite() => Ok(Vec3::splat(*c)),
        _ => Err(format!("expected x,y,z (or one value), got '{s}'")),
    }
}

/// Camera selection and overrides.
#[derive(Args, Debug, Clone)]
pub struct CameraArgs {
    /// glTF camera index (default: the first camera, else an automatic camera).
    #[arg(long)]
    pub camera: Option<usize>,
    /// Camera position override, x,y,z.
    #[arg(long, value_parser = parse_vec3)]
    pub look_from: Option<Vec3>,
    /// Look-at point override, x,y,z.
    #[arg(long, value_parser = parse_vec3)]
    pub look_at: Option<Vec3>,
    /// Vertical field of view override, degrees.
    #[arg(long)]
    pub fov: Option<f32>,
}

impl CameraArgs {
    /// The camera for an image of `aspect`.
    pub fn resolve(&self, scene: &Scene, aspect: f32) -> Result<Camera> {
        let base = match self.camera {
            Some(i) => match scene.cameras.get(i) {
                Some(c) => *c,
                None => usage!(
                    "--camera",
                    "--camera {i}: the scene has {} camera(s)",
                    scene.cameras.len()
                ),
            },
            None => scene
                .cameras
                .first()
                .copied()
                .unwrap_or_else(|| rqr::scene::auto_camera(&scene.bounds, aspect)),
        };
        if let Some(fov) = self.fov {
            if !(fov > 0.0 && fov < 180.0) {
                usage!("--fov", "--fov {fov} must be in (0, 180) degrees");
            }
        }
        if self.look_from.is_none() && self.look_at.is_none() && self.fov.is_none() {
            return Ok(base);
        }
        let from = self
            .look_from
            .unwrap_or(base.camera_to_world.w_axis.truncate());
        let forward = -base.camera_to_world.z_axis.truncate();
        let at = self.look_at.unwrap_or(from + forward);
        if (at - from).length() < 1e-6 {
            usage!(
                "--look-from",
                "--look-from and --look-at are the same point"
            );
        }
        let yfov = match (self.fov, base.projection) {
            (Some(f), _) => f.to_radians(),
            (None, rqr::scene::Projection::Perspective { yfov, .. }) => yfov,
            (None, _) => 45f32.to_radians(),
        };
        Ok(rqr::scene::look_at_camera(from, at, Vec3::Y, yfov))
    }
}

fn parse_environment(s: &str) -> Result<EnvironmentSource, String> {
    EnvironmentSource::parse(s).map_err(|e| match e {
        rqr::environment::EnvironmentError::Argument { message, .. } => message,
        other => other.to_string(),
    })
}

/// A finite number ≥ 0 (`--light-radius`).
fn parse_non_negative(s: &str) -> std::result::Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        Ok(v) => Err(format!("{v} must be a finite number >= 0")),
        Err(e) => Err(format!("'{s}' is not a number: {e}")),
    }
}

/// An angle in degrees in [0, 90) (`--sun-angle`).
fn parse_sun_angle(s: &str) -> std::result::Result<f32, String> {
    let v = parse_non_negative(s)?;
    if v >= 90.0 {
        return Err(format!("{v} degrees must be below 90"));
    }
    Ok(v)
}

impl ImageArgs {
    /// Applies `--light-radius` and `--sun-angle` to `scene`'s lights (they override the
    /// sizes the file gave).
    pub fn apply_light_sizes(&self, scene: &mut Scene) {
        for light in &mut scene.lights {
            match light.kind {
                rqr::scene::LightKind::Directional => {
                    if let Some(deg) = self.sun_angle {
                        light.size = deg.to_radians();
                    }
                }
                _ => {
                    if let Some(r) = self.light_radius {
                        light.size = r;
                    }
                }
            }
        }
    }

    /// Loads `--environment`'s map before any device work (a bad file fails fast); `None`
    /// also when the flag was not given ([`ImageArgs::light_scene`] then chooses).
    pub fn load_environment(&self) -> Result<Option<EnvironmentMap>> {
        match &self.environment {
            Some(source) => Ok(source.load()?),
            None => Ok(None),
        }
    }

    /// What lights `scene`: `--environment` when given, else the built-in
    /// [`rqr::environment::default_environment`] for a scene without lights of its own, else
    /// none (the file's lights).
    pub fn environment_source(&self, scene: &Scene) -> EnvironmentSource {
        match &self.environment {
            Some(source) => source.clone(),
            None if scene.default_lights => rqr::environment::default_environment(),
            None => EnvironmentSource::None,
        }
    }

    /// Lights `scene` for its environment ([`ImageArgs::environment_source`]): drops the
    /// default rig under one, adds the sky's sun, and returns the map (`loaded`: what
    /// [`ImageArgs::load_environment`] gave for an explicit `--environment`).
    pub fn light_scene(
        &self,
        scene: &mut Scene,
        loaded: Option<EnvironmentMap>,
    ) -> Result<Option<EnvironmentMap>> {
        let source = self.environment_source(scene);
        let map = match (&self.environment, loaded) {
            (Some(_), map) => map,
            (None, _) => source.load()?,
        };
        source.light_scene(scene, self.environment_rotation, self.environment_intensity)?;
        Ok(map)
    }
}

/// Prepares `map` on the device and lights `renderer` with it; returns how long the
/// preparation took.
pub fn light_with(
    ctx: &Context,
    renderer: &mut rqr::render::Renderer,
    map: Option<&EnvironmentMap>,
) -> Result<Option<rqr::environment::gpu::PrepareTiming>> {
    let Some(map) = map else {
        return Ok(None);
    };
    let env = prepare_environment(ctx, map)?;
    let timing = env.timing;
    renderer.set_environment(ctx, Some(env))?;
    Ok(Some(timing))
}

/// Prepares `map` through the on-disk cache (`RQR_CACHE_DIR` or the user's cache folder).
pub fn prepare_environment(ctx: &Context, map: &EnvironmentMap) -> Result<GpuEnvironment> {
    let env = GpuEnvironment::prepare_with_user_cache(ctx, map)?;
    let t = env.timing;
    log::info!(
        "environment {}x{} prepared in {:.1} ms{}",
        map.width,
        map.height,
        t.total_ms,
        if t.cached { " (from the cache)" } else { "" }
    );
    Ok(env)
}

fn parse_background(s: &str) -> Result<(Vec3, bool), String> {
    if s.eq_ignore_ascii_case("sky") {
        return Ok((Vec3::ONE, true));
    }
    if let Some(rest) = s.strip_prefix("sky:") {
        return parse_vec3(rest).map(|v| (v, true));
    }
    parse_vec3(s).map(|v| (v, false))
}

/// Image and Whitted settings shared by `render` and `compare`.
#[derive(Args, Debug, Clone)]
pub struct ImageArgs {
    /// Image width in pixels.
    #[arg(long, default_value_t = 512)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 512)]
    pub height: u32,
    /// Samples per pixel (grid and jitter need a square number).
    #[arg(long, default_value_t = 1)]
    pub spp: u32,
    /// Sub-pixel sample placement [default: center; sobol with --denoise, so that every frame
    /// jitters anew and accumulated frames anti-alias].
    #[arg(long, value_enum)]
    pub sampler: Option<SamplerKind>,
    /// Reconstruction filter.
    #[arg(long, value_enum, default_value_t = FilterKind::Box)]
    pub filter: FilterKind,
    /// Maximum ray segments per path (1 = primary + shadow rays).
    #[arg(long, default_value_t = 5)]
    pub max_depth: u32,
    /// Stop a path when its weight's largest channel falls below this.
    #[arg(long, default_value_t = 0.05)]
    pub min_weight: f32,
    /// Ray offset along the geometric normal (default: 1e-4 × scene diagonal).
    #[arg(long)]
    pub epsilon: Option<f32>,
    /// Ambient radiance: r,g,b or one value.
    #[arg(long, value_parser = parse_vec3, default_value = "0.03")]
    pub ambient: Vec3,
    /// Background: r,g,b, one value, `sky`, or `sky:r,g,b` (scaled gradient) [default:
    /// 0.05]. With `--environment`, what camera rays that miss see instead of the map (the
    /// map still lights the scene).
    #[arg(long, value_parser = parse_background)]
    pub background: Option<(Vec3, bool)>,
    /// Image-based lighting: an equirectangular Radiance `.hdr` or OpenEXR file (width = 2 ×
    /// height, row 0 at the zenith, +Z at its centre), `sky[:ELEVATION_DEG,AZIMUTH_DEG[,
    /// TURBIDITY]]` (the Hosek-Wilkie sky and its sun; `sky` alone: 45,150,3), or `none` (the
    /// default light rig and --ambient) [default: a built-in environment for a scene
    /// without lights, none for a scene with lights].
    #[arg(long, value_parser = parse_environment, value_name = "PATH|sky[:E,A[,T]]|studio|none")]
    pub environment: Option<EnvironmentSource>,
    /// Turns the environment about +Y, degrees counter-clockwise seen from above.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub environment_rotation: f32,
    /// Scales the environment's radiance.
    #[arg(long, default_value_t = 1.0)]
    pub environment_intensity: f32,
    /// Adaptive sampler: subdivide where two samples differ by more than this.
    #[arg(long, default_value_t = 0.1)]
    pub adaptive_threshold: f32,
    /// Adaptive sampler: maximum subdivision levels.
    #[arg(long, default_value_t = 2)]
    pub adaptive_depth: u32,
    /// Tonemapping operator for PNG output.
    #[arg(long, value_enum, default_value_t = Tonemap::KhronosNeutral)]
    pub tonemap: Tonemap,
    /// Exposure in EV stops.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub exposure: f32,
    /// Seed of the random samplers.
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// Shading model: `whitted` (hard shadows, perfect mirrors, deterministic) or
    /// `distributed` (soft shadows from lights with a size, glossy reflection, rough
    /// transmission, shadowed environment light; noisy, converges with --spp).
    #[arg(long, value_enum, default_value_t = Shading::Whitted)]
    pub shading: Shading,
    /// Distributed shading: diffuse bounces per path (0: direct light only on diffuse
    /// surfaces, Cook's model; N: a path tracer with Russian roulette).
    #[arg(long, default_value_t = 0)]
    pub diffuse_bounces: u32,
    /// Distributed shading: trace a diffuse ray where the diffuse bounces are spent even in a
    /// scene without emissive triangles (where light sampling alone estimates that lobe, at
    /// less cost, by default). Both estimators converge to the same image.
    #[arg(long)]
    pub trace_spent_diffuse: bool,
    /// Distributed shading: denoise each frame before tonemapping: `temporal` (accumulate the
    /// demodulated light on the reprojected history) or `svgf` (that, then an edge-aware
    /// à-trous filter; a single frame gets the filter alone).
    #[arg(long, value_enum, default_value_t = DenoiseMode::None)]
    pub denoise: DenoiseMode,
    /// Denoising: frames of history a pixel keeps at most.
    #[arg(long, default_value_t = rqr::render::denoise::DEFAULT_HISTORY_CAP, value_name = "N")]
    pub history_cap: u32,
    /// Distributed shading: radius of every point and spot light's sphere, in scene units
    /// (overrides the lights' glTF `extras.radius`; 0 = punctual).
    #[arg(long, value_name = "R", value_parser = parse_non_negative)]
    pub light_radius: Option<f32>,
    /// Distributed shading: angular radius of every directional light, in degrees
    /// (overrides `extras.angularRadius`; 0 = punctual; the sun is about 0.27).
    #[arg(long, value_name = "DEG", value_parser = parse_sun_angle)]
    pub sun_angle: Option<f32>,
    /// Hybrid path: what the raster pass writes (`visibility`: instance + primitive, the
    /// material is evaluated in the shading pass; `full`: the classic 7-attachment G-buffer).
    #[arg(long, value_enum, default_value_t = GbufferLayout::Visibility)]
    pub gbuffer: GbufferLayout,
    /// Hybrid path: what rasterizes primary visibility (`graphics` pipeline, `compute`
    /// rasterizer, or `auto`: the faster one as measured on first use of the device).
    #[arg(long, value_enum, default_value_t = RasterChoice::Auto)]
    pub raster: RasterChoice,
}

impl ImageArgs {
    /// Resolves `--raster` on the opened device: `auto` by measurement.
    pub fn raster(&self, ctx: &Context) -> (RasterMode, String) {
        match self.raster.forced() {
            Some(mode) => (mode, format!("forced by --raster {}", mode.as_str())),
            None => {
                let d = rqr::device_select::autotune::decision(ctx);
                (d.raster, d.raster_reason)
            }
        }
    }
    /// Render settings; ranges are checked here, before any GPU work.
    pub fn settings(&self) -> Result<RenderSettings> {
        let s = RenderSettings {
            width: self.width,
            height: self.height,
            spp: self.spp,
            sampler: self.sampler.unwrap_or(if self.denoise.enabled() {
                SamplerKind::Sobol
            } else {
                SamplerKind::Center
            }),
            filter: self.filter,
            max_depth: self.max_depth,
            min_weight: self.min_weight,
            epsilon: self.epsilon,
            ambient: self.ambient,
            background: self.background.map_or(Vec3::splat(0.05), |b| b.0),
            sky: self.background.is_some_and(|b| b.1),
            environment_background: self.background.is_none(),
            environment_rotation: self.environment_rotation,
            environment_intensity: self.environment_intensity,
            adaptive_threshold: self.adaptive_threshold,
            adaptive_depth: self.adaptive_depth,
            no_specular: false,
            seed: self.seed,
            tonemap: self.tonemap,
            exposure: self.exposure,
            gbuffer: self.gbuffer,
            // Resolved on the opened device (ImageArgs::raster).
            raster: Default::default(),
            shading: self.shading,
            diffuse_bounces: self.diffuse_bounces,
            trace_spent_diffuse: self.trace_spent_diffuse,
            denoise: self.denoise,
            history_cap: self.history_cap,
        };
        s.validate(MAX_SIDE)?;
        Ok(s)
    }
}

/// Fails the command when the validation layer (`RQR_VALIDATION=1`) reported errors.
pub fn check_validation(ctx: &Context) -> Result<()> {
    let errors = ctx.validation_errors();
    if !errors.is_empty() {
        bail!(
            "{} Vulkan validation error(s); first: {}",
            errors.len(),
            errors[0]
        );
    }
    Ok(())
}

/// Fails early when `path` cannot be written: missing directory, a directory, read-only.
pub fn check_output_file(path: &Path) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        bail!("output directory '{}' does not exist", dir.display());
    }
    if path.is_dir() {
        bail!("output '{}' is a directory", path.display());
    }
    let existed = path.exists();
    std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .with_context(|| format!("cannot write '{}'", path.display()))?;
    if !existed {
        let _ = std::fs::remove_file(path);
    }
    Ok(())
}
