//! Render settings (`RenderSettings` and its enums), their limits and validation, and the
//! rendering path.

use glam::Vec3;

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
    /// Whether sample k's position depends on k alone, so that numbering samples through a
    /// sequence (k = frame × spp + j) keeps them well spread (not grid and jitter, whose
    /// strata are sized by spp, nor the adaptive sampler).
    pub fn sequence_indexed(self) -> bool {
        matches!(self, Self::Halton | Self::Sobol | Self::Bluenoise)
    }

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

/// Shading model (`--shading`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Shading {
    /// Whitted (1980): hard shadows from punctual lights, perfect mirror and refraction rays,
    /// rough surfaces fading their mirror term; deterministic.
    #[default]
    Whitted,
    /// Distributed ray tracing (Cook 1984): lights with a size, every lobe sampled (glossy
    /// reflection, rough transmission), shadowed environment light, multiple importance
    /// sampling; noisy at low spp, converging to the reference.
    Distributed,
}

impl Shading {
    /// The `--shading` name.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Whitted => "whitted",
            Self::Distributed => "distributed",
        }
    }
}

/// Largest `--diffuse-bounces`.
pub const MAX_DIFFUSE_BOUNCES: u32 = 16;

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
    /// Camera rays that miss show the environment, when the renderer has one (false when
    /// `--background` was given: a product shot on white, lit by the environment).
    pub environment_background: bool,
    /// Rotation of the environment about +Y in degrees, counter-clockwise seen from above.
    pub environment_rotation: f32,
    /// Scale of the environment's radiance.
    pub environment_intensity: f32,
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
    pub gbuffer: super::passes::gbuffer::GbufferLayout,
    /// What runs the hybrid path's visibility pass.
    pub raster: super::passes::raster_compute::RasterMode,
    /// Shading model.
    pub shading: Shading,
    /// Distributed model: diffuse bounces a path may take (0: direct light only on diffuse
    /// surfaces, as in Cook's model; more: a path tracer with Russian roulette).
    pub diffuse_bounces: u32,
    /// Distributed model: where a vertex's diffuse bounces are spent, still trace the diffuse
    /// lobe's ray (it collects the emission, lights and environment it meets, weighted against
    /// light sampling) even in a scene without emissive triangles, where light sampling alone
    /// estimates that lobe by default at less cost. Both converge to one image; scenes with
    /// emissive triangles always trace it (nothing else finds their light).
    pub trace_spent_diffuse: bool,
    /// Denoiser run on each distributed frame before tonemapping.
    pub denoise: super::denoise::DenoiseMode,
    /// Frames of history a denoised pixel keeps at most (its blend weight's floor is the
    /// inverse).
    pub history_cap: u32,
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
            environment_background: true,
            environment_rotation: 0.0,
            environment_intensity: 1.0,
            adaptive_threshold: 0.1,
            adaptive_depth: 2,
            no_specular: false,
            seed: 0,
            tonemap: Tonemap::default(),
            exposure: 0.0,
            gbuffer: Default::default(),
            raster: Default::default(),
            shading: Shading::Whitted,
            diffuse_bounces: 0,
            trace_spent_diffuse: false,
            denoise: super::denoise::DenoiseMode::None,
            history_cap: super::denoise::DEFAULT_HISTORY_CAP,
        }
    }
}

/// Largest `--max-depth` (the shader's path stack holds `MAX_DEPTH + 4` rays).
pub const MAX_DEPTH: u32 = 16;
/// Largest `--spp`.
pub const MAX_SPP: u32 = 4096;
/// Largest `--adaptive-depth`.
pub const MAX_ADAPTIVE_DEPTH: u32 = 4;

/// A setting the user (or a library caller) chose that cannot work, named by the flag that
/// holds it; found before any GPU work. A usage mistake, not a device failure: the command line
/// exits with code 2 on it, like on the errors its parser reports. A setting the device cannot
/// serve (too large for its memory, say) is a [`crate::vk::VkError::Limit`] instead.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("invalid settings: {reason}")]
pub struct SettingsError {
    /// The flag at fault as the command line spells it (`--spp`), the first of them when a
    /// combination is wrong; the field's name for settings no flag sets.
    pub field: &'static str,
    /// What is wrong, naming the flag and its value, and what would work.
    pub reason: String,
}

impl SettingsError {
    /// A [`SettingsError`] for `field`.
    pub fn new(field: &'static str, reason: impl Into<String>) -> Self {
        Self {
            field,
            reason: reason.into(),
        }
    }
}

impl RenderSettings {
    /// Checks ranges; `max_dimension` is the largest image side allowed (rqr's own limit
    /// before a device is open, the device's `maxImageDimension2D` after).
    pub fn validate(&self, max_dimension: u32) -> Result<(), SettingsError> {
        let bad = |field: &'static str, m: String| Err(SettingsError::new(field, m));
        if self.width == 0 || self.height == 0 {
            let (flag, value) = if self.width == 0 {
                ("--width", self.width)
            } else {
                ("--height", self.height)
            };
            return bad(
                flag,
                format!(
                    "{flag} {value}: resolution {}x{} must be at least 1x1",
                    self.width, self.height
                ),
            );
        }
        if self.width > max_dimension || self.height > max_dimension {
            let (flag, value) = if self.width > max_dimension {
                ("--width", self.width)
            } else {
                ("--height", self.height)
            };
            return bad(
                flag,
                format!(
                    "{flag} {value}: resolution {}x{} exceeds the limit of {max_dimension} pixels per side",
                    self.width, self.height
                ),
            );
        }
        if self.spp == 0 || self.spp > MAX_SPP {
            return bad(
                "--spp",
                format!("--spp {} must be in 1..={MAX_SPP}", self.spp),
            );
        }
        if matches!(self.sampler, SamplerKind::Grid | SamplerKind::Jitter) {
            let k = (self.spp as f64).sqrt().round() as u32;
            if k * k != self.spp {
                return bad(
                    "--sampler",
                    format!(
                        "--sampler {:?} needs a square --spp (1, 4, 9, 16, …), got {}",
                        self.sampler, self.spp
                    )
                    .to_lowercase(),
                );
            }
        }
        if self.max_depth == 0 || self.max_depth > MAX_DEPTH {
            return bad(
                "--max-depth",
                format!("--max-depth {} must be in 1..={MAX_DEPTH}", self.max_depth),
            );
        }
        if !(0.0..1.0).contains(&self.min_weight) {
            return bad(
                "--min-weight",
                format!("--min-weight {} must be in [0, 1)", self.min_weight),
            );
        }
        if self.adaptive_depth > MAX_ADAPTIVE_DEPTH {
            return bad(
                "--adaptive-depth",
                format!(
                    "--adaptive-depth {} must be at most {MAX_ADAPTIVE_DEPTH}",
                    self.adaptive_depth
                ),
            );
        }
        if !self.exposure.is_finite() {
            return bad(
                "--exposure",
                format!("--exposure {} must be finite", self.exposure),
            );
        }
        if !self.environment_rotation.is_finite() {
            return bad(
                "--environment-rotation",
                format!(
                    "--environment-rotation {} must be finite",
                    self.environment_rotation
                ),
            );
        }
        if !(self.environment_intensity.is_finite() && self.environment_intensity >= 0.0) {
            return bad(
                "--environment-intensity",
                format!(
                    "--environment-intensity {} must be a finite non-negative number",
                    self.environment_intensity
                ),
            );
        }
        if !(self.adaptive_threshold.is_finite() && self.adaptive_threshold >= 0.0) {
            return bad(
                "--adaptive-threshold",
                format!(
                    "--adaptive-threshold {} must be a finite non-negative number",
                    self.adaptive_threshold
                ),
            );
        }
        if self.shading == Shading::Distributed && self.sampler == SamplerKind::Adaptive {
            return bad(
                "--sampler",
                "--sampler adaptive subdivides where samples differ, and every sample of \
                 --shading distributed differs (noise): use sobol, halton or another sampler"
                    .into(),
            );
        }
        if self.diffuse_bounces > MAX_DIFFUSE_BOUNCES {
            return bad(
                "--diffuse-bounces",
                format!(
                    "--diffuse-bounces {} must be at most {MAX_DIFFUSE_BOUNCES}",
                    self.diffuse_bounces
                ),
            );
        }
        if self.diffuse_bounces > 0 && self.shading != Shading::Distributed {
            return bad(
"--diffuse-bounces",
                "--diffuse-bounces needs --shading distributed (the Whitted model traces no diffuse rays)"
                    .into(),
            );
        }
        if self.denoise.enabled() && self.shading != Shading::Distributed {
            return bad("--denoise", format!(
                "--denoise {} needs --shading distributed (the Whitted model has no noise to filter)",
                self.denoise.as_str()
            ));
        }
        if self.history_cap == 0 || self.history_cap > super::denoise::MAX_HISTORY_CAP {
            return bad(
                "--history-cap",
                format!(
                    "--history-cap {} must be in 1..={}",
                    self.history_cap,
                    super::denoise::MAX_HISTORY_CAP
                ),
            );
        }
        if let Some(e) = self.epsilon {
            if !(e.is_finite() && e >= 0.0) {
                return bad(
                    "--epsilon",
                    format!("--epsilon {e} must be a finite non-negative number"),
                );
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Every mistake [`RenderSettings::validate`] finds names the flag it reports in its
    /// message, and the flag is the one at fault.
    #[test]
    fn settings_errors_name_their_flag() {
        let base = RenderSettings::default();
        let cases: Vec<(RenderSettings, &str)> = vec![
            (
                RenderSettings {
                    width: 0,
                    ..base.clone()
                },
                "--width",
            ),
            (
                RenderSettings {
                    height: 0,
                    ..base.clone()
                },
                "--height",
            ),
            (
                RenderSettings {
                    height: 20_000,
                    ..base.clone()
                },
                "--height",
            ),
            (
                RenderSettings {
                    spp: 0,
                    ..base.clone()
                },
                "--spp",
            ),
            (
                RenderSettings {
                    sampler: SamplerKind::Grid,
                    spp: 3,
                    ..base.clone()
                },
                "--sampler",
            ),
            (
                RenderSettings {
                    max_depth: 99,
                    ..base.clone()
                },
                "--max-depth",
            ),
            (
                RenderSettings {
                    min_weight: 1.5,
                    ..base.clone()
                },
                "--min-weight",
            ),
            (
                RenderSettings {
                    exposure: f32::NAN,
                    ..base.clone()
                },
                "--exposure",
            ),
            (
                RenderSettings {
                    diffuse_bounces: 1,
                    ..base.clone()
                },
                "--diffuse-bounces",
            ),
            (
                RenderSettings {
                    epsilon: Some(-1.0),
                    ..base.clone()
                },
                "--epsilon",
            ),
        ];
        for (settings, flag) in cases {
            let e = settings.validate(16384).expect_err(flag);
            assert_eq!(e.field, flag, "{e}");
            assert!(e.reason.contains(flag), "{e}");
            assert!(e.to_string().starts_with("invalid settings: "), "{e}");
        }
        assert!(base.validate(16384).is_ok());
    }
}
