//! Render settings and the `Frame` uniform shared with `shaders/common/frame.glsl`.

use glam::{Mat4, Vec3, Vec4};

use crate::scene::{Camera, Projection};

/// Sub-pixel sample placement (`--sampler`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SamplerKind {
    /// Pixel centres only.
    #[default]
    Center,
    /// Regular √N×√N grid (N must be a square).
    Grid,
    /// Stratified √N×√N grid with a random offset per cell (N must be a square).
    Jitter,
    /// Halton (2,3) with a per-pixel Cranley-Patterson rotation.
    Halton,
    /// Owen-scrambled Sobol (hash-based nested uniform scrambling, Burley 2020).
    Sobol,
    /// R2 sequence offset per pixel by interleaved gradient noise (Jimenez 2014).
    Bluenoise,
    /// The seed's adaptive quincunx supersampling.
    Adaptive,
}

impl SamplerKind {
    /// The shaders' `SAMPLER_*` code.
    pub fn code(self) -> u32 {
        use crate::interface as i;
        match self {
            Self::Center => i::SAMPLER_CENTER,
            Self::Grid => i::SAMPLER_GRID,
            Self::Jitter => i::SAMPLER_JITTER,
            Self::Halton => i::SAMPLER_HALTON,
            Self::Sobol => i::SAMPLER_SOBOL,
            Self::Bluenoise => i::SAMPLER_BLUENOISE,
            Self::Adaptive => i::SAMPLER_ADAPTIVE,
        }
    }
}

/// Pixel reconstruction filter (`--filter`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FilterKind {
    /// Samples inside the pixel, equal weights.
    #[default]
    Box,
    /// Samples within one pixel of the centre, weighted (1-|dx|)(1-|dy|).
    Tent,
}

impl FilterKind {
    /// The shaders' `FILTER_*` code.
    pub fn code(self) -> u32 {
        match self {
            Self::Box => crate::interface::FILTER_BOX,
            Self::Tent => crate::interface::FILTER_TENT,
        }
    }
}

/// Tonemapping operator for PNG output (`--tonemap`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Tonemap {
    /// Clamp only.
    None,
    /// ACES filmic (Narkowicz fit).
    Aces,
    /// Khronos PBR Neutral.
    #[default]
    KhronosNeutral,
}

/// Everything that shapes one rendered image.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RenderSettings {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Samples per pixel (ignored by the adaptive sampler).
    pub spp: u32,
    /// Sample placement.
    pub sampler: SamplerKind,
    /// Reconstruction filter.
    pub filter: FilterKind,
    /// Maximum segments per path (1 = primary + shadow rays only).
    pub max_depth: u32,
    /// Paths stop when their weight's largest channel drops below this.
    pub min_weight: f32,
    /// Ray offset along the geometric normal; `None` = 1e-4 × scene diagonal.
    pub epsilon: Option<f32>,
    /// Ambient radiance (times base colour and occlusion).
    pub ambient: Vec3,
    /// Background radiance (scaled sky gradient when `sky`).
    pub background: Vec3,
    /// Sky gradient instead of a constant background.
    pub sky: bool,
    /// Adaptive sampler: subdivide when two samples differ by more than this (per channel, clamped to 1).
    pub adaptive_threshold: f32,
    /// Adaptive sampler: maximum subdivision levels.
    pub adaptive_depth: u32,
    /// Disable the GGX specular lobe of direct light (for energy tests).
    pub no_specular: bool,
    /// Seed of the random samplers.
    pub seed: u32,
    /// Tonemapping operator for 8-bit output.
    pub tonemap: Tonemap,
    /// Exposure in EV (multiplies by 2^EV before tonemapping).
    pub exposure: f32,
    /// What the hybrid path's raster pass writes.
    pub gbuffer: super::gbuffer::GbufferLayout,
    /// What runs the hybrid path's visibility pass.
    pub raster: super::raster_compute::RasterMode,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width: 512,
            height: 512,
            spp: 1,
            sampler: SamplerKind::Center,
            filter: FilterKind::Box,
            max_depth: 5,
            min_weight: 0.05,
            epsilon: None,
            ambient: Vec3::splat(0.03),
            background: Vec3::splat(0.05),
            sky: false,
            adaptive_threshold: 0.1,
            adaptive_depth: 2,
            no_specular: false,
            seed: 0,
            tonemap: Tonemap::default(),
            exposure: 0.0,
            gbuffer: Default::default(),
            raster: Default::default(),
        }
    }
}

/// Largest `--max-depth` (the shader's path stack holds `MAX_DEPTH + 4` rays).
pub const MAX_DEPTH: u32 = 16;
/// Largest `--spp`.
pub const MAX_SPP: u32 = 4096;
/// Largest `--adaptive-depth`.
pub const MAX_ADAPTIVE_DEPTH: u32 = 4;

/// Invalid settings, found before any GPU work.
#[derive(Debug, thiserror::Error)]
#[error("invalid render settings: {0}")]
pub struct SettingsError(pub String);

impl RenderSettings {
    /// Checks ranges; `max_dimension` is the largest image side allowed (rqr's own limit
    /// before a device is open, the device's `maxImageDimension2D` after).
    pub fn validate(&self, max_dimension: u32) -> Result<(), SettingsError> {
        let bad = |m: String| Err(SettingsError(m));
        if self.width == 0 || self.height == 0 {
            return bad(format!(
                "resolution {}x{} must be at least 1x1",
                self.width, self.height
            ));
        }
        if self.width > max_dimension || self.height > max_dimension {
            return bad(format!(
                "resolution {}x{} exceeds the limit of {max_dimension} pixels per side",
                self.width, self.height
            ));
        }
        if self.spp == 0 || self.spp > MAX_SPP {
            return bad(format!("--spp {} must be in 1..={MAX_SPP}", self.spp));
        }
        if matches!(self.sampler, SamplerKind::Grid | SamplerKind::Jitter) {
            let k = (self.spp as f64).sqrt().round() as u32;
            if k * k != self.spp {
                return bad(format!(
                    "--sampler {:?} needs a square --spp (1, 4, 9, 16, …), got {}",
                    self.sampler, self.spp
                )
                .to_lowercase());
            }
        }
        if self.max_depth == 0 || self.max_depth > MAX_DEPTH {
            return bad(format!(
                "--max-depth {} must be in 1..={MAX_DEPTH}",
                self.max_depth
            ));
        }
        if !(0.0..1.0).contains(&self.min_weight) {
            return bad(format!(
                "--min-weight {} must be in [0, 1)",
                self.min_weight
            ));
        }
        if self.adaptive_depth > MAX_ADAPTIVE_DEPTH {
            return bad(format!(
                "--adaptive-depth {} must be at most {MAX_ADAPTIVE_DEPTH}",
                self.adaptive_depth
            ));
        }
        if !self.exposure.is_finite() {
            return bad(format!("--exposure {} must be finite", self.exposure));
        }
        if !(self.adaptive_threshold.is_finite() && self.adaptive_threshold >= 0.0) {
            return bad(format!(
                "--adaptive-threshold {} must be a finite non-negative number",
                self.adaptive_threshold
            ));
        }
        if let Some(e) = self.epsilon {
            if !(e.is_finite() && e >= 0.0) {
                return bad(format!(
                    "--epsilon {e} must be a finite non-negative number"
                ));
            }
        }
        Ok(())
    }
}

/// Which rendering path (`--mode`; also what memory estimates and frame loops are for).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
pub enum RenderPath {
    /// Pure ray tracing: primary, shadow, reflection and refraction rays.
    #[default]
    #[value(name = "rt")]
    #[serde(rename = "rt")]
    RayTraced,
    /// Raster G-buffer for primary visibility, ray-traced shadows/reflections/refractions.
    #[value(name = "hybrid")]
    #[serde(rename = "hybrid")]
    Hybrid,
}

impl RenderPath {
    /// The `--mode` name (`rt`, `hybrid`).
    pub fn as_str(self) -> &'static str {
        match self {
            Self::RayTraced => "rt",
            Self::Hybrid => "hybrid",
        }
    }

    /// Human-readable name (`ray traced`, `hybrid`).
    pub fn label(self) -> &'static str {
        match self {
            Self::RayTraced => "ray traced",
            Self::Hybrid => "hybrid",
        }
    }
}

/// Bytes per texel of the formats the passes allocate.
fn format_bytes(format: ash::vk::Format) -> u64 {
    use ash::vk::Format;
    match format {
        Format::R32G32B32A32_SFLOAT | Format::R32G32B32A32_UINT => 16,
        Format::R16G16B16A16_SFLOAT | Format::R32G32_UINT => 8,
        _ => 4,
    }
}

/// Bytes of one `vec4` (colour, accumulation and adaptive-corner texels).
const RGBA32F: u64 = 16;
/// Bytes of one pixel's [`super::Aov`].
const AOV_BYTES: u64 = std::mem::size_of::<super::Aov>() as u64;

impl RenderSettings {
    /// Pixels of the image.
    pub fn pixels(&self) -> u64 {
        u64::from(self.width) * u64::from(self.height)
    }

    /// Device memory a render at these settings allocates for its own buffers and images:
    /// colour, adaptive corners and tonemap output (ray-traced), or accumulation, tonemap
    /// output and one G-buffer with depth per sample (hybrid), plus the per-pixel AOVs when
    /// `aov` (without, the passes bind a one-element placeholder). The scene and the ray
    /// backend come on top (see [`crate::accel`]).
    pub fn estimate_bytes(&self, path: RenderPath, aov: bool) -> u64 {
        let pixels = self.pixels();
        let aov = if aov { AOV_BYTES } else { 0 };
        let tonemapped = 4;
        match path {
            RenderPath::RayTraced => {
                let corners = (u64::from(self.width) + 1) * (u64::from(self.height) + 1);
                pixels * (RGBA32F + aov + tonemapped) + corners * RGBA32F
            }
            RenderPath::Hybrid => {
                let gbuffer: u64 = self
                    .gbuffer
                    .formats()
                    .iter()
                    .map(|&f| format_bytes(f))
                    .sum::<u64>()
                    + 4; // D32 depth
                pixels * (RGBA32F + aov + tonemapped)
                    + pixels.saturating_mul(gbuffer * u64::from(self.spp))
            }
        }
    }

    /// The largest buffer a pass binds as one storage buffer, to compare with
    /// `maxStorageBufferRange`: the per-pixel AOVs when `aov`, else the colour (or the
    /// ray-traced path's adaptive corners, one row and column larger).
    pub fn largest_buffer_bytes(&self, aov: bool) -> u64 {
        let corners = (u64::from(self.width) + 1) * (u64::from(self.height) + 1) * RGBA32F;
        let aov = if aov { self.pixels() * AOV_BYTES } else { 0 };
        aov.max(corners)
    }

    /// [`Self::validate`] against the device's image limit, then checks that every per-pixel
    /// buffer (the AOVs only when `aov`) fits `maxStorageBufferRange` and that
    /// [`Self::estimate_bytes`] plus `in_use` bytes fit the largest device-local heap: a
    /// clear error before anything is allocated, instead of an allocation failure or an
    /// invalid descriptor mid-frame.
    pub fn check_device(
        &self,
        info: &crate::vk::DeviceInfo,
        path: RenderPath,
        aov: bool,
        in_use: u64,
    ) -> Result<(), SettingsError> {
        self.validate(info.max_image_dimension_2d)?;
        let mib = |b: u64| b.div_ceil(1 << 20);
        let range = u64::from(info.max_storage_buffer_range);
        let largest = self.largest_buffer_bytes(aov);
        if largest > range {
            // Name the way out: AOVs alone need three times the colour's range.
            let (what, hint) = if aov && self.largest_buffer_bytes(false) <= range {
                (
                    " with AOVs",
                    "lower the resolution or render without AOVs (--aov)",
                )
            } else {
                ("", "lower the resolution")
            };
            return Err(SettingsError(format!(
                "resolution {}x{}{what} needs a {} MiB per-pixel buffer, but '{}' binds at most {} MiB per storage buffer (maxStorageBufferRange); {hint}",
                self.width,
                self.height,
                mib(largest),
                info.name,
                mib(range)
            )));
        }
        let heap = info.largest_device_heap();
        let needed = self.estimate_bytes(path, aov);
        if needed.saturating_add(in_use) > heap {
            return Err(SettingsError(format!(
                "{}x{} at {} spp ({}{}) needs about {} MiB of device memory on top of {} MiB in use, more than the {} MiB device heap of '{}'; lower the resolution{}",
                self.width,
                self.height,
                self.spp,
                match path {
                    RenderPath::RayTraced => "ray traced",
                    RenderPath::Hybrid => "hybrid",
                },
                if aov { ", with AOVs" } else { "" },
                mib(needed),
                mib(in_use),
                mib(heap),
                info.name,
                match path {
                    RenderPath::RayTraced => "",
                    RenderPath::Hybrid => " or --spp (the hybrid path keeps one G-buffer per sample)",
                }
            )));
        }
        Ok(())
    }
}

pub use crate::interface::{
    GpuFrame, FLAG_ADAPTIVE_CORNERS, FLAG_NO_SPECULAR, FLAG_SKY, FLAG_WRITE_AOV,
};

/// Near plane used when the camera has none that fits.
const DEFAULT_ZNEAR: f32 = 0.01;

/// Camera matrices for a render of `width`×`height`.
#[derive(Clone, Copy, Debug)]
pub struct CameraSetup {
    /// Camera to world.
    pub camera_to_world: Mat4,
    /// Projection (Vulkan clip space, y down, depth 0..1).
    pub proj: Mat4,
    /// tan(yfov/2) (perspective).
    pub tan_half_fov_y: f32,
    /// Orthographic half extents, if orthographic.
    pub ortho_half: Option<[f32; 2]>,
}

impl CameraSetup {
    /// Builds the matrices. The render's aspect ratio always wins over the file's; an
    /// orthographic camera keeps its ymag and derives xmag from the aspect.
    pub fn new(camera: &Camera, width: u32, height: u32, scene_scale: f32) -> Self {
        let aspect = width as f32 / height as f32;
        match camera.projection {
            Projection::Perspective {
                yfov, znear, zfar, ..
            } => {
                let t = (yfov * 0.5).tan();
                let zn = if znear > 0.0 { znear } else { DEFAULT_ZNEAR };
                let zf = zfar.unwrap_or(scene_scale.max(1.0) * 100.0).max(zn * 2.0);
                let proj = Mat4::from_cols(
                    Vec4::new(1.0 / (aspect * t), 0.0, 0.0, 0.0),
                    Vec4::new(0.0, -1.0 / t, 0.0, 0.0),
                    Vec4::new(0.0, 0.0, zf / (zn - zf), -1.0),
                    Vec4::new(0.0, 0.0, zn * zf / (zn - zf), 0.0),
                );
                Self {
                    camera_to_world: camera.camera_to_world,
                    proj,
                    tan_half_fov_y: t,
                    ortho_half: None,
                }
            }
            Projection::Orthographic {
                ymag, znear, zfar, ..
            } => {
                let half = [ymag * aspect, ymag];
                let (zn, zf) = (znear, zfar.max(znear + 1e-3));
                let proj = Mat4::from_cols(
                    Vec4::new(1.0 / half[0], 0.0, 0.0, 0.0),
                    Vec4::new(0.0, -1.0 / half[1], 0.0, 0.0),
                    Vec4::new(0.0, 0.0, 1.0 / (zn - zf), 0.0),
                    Vec4::new(0.0, 0.0, zn / (zn - zf), 1.0),
                );
                Self {
                    camera_to_world: camera.camera_to_world,
                    proj,
                    tan_half_fov_y: 1.0,
                    ortho_half: Some(half),
                }
            }
        }
    }

    /// World to camera.
    pub fn view(&self) -> Mat4 {
        self.camera_to_world.inverse()
    }
}

impl GpuFrame {
    /// Fills the uniform for `settings` seen through `camera`.
    pub fn new(settings: &RenderSettings, camera: &CameraSetup, scene_scale: f32) -> Self {
        let view = camera.view();
        let mut flags = 0;
        if settings.no_specular {
            flags |= FLAG_NO_SPECULAR;
        }
        if settings.sky {
            flags |= FLAG_SKY;
        }
        Self {
            camera_to_world: camera.camera_to_world.to_cols_array(),
            view: view.to_cols_array(),
            proj: camera.proj.to_cols_array(),
            view_proj: (camera.proj * view).to_cols_array(),
            prev_view_proj: (camera.proj * view).to_cols_array(),
            jitter: [0.0; 2],
            pad1: [0.0; 2],
            camera_pos: camera.camera_to_world.w_axis.truncate().to_array(),
            tan_half_fov_y: camera.tan_half_fov_y,
            aspect: settings.width as f32 / settings.height as f32,
            ortho: u32::from(camera.ortho_half.is_some()),
            ortho_half: camera.ortho_half.unwrap_or([1.0, 1.0]),
            width: settings.width,
            height: settings.height,
            spp: settings.spp,
            sampler_kind: settings.sampler.code(),
            filter_kind: settings.filter.code(),
            max_depth: settings.max_depth,
            flags,
            seed: settings.seed,
            min_weight: settings.min_weight,
            epsilon: settings.epsilon.unwrap_or(scene_scale * 1e-4),
            adaptive_threshold: settings.adaptive_threshold,
            adaptive_depth: settings.adaptive_depth,
            ambient: settings.ambient.to_array(),
            pixel_spread: if camera.ortho_half.is_some() {
                0.0
            } else {
                (2.0 * camera.tan_half_fov_y / settings.height as f32).atan()
            },
            background: settings.background.to_array(),
            pad0: 0.0,
        }
    }
}
