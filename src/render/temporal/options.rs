//! What the reprojection is asked to do and what it reports: thresholds, [`ReuseOptions`],
//! per-frame [`ReuseStats`] and the counters they are read from.

use serde::Serialize;

use crate::interface::reproject::*;
use crate::render::passes::raytrace::{ray_counts, striped_sum};
use crate::render::settings::{RenderSettings, SamplerKind, SettingsError};
use crate::render::{RayCounts, RenderOutput};

/// Rejection: |dot(cached − new position, new normal)| / view depth above this (ReBLUR, Bevy
/// Solari's `pixel_dissimilar`).
pub const PLANE_DISTANCE_THRESHOLD: f32 = 0.003;
/// Rejection: dot of the cached and new geometric normals below this (cos 25°).
pub const NORMAL_DOT_THRESHOLD: f32 = 0.906;
/// rt path with [`PrimaryRayCheck::Edges`]: a neighbour's sample this far off a sample's plane
/// (relative to the view depth) marks a depth edge.
pub const EDGE_PLANE_THRESHOLD: f32 = 0.01;
/// Metallic at or above this is view-dependent (mirror/metal).
pub const SPECULAR_METALLIC: f32 = 0.5;
/// Roughness below this is view-dependent: the Whitted reflection weight is
/// Fresnel × (1 − roughness)², at least a quarter of Fresnel below 0.5.
pub const SPECULAR_ROUGHNESS: f32 = 0.5;
/// An empty pixel (no sample projected into it) takes a neighbour's sample whose projection
/// lies within this many pixels of its centre, then goes through the visibility tests like
/// any other sample.
pub const FILL_RADIUS: f32 = 1.0;
/// Fills copy only samples whose colour was traced where they are (0 hops); a fill's copy
/// and an interpolated colour count one hop, so a colour is never more than one fill radius
/// from where it was computed (copying copies lets sub-pixel errors add up: FLIP 0.035 →
/// 0.047 over a 30-frame orbit with 3 hops).
pub const MAX_FILL_HOPS: u32 = 1;
/// Default `--subsample-threshold`.
pub const DEFAULT_SUBSAMPLE_THRESHOLD: f32 = 0.05;

/// Checks that `settings` sample the way reuse between frames caches samples: one sample per
/// pixel, at its centre. The one statement of the rule: [`super::Reprojector::new`] and the
/// command line both check it.
pub fn check_sampling(settings: &RenderSettings) -> Result<(), SettingsError> {
    if settings.spp != 1 || settings.sampler != SamplerKind::Center {
        return Err(SettingsError::new(
            if settings.spp != 1 { "--spp" } else { "--sampler" },
            "--reproject, --frameless and --adaptive-subsample cache one sample per pixel: use --spp 1 --sampler center",
        ));
    }
    Ok(())
}

/// Which primary rays the pure ray-traced path spends on checking reprojected samples (the
/// hybrid path always checks every pixel against its raster G-buffer, which costs no rays).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PrimaryRayCheck {
    /// One primary ray per reprojected sample: exact, but a primary ray per pixel per frame.
    Full,
    /// Primary rays only where the reprojected samples form a depth edge or border a hole;
    /// elsewhere the reprojected sample is its own visibility (nearest of the scattered
    /// samples). A hidden surface can only appear next to such an edge.
    #[default]
    Edges,
}

/// What a sequence may reuse between frames.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ReuseOptions {
    /// Reproject the previous frame's samples (`--reproject`).
    pub reproject: bool,
    /// Re-trace at least this share of the pixels per frame, in percent (`--frameless`);
    /// implies `reproject`.
    pub frameless_percent: Option<f32>,
    /// Adaptive sub-sampling of the pixels that need new colour (`--adaptive-subsample`).
    pub adaptive_subsample: bool,
    /// Interpolate a block when its samples differ by at most this: the largest channel
    /// difference of the colours as displayed (x / (1 + x), then a square root).
    pub subsample_threshold: f32,
    /// Re-trace samples older than this many frames (`None`: no limit).
    pub max_age: Option<u32>,
    /// `--rt-visibility`: which reprojected samples the rt path's verify pass spends primary
    /// rays on.
    pub rt_visibility: PrimaryRayCheck,
    /// Keep each frame's linear colour (EXR output) besides its display pixels. Off, the
    /// passes write only the display pixels: one word per pixel instead of five (the
    /// colours adaptive sub-sampling interpolates between are in the next cache anyway).
    pub linear_color: bool,
    /// The scene's geometry moves between frames (animated transforms, skins, morph
    /// targets): samples keep anchors (16 bytes per pixel, in each of two buffers) and move
    /// with their objects. The anchors are allocated with the cache, and checked with it
    /// before anything is allocated ([`super::Reprojector::check_device`]).
    pub moving_geometry: bool,
}

impl Default for ReuseOptions {
    fn default() -> Self {
        Self {
            reproject: false,
            frameless_percent: None,
            adaptive_subsample: false,
            subsample_threshold: DEFAULT_SUBSAMPLE_THRESHOLD,
            max_age: None,
            rt_visibility: PrimaryRayCheck::Edges,
            linear_color: true,
            moving_geometry: false,
        }
    }
}

impl ReuseOptions {
    /// Whether samples are carried between frames.
    pub fn reuses(&self) -> bool {
        self.reproject || self.frameless_percent.is_some()
    }

    /// Whether any of the options changes how a frame is rendered.
    pub fn any(&self) -> bool {
        self.reuses() || self.adaptive_subsample
    }

    /// Checks ranges.
    pub fn validate(&self) -> Result<(), SettingsError> {
        if let Some(p) = self.frameless_percent {
            if !(p > 0.0 && p <= 100.0) {
                return Err(SettingsError::new(
                    "--frameless",
                    format!("--frameless {p} must be a percentage in (0, 100]"),
                ));
            }
        }
        if let Some(k) = self.max_age {
            if k > MAX_CACHE_AGE {
                return Err(SettingsError::new(
                    "--max-age",
                    format!(
                        "--max-age {k} must be at most {MAX_CACHE_AGE} (cached samples count their age in 10 bits)"
                    ),
                ));
            }
        }
        if !(self.subsample_threshold.is_finite() && self.subsample_threshold >= 0.0) {
            return Err(SettingsError::new(
                "--subsample-threshold",
                format!(
                    "--subsample-threshold {} must be a finite non-negative number",
                    self.subsample_threshold
                ),
            ));
        }
        Ok(())
    }
}

/// Where a pixel's colour came from this frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PixelSource {
    /// A reprojected sample of an earlier frame.
    Reused,
    /// Traced this frame.
    Traced,
    /// Interpolated by adaptive sub-sampling.
    Interpolated,
}

/// Per-frame reuse statistics (pixel counts).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct ReuseStats {
    /// Pixels in the image.
    pub pixels: u64,
    /// Pixels showing a reprojected sample.
    pub reused: u64,
    /// Pixels traced this frame.
    pub traced: u64,
    /// Pixels interpolated this frame.
    pub interpolated: u64,
    /// Reused pixels that no sample landed on, showing a neighbour's sample that projects
    /// within [`FILL_RADIUS`] pixels of their centre (see `shaders/temporal/temporal_shown.comp`'s `fill`).
    pub filled: u64,
    /// Pixels no sample landed on (first frame, disocclusions, screen edges).
    pub holes: u64,
    /// Samples rejected by the primary-visibility test.
    pub rejected: u64,
    /// Pixels re-traced because the sample or the surface is view-dependent.
    pub view_dependent: u64,
    /// Samples re-traced for being older than `max_age`.
    pub expired: u64,
    /// Samples re-traced by the frameless refresh.
    pub frameless: u64,
    /// Primary rays of the rt path's verify pass (included in the primary ray count):
    /// checks of reprojected samples.
    pub verify_rays: u64,
}

impl ReuseStats {
    /// Share of reused pixels.
    pub fn reused_fraction(&self) -> f64 {
        self.reused as f64 / self.pixels.max(1) as f64
    }
    /// Share of traced pixels.
    pub fn traced_fraction(&self) -> f64 {
        self.traced as f64 / self.pixels.max(1) as f64
    }
    /// Share of interpolated pixels.
    pub fn interpolated_fraction(&self) -> f64 {
        self.interpolated as f64 / self.pixels.max(1) as f64
    }
}

/// One frame rendered with reuse.
pub struct ReprojectedFrame {
    /// The image, rays and pass times (no AOVs).
    pub output: RenderOutput,
    /// Where each pixel's colour came from (row 0 = top).
    pub sources: Vec<PixelSource>,
    /// Pixel counts.
    pub stats: ReuseStats,
}

/// Rays, samples and pixel statistics from a reprojected frame's counters.
pub(super) fn counts(c: &[u32], pixels: u64) -> (RayCounts, u64, ReuseStats) {
    // A statistic is the sum of its stripes, which start after the shared slots and are laid out
    // as the full frame's ray counters (interface/mod.rs checks), rays and samples first.
    let stats = c.get(COUNTER_STRIPE_WORDS as usize..).unwrap_or(&[]);
    let count = |i: u32| striped_sum(stats, i);
    let (rays, samples) = ray_counts(stats);
    (
        rays,
        samples,
        ReuseStats {
            pixels,
            reused: count(C_REUSED),
            traced: count(C_TRACED),
            interpolated: count(C_INTERP),
            filled: count(C_FILLED),
            holes: count(C_HOLES),
            rejected: count(C_REJECTED),
            view_dependent: count(C_VIEW_DEPENDENT),
            expired: count(C_EXPIRED),
            frameless: count(C_FRAMELESS),
            verify_rays: count(C_VERIFY_RAYS),
        },
    )
}
