//! What a sequence reports: per-frame records, the comparison with full renders, and the
//! summary over frames (means, spreads of the GPU time per pass).

use serde::Serialize;

use crate::render::image::metrics::ImageDiff;
use crate::render::settings::RenderPath;
use crate::render::temporal::{PixelSource, ReuseOptions, ReuseStats};
use crate::render::{RayCounts, RenderOutput};
use crate::scene::Camera;

/// How a sequence renders its frames.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SequenceOptions {
    /// Rendering path.
    pub path: RenderPath,
    /// Reuse between frames (none: every frame is a full render).
    pub reuse: ReuseOptions,
    /// Also render every frame in full and compare (`--reference`).
    pub reference: bool,
}

/// A full render of the same frame and how the frame compares with it.
#[derive(Clone, Debug, Serialize)]
pub struct ReferenceComparison {
    /// Rays of the full render.
    pub rays: RayCounts,
    /// Rays of the frame / rays of the full render.
    pub ray_fraction: f64,
    /// FLIP and PSNR of the frame against the full render.
    pub diff: ImageDiff,
    /// The full render's GPU milliseconds.
    pub total_gpu_ms: f64,
}

/// One rendered frame of a sequence.
pub struct SequenceFrame {
    /// Global frame number.
    pub index: u32,
    /// The frame's camera.
    pub camera: Camera,
    /// The image and its rays and pass times.
    pub output: RenderOutput,
    /// Where each pixel's colour came from.
    pub sources: Vec<PixelSource>,
    /// Pixel counts.
    pub stats: ReuseStats,
    /// Comparison with a full render (with [`SequenceOptions::reference`]).
    pub reference: Option<ReferenceComparison>,
    /// The full render itself (with [`SequenceOptions::reference`]).
    pub reference_output: Option<RenderOutput>,
    /// GPU milliseconds of the whole frame, first command to last (passes, the stages
    /// between them and barriers; `output.gpu_ms` has the passes).
    pub frame_gpu_ms: f64,
    /// Whether the frame could reuse an earlier frame's samples (false for the first frame
    /// of a range and for sequences without reuse).
    pub reused_history: bool,
}

impl SequenceFrame {
    /// The per-frame record of `--json` and of reports (no pixels).
    pub fn summary(&self) -> FrameSummary {
        FrameSummary {
            frame: self.index,
            camera_position: self.camera.position().to_array(),
            camera_forward: self.camera.forward().to_array(),
            rays: self.output.rays,
            rays_total: self.output.rays.total(),
            reuse: self.stats,
            reused_fraction: self.stats.reused_fraction(),
            traced_fraction: self.stats.traced_fraction(),
            interpolated_fraction: self.stats.interpolated_fraction(),
            gpu_ms: self.output.gpu_ms.clone(),
            total_gpu_ms: self.frame_gpu_ms,
            reused_history: self.reused_history,
            reference: self.reference.as_ref().map(|r| ReferenceSummary {
                rays_total: r.rays.total(),
                ray_fraction: r.ray_fraction,
                flip_mean: r.diff.flip_mean,
                flip_p95: r.diff.flip_p95,
                flip_max: r.diff.flip_max,
                psnr_db: r.diff.psnr_db,
                total_gpu_ms: r.total_gpu_ms,
            }),
        }
    }
}

/// Reference numbers of a [`FrameSummary`].
#[derive(Clone, Debug, Serialize)]
pub struct ReferenceSummary {
    /// Rays of the full render.
    pub rays_total: u64,
    /// Rays of the frame / rays of the full render.
    pub ray_fraction: f64,
    /// Mean FLIP against the full render.
    pub flip_mean: f32,
    /// 95th percentile FLIP.
    pub flip_p95: f32,
    /// Largest FLIP.
    pub flip_max: f32,
    /// PSNR in dB (infinite, written as null, when identical).
    pub psnr_db: f64,
    /// The full render's GPU milliseconds.
    pub total_gpu_ms: f64,
}

/// Statistics of one frame (what `rqr render --json` prints per frame).
#[derive(Clone, Debug, Serialize)]
pub struct FrameSummary {
    /// Global frame number.
    pub frame: u32,
    /// Camera position.
    pub camera_position: [f32; 3],
    /// Camera view direction.
    pub camera_forward: [f32; 3],
    /// Rays traced by kind (verification rays included in `primary`).
    pub rays: RayCounts,
    /// All rays.
    pub rays_total: u64,
    /// Pixel counts.
    pub reuse: ReuseStats,
    /// Share of reused pixels.
    pub reused_fraction: f64,
    /// Share of traced pixels.
    pub traced_fraction: f64,
    /// Share of interpolated pixels.
    pub interpolated_fraction: f64,
    /// GPU milliseconds per pass.
    pub gpu_ms: Vec<(String, f64)>,
    /// GPU milliseconds of the whole frame (passes, stages between them, barriers).
    pub total_gpu_ms: f64,
    /// Whether the frame could reuse an earlier frame's samples.
    pub reused_history: bool,
    /// Against the full render, when requested.
    pub reference: Option<ReferenceSummary>,
}

/// Means over the frames of a sequence.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SequenceSummary {
    /// Frames.
    pub frames: usize,
    /// Mean rays per frame.
    pub mean_rays: f64,
    /// Mean share of reused pixels.
    pub mean_reused_fraction: f64,
    /// Mean share of traced pixels.
    pub mean_traced_fraction: f64,
    /// Mean share of interpolated pixels.
    pub mean_interpolated_fraction: f64,
    /// Mean GPU milliseconds per frame.
    pub mean_gpu_ms: f64,
    /// Mean rays of the full renders (with references).
    pub mean_reference_rays: Option<f64>,
    /// Mean of the per-frame ray fractions (with references).
    pub mean_ray_fraction: Option<f64>,
    /// Largest per-frame ray fraction (with references).
    pub max_ray_fraction: Option<f64>,
    /// Mean of the per-frame mean FLIP (with references).
    pub mean_flip: Option<f64>,
    /// Largest per-frame mean FLIP (with references).
    pub max_flip: Option<f64>,
    /// Mean PSNR over frames with a finite PSNR (with references).
    pub mean_psnr_db: Option<f64>,
    /// Mean GPU milliseconds of the full renders (with references).
    pub mean_reference_gpu_ms: Option<f64>,
    /// Median, smallest and largest GPU milliseconds per frame.
    pub frame_gpu_ms: Spread,
    /// Mean GPU milliseconds of the frames that reused an earlier frame's samples (all but a
    /// range's first frame with reuse; `None` without reuse).
    pub mean_reused_frame_gpu_ms: Option<f64>,
    /// Mean GPU time of the reusing frames ÷ mean GPU time of the full renders of the same
    /// frames (with references and reuse).
    pub reused_over_full_gpu_time: Option<f64>,
    /// Per pass: median, smallest and largest GPU milliseconds over the frames that ran it.
    pub passes: Vec<PassSpread>,
}

/// Median, smallest and largest of a set of timings.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Spread {
    /// Median.
    pub median: f64,
    /// Smallest.
    pub min: f64,
    /// Largest.
    pub max: f64,
    /// Mean.
    pub mean: f64,
}

impl Spread {
    /// Of `values` (all zero when empty).
    pub fn of(values: &[f64]) -> Self {
        if values.is_empty() {
            return Self::default();
        }
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        Self {
            median: v[v.len() / 2],
            min: v[0],
            max: v[v.len() - 1],
            mean: v.iter().sum::<f64>() / v.len() as f64,
        }
    }
}

/// GPU time of one named pass over many frames.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PassSpread {
    /// Scope name.
    pub name: String,
    /// Its spread.
    #[serde(flatten)]
    pub ms: Spread,
}

/// Per pass, in first-seen order: the spread of its GPU milliseconds over `frames`.
pub fn pass_spreads<'a>(frames: impl IntoIterator<Item = &'a [(String, f64)]>) -> Vec<PassSpread> {
    let mut names: Vec<String> = Vec::new();
    let mut values: Vec<Vec<f64>> = Vec::new();
    for passes in frames {
        for (name, ms) in passes {
            match names.iter().position(|n| n == name) {
                Some(i) => values[i].push(*ms),
                None => {
                    names.push(name.clone());
                    values.push(vec![*ms]);
                }
            }
        }
    }
    names
        .into_iter()
        .zip(values)
        .map(|(name, v)| PassSpread {
            name,
            ms: Spread::of(&v),
        })
        .collect()
}

impl SequenceSummary {
    /// Means over `frames`.
    pub fn new(frames: &[FrameSummary]) -> Self {
        let n = frames.len();
        if n == 0 {
            return Self::default();
        }
        let mean = |f: &dyn Fn(&FrameSummary) -> f64| frames.iter().map(f).sum::<f64>() / n as f64;
        let refs: Vec<&ReferenceSummary> =
            frames.iter().filter_map(|f| f.reference.as_ref()).collect();
        let rmean = |f: &dyn Fn(&ReferenceSummary) -> f64| {
            (!refs.is_empty()).then(|| refs.iter().map(|r| f(r)).sum::<f64>() / refs.len() as f64)
        };
        let rmax =
            |f: &dyn Fn(&ReferenceSummary) -> f64| refs.iter().map(|r| f(r)).reduce(f64::max);
        let finite: Vec<f64> = refs
            .iter()
            .map(|r| r.psnr_db)
            .filter(|p| p.is_finite())
            .collect();
        Self {
            frames: n,
            mean_rays: mean(&|f| f.rays_total as f64),
            mean_reused_fraction: mean(&|f| f.reused_fraction),
            mean_traced_fraction: mean(&|f| f.traced_fraction),
            mean_interpolated_fraction: mean(&|f| f.interpolated_fraction),
            mean_gpu_ms: mean(&|f| f.total_gpu_ms),
            mean_reference_rays: rmean(&|r| r.rays_total as f64),
            mean_ray_fraction: rmean(&|r| r.ray_fraction),
            max_ray_fraction: rmax(&|r| r.ray_fraction),
            mean_flip: rmean(&|r| f64::from(r.flip_mean)),
            max_flip: rmax(&|r| f64::from(r.flip_mean)),
            mean_psnr_db: (!finite.is_empty())
                .then(|| finite.iter().sum::<f64>() / finite.len() as f64),
            mean_reference_gpu_ms: rmean(&|r| r.total_gpu_ms),
            frame_gpu_ms: Spread::of(&frames.iter().map(|f| f.total_gpu_ms).collect::<Vec<_>>()),
            mean_reused_frame_gpu_ms: reused_mean(frames, |f| f.total_gpu_ms),
            reused_over_full_gpu_time: reused_mean(frames, |f| f.total_gpu_ms)
                .zip(reused_mean(frames, |f| {
                    f.reference.as_ref().map_or(f64::NAN, |r| r.total_gpu_ms)
                }))
                .filter(|(_, full)| full.is_finite() && *full > 0.0)
                .map(|(frame, full)| frame / full),
            passes: pass_spreads(frames.iter().map(|f| f.gpu_ms.as_slice())),
        }
    }
}

/// Mean of `value` over the frames that reused samples (`None` when there are none).
fn reused_mean(frames: &[FrameSummary], value: impl Fn(&FrameSummary) -> f64) -> Option<f64> {
    let v: Vec<f64> = frames
        .iter()
        .filter(|f| f.reused_history)
        .map(value)
        .collect();
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}
