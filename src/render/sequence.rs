//! Camera sequences (issue #7): camera paths (orbit, dolly, glTF camera animation) and the
//! driver that renders frame after frame, with or without reuse between frames
//! ([`super::reproject`]), and optionally compares each frame with a full render.
//!
//! Frame numbers are global: frame `k` of a path is the same camera whichever range is
//! rendered, so a scheduler can spread a sequence over machines. The sample cache starts
//! empty at the first frame of every range (and whenever frames are not rendered in order),
//! so a range's first frame is a full render and a range never depends on frames before it.

use std::path::Path;
use std::str::FromStr;

use glam::{Mat4, Quat, Vec3};
use serde::Serialize;

use super::compare::{self, ImageDiff};
use super::gbuffer::{self, Draw};
use super::reproject::{
    PixelSource, RenderPath, ReprojectedFrame, Reprojector, ReuseOptions, ReuseStats,
};
use super::targets::{FrameRing, FrameTargets, RingContents};
use super::{merge_scopes, RayCounts, RenderOutput, RenderSettings, Renderer};
use crate::scene::{Camera, Scene};
use crate::vk::{Context, FrameTiming, GpuProfiler, VkError};

/// A camera path as written on the command line (`--camera-path`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum CameraPathSpec {
    /// The camera does not move.
    Static,
    /// Rotate about the vertical axis (world +Y) through the pivot, degrees per frame.
    Orbit(f32),
    /// Move along the view direction, scene units per frame.
    Dolly(f32),
    /// The glTF file's animation of the camera node.
    Gltf,
}

impl FromStr for CameraPathSpec {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let number = |v: &str, what: &str| -> Result<f32, String> {
            match v.trim().parse::<f32>() {
                Ok(x) if x.is_finite() => Ok(x),
                _ => Err(format!("{what} '{v}' is not a finite number")),
            }
        };
        match s.split_once(':') {
            Some(("orbit", v)) => Ok(Self::Orbit(number(v, "orbit: degrees per frame")?)),
            Some(("dolly", v)) => Ok(Self::Dolly(number(v, "dolly: distance per frame")?)),
            None if s == "gltf" => Ok(Self::Gltf),
            None if s == "static" => Ok(Self::Static),
            _ => Err(format!(
                "unknown camera path '{s}': expected orbit:DEG_PER_FRAME, dolly:DIST_PER_FRAME, gltf or static"
            )),
        }
    }
}

impl std::fmt::Display for CameraPathSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Static => write!(f, "static"),
            Self::Orbit(d) => write!(f, "orbit:{d}"),
            Self::Dolly(d) => write!(f, "dolly:{d}"),
            Self::Gltf => write!(f, "gltf"),
        }
    }
}

/// A camera path resolved against a scene: the camera of every frame number.
#[derive(Clone, Debug, PartialEq)]
pub enum CameraPath {
    /// The base camera in every frame.
    Static,
    /// Frame k: the base camera rotated by k × `degrees_per_frame` about the vertical line
    /// through `pivot` (position and orientation turn together).
    Orbit {
        /// Degrees per frame (positive: counter-clockwise seen from above).
        degrees_per_frame: f32,
        /// A point on the rotation axis.
        pivot: Vec3,
    },
    /// Frame k: the base camera moved k × `distance_per_frame` along its view direction.
    Dolly {
        /// Scene units per frame.
        distance_per_frame: f32,
    },
    /// The glTF animation of the camera's node, sampled at `frame / fps` seconds.
    Animation(Box<CameraAnimation>),
}

impl CameraPath {
    /// The camera of frame `frame`; `base` is frame 0's camera of orbit, dolly and static paths.
    pub fn camera(&self, base: &Camera, frame: u32) -> Camera {
        let k = frame as f32;
        match self {
            Self::Static => *base,
            Self::Orbit {
                degrees_per_frame,
                pivot,
            } => {
                let turn = Mat4::from_translation(*pivot)
                    * Mat4::from_rotation_y((degrees_per_frame * k).to_radians())
                    * Mat4::from_translation(-*pivot);
                Camera {
                    camera_to_world: turn * base.camera_to_world,
                    projection: base.projection,
                }
            }
            Self::Dolly { distance_per_frame } => Camera {
                camera_to_world: Mat4::from_translation(base.forward() * distance_per_frame * k)
                    * base.camera_to_world,
                projection: base.projection,
            },
            Self::Animation(a) => a.camera(base, frame),
        }
    }
}

/// Why a glTF camera animation could not be read.
#[derive(Debug, thiserror::Error)]
#[error("camera path gltf: {0}")]
pub struct CameraAnimationError(pub String);

/// Keyframes of one animation property.
#[derive(Clone, Debug, PartialEq)]
enum Track<T> {
    Linear(Vec<f32>, Vec<T>),
    Step(Vec<f32>, Vec<T>),
    /// Per key: in-tangent, value, out-tangent.
    Cubic(Vec<f32>, Vec<[T; 3]>),
}

trait Keyframe: Copy {
    fn lerp(a: Self, b: Self, t: f32) -> Self;
    fn hermite(v0: Self, out0: Self, v1: Self, in1: Self, dt: f32, t: f32) -> Self;
}

impl Keyframe for Vec3 {
    fn lerp(a: Self, b: Self, t: f32) -> Self {
        a.lerp(b, t)
    }
    fn hermite(v0: Self, out0: Self, v1: Self, in1: Self, dt: f32, t: f32) -> Self {
        let (t2, t3) = (t * t, t * t * t);
        v0 * (2.0 * t3 - 3.0 * t2 + 1.0)
            + out0 * dt * (t3 - 2.0 * t2 + t)
            + v1 * (-2.0 * t3 + 3.0 * t2)
            + in1 * dt * (t3 - t2)
    }
}

impl Keyframe for Quat {
    fn lerp(a: Self, b: Self, t: f32) -> Self {
        a.slerp(b, t)
    }
    fn hermite(v0: Self, out0: Self, v1: Self, in1: Self, dt: f32, t: f32) -> Self {
        let (t2, t3) = (t * t, t * t * t);
        let v = glam::Vec4::from(v0) * (2.0 * t3 - 3.0 * t2 + 1.0)
            + glam::Vec4::from(out0) * dt * (t3 - 2.0 * t2 + t)
            + glam::Vec4::from(v1) * (-2.0 * t3 + 3.0 * t2)
            + glam::Vec4::from(in1) * dt * (t3 - t2);
        Quat::from_vec4(v).normalize()
    }
}

impl<T: Keyframe> Track<T> {
    /// glTF sampling: clamped to the first and last key.
    fn sample(&self, time: f32) -> Option<T> {
        let times = match self {
            Self::Linear(t, _) | Self::Step(t, _) | Self::Cubic(t, _) => t,
        };
        let last = times.len().checked_sub(1)?;
        let i = times.partition_point(|&k| k <= time);
        let (a, b, u) = if i == 0 {
            (0, 0, 0.0)
        } else if i > last {
            (last, last, 0.0)
        } else {
            let dt = times[i] - times[i - 1];
            (
                i - 1,
                i,
                if dt > 0.0 {
                    (time - times[i - 1]) / dt
                } else {
                    0.0
                },
            )
        };
        Some(match self {
            Self::Linear(_, v) => T::lerp(*v.get(a)?, *v.get(b)?, u),
            Self::Step(_, v) => *v.get(a)?,
            Self::Cubic(t, v) => {
                let (ka, kb) = (v.get(a)?, v.get(b)?);
                if a == b {
                    ka[1]
                } else {
                    T::hermite(ka[1], ka[2], kb[1], kb[0], t[b] - t[a], u)
                }
            }
        })
    }
}

/// The translation/rotation animation of a glTF camera node (channels on the node itself;
/// its parents are taken as static, at their rest pose).
#[derive(Clone, Debug, PartialEq)]
pub struct CameraAnimation {
    parent_world: Mat4,
    rest: (Vec3, Quat, Vec3),
    translation: Option<Track<Vec3>>,
    rotation: Option<Track<Quat>>,
    /// Frames per second: frame k samples the animation at k / fps seconds.
    pub fps: f32,
}

impl CameraAnimation {
    /// Reads the animation of camera `camera` (the scene's camera index, as in
    /// [`Scene::cameras`]) in scene `scene` (default: the file's default scene, else 0) of a
    /// `.gltf`/`.glb` file.
    pub fn load(
        path: &Path,
        scene: Option<usize>,
        camera: usize,
        fps: f32,
    ) -> Result<Self, CameraAnimationError> {
        let err = |m: String| CameraAnimationError(format!("{}: {m}", path.display()));
        if !(fps.is_finite() && fps > 0.0) {
            return Err(CameraAnimationError(format!(
                "--fps {fps} must be a positive number"
            )));
        }
        let gltf = gltf::Gltf::open(path).map_err(|e| err(e.to_string()))?;
        let doc = &gltf.document;
        let chosen = match scene {
            Some(i) => doc.scenes().nth(i),
            None => doc.default_scene().or_else(|| doc.scenes().next()),
        }
        .ok_or_else(|| err("the file has no such scene".into()))?;
        // The loader's camera order: camera nodes reached from the scene, by node index.
        let mut cameras: Vec<(usize, Mat4)> = Vec::new();
        let mut stack: Vec<(gltf::Node, Mat4)> =
            chosen.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
        let mut visits = 0usize;
        while let Some((node, parent)) = stack.pop() {
            visits += 1;
            if visits > crate::scene::MAX_INSTANCES {
                return Err(err("the node hierarchy is too large".into()));
            }
            if node.camera().is_some() {
                cameras.push((node.index(), parent));
            }
            let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
            stack.extend(node.children().map(|c| (c, world)));
        }
        cameras.sort_by_key(|c| c.0);
        let &(node_index, parent_world) = cameras.get(camera).ok_or_else(|| {
            err(format!(
                "camera {camera} does not exist ({} cameras)",
                cameras.len()
            ))
        })?;
        let node = doc
            .nodes()
            .nth(node_index)
            .ok_or_else(|| err("camera node missing".into()))?;
        let (t, r, s) = node.transform().decomposed();
        let buffers = gltf::import_buffers(doc, path.parent(), gltf.blob.clone())
            .map_err(|e| err(e.to_string()))?;
        let mut translation = None;
        let mut rotation = None;
        for animation in doc.animations() {
            for channel in animation.channels() {
                if channel.target().node().index() != node_index {
                    continue;
                }
                let reader = channel.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
                let times: Vec<f32> = reader
                    .read_inputs()
                    .ok_or_else(|| err("animation sampler without input times".into()))?
                    .collect();
                let interpolation = channel.sampler().interpolation();
                let outputs = reader
                    .read_outputs()
                    .ok_or_else(|| err("animation sampler without outputs".into()))?;
                use gltf::animation::util::ReadOutputs;
                match outputs {
                    ReadOutputs::Translations(v) if translation.is_none() => {
                        let v: Vec<Vec3> = v.map(Vec3::from).collect();
                        translation = Some(track(interpolation, times, v).map_err(err)?);
                    }
                    ReadOutputs::Rotations(v) if rotation.is_none() => {
                        let v: Vec<Quat> = v.into_f32().map(Quat::from_array).collect();
                        rotation = Some(track(interpolation, times, v).map_err(err)?);
                    }
                    _ => {}
                }
            }
        }
        if translation.is_none() && rotation.is_none() {
            return Err(err(format!(
                "scene has no camera animation (no translation or rotation channel targets camera {camera}'s node {node_index})"
            )));
        }
        Ok(Self {
            parent_world,
            rest: (Vec3::from(t), Quat::from_array(r), Vec3::from(s)),
            translation,
            rotation,
            fps,
        })
    }

    /// The camera of frame `frame` (projection from `base`).
    pub fn camera(&self, base: &Camera, frame: u32) -> Camera {
        let time = frame as f32 / self.fps;
        let (t, r, s) = self.rest;
        let t = self
            .translation
            .as_ref()
            .and_then(|k| k.sample(time))
            .unwrap_or(t);
        let r = self
            .rotation
            .as_ref()
            .and_then(|k| k.sample(time))
            .unwrap_or(r);
        let mut world =
            self.parent_world * Mat4::from_scale_rotation_translation(s, r.normalize(), t);
        if !world.is_finite() {
            // Degenerate keys (a zero quaternion): keep the node's rest pose.
            let (t, r, s) = self.rest;
            world = self.parent_world * Mat4::from_scale_rotation_translation(s, r.normalize(), t);
        }
        Camera {
            camera_to_world: crate::scene::camera::camera_pose(world),
            projection: base.projection,
        }
    }
}

fn track<T: Copy>(
    interpolation: gltf::animation::Interpolation,
    times: Vec<f32>,
    values: Vec<T>,
) -> Result<Track<T>, String> {
    use gltf::animation::Interpolation;
    let bad = || {
        format!(
            "animation has {} keys and {} values",
            times.len(),
            values.len()
        )
    };
    if times.is_empty() || times.iter().any(|t| !t.is_finite()) {
        return Err("animation input times are empty or not finite".into());
    }
    Ok(match interpolation {
        Interpolation::Linear if values.len() == times.len() => Track::Linear(times, values),
        Interpolation::Step if values.len() == times.len() => Track::Step(times, values),
        Interpolation::CubicSpline if values.len() == 3 * times.len() => Track::Cubic(
            times,
            values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        ),
        _ => return Err(bad()),
    })
}

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

/// Renders the frames of a camera path.
///
/// Every resource is allocated once, in [`Sequence::new`] (and [`Sequence::prepare_bursts`]):
/// the reprojection cache, the full-render targets and the host-visible ring that frames copy
/// their images and counters into. Frames are recorded in bursts, back to back in one
/// submission ([`Sequence::render_burst`]); [`Sequence::render_frame`] is a burst of one.
pub struct Sequence<'r> {
    draws: Vec<Draw>,
    settings: RenderSettings,
    base: Camera,
    path: CameraPath,
    options: SequenceOptions,
    reprojector: Option<Reprojector<'r>>,
    /// Full renders: every frame of a sequence without reuse, and the references.
    full: FrameTargets,
    burst: BurstResources,
    next: Option<u32>,
}

/// What the full render of a frame keeps for its comparison and for callers.
const REFERENCE_CONTENTS: RingContents = RingContents {
    rgba8: true,
    color: true,
    aov: false,
    states: false,
};

/// What a burst's frames copy their outputs into, and its timestamps.
struct BurstResources {
    frames: FrameRing,
    references: Option<FrameRing>,
    profiler: Option<GpuProfiler>,
}

impl BurstResources {
    fn new(
        ctx: &Context,
        settings: &RenderSettings,
        frames: u32,
        contents: RingContents,
        reference: bool,
    ) -> crate::Result<Self> {
        let pixels = settings.pixels();
        let ring = FrameRing::new(ctx, "sequence frames", frames, pixels, contents)?;
        let references = reference
            .then(|| {
                FrameRing::new(
                    ctx,
                    "sequence references",
                    frames,
                    pixels,
                    REFERENCE_CONTENTS,
                )
            })
            .transpose()?;
        // Each frame (and its reference) is one profiler frame plus its scopes.
        let scopes = (super::reproject::SCOPES_PER_FRAME + 8) * frames * 2;
        Ok(Self {
            frames: ring,
            references,
            profiler: GpuProfiler::new(ctx, scopes).ok(),
        })
    }
}

/// How the warm-up before timed bursts went ([`Sequence::warm_up`]).
#[derive(Clone, Debug, Default, Serialize)]
pub struct WarmUp {
    /// Warm-up bursts rendered.
    pub bursts: u32,
    /// Frames per warm-up burst.
    pub frames_per_burst: u32,
    /// Mean GPU milliseconds per frame of each warm-up burst.
    pub burst_mean_ms: Vec<f64>,
    /// Whether the last two bursts agreed within [`WARM_UP_TOLERANCE`].
    pub settled: bool,
}

pub use super::burst::{WARM_UP_MAX_BURSTS, WARM_UP_TOLERANCE};

impl<'r> Sequence<'r> {
    /// Prepares a sequence of `scene` (already uploaded into `renderer`) along `path`, where
    /// `base` is frame 0's camera. Fails before allocating anything when the frames, and with
    /// reuse the sample cache ([`Reprojector::check_device`]), do not fit the device.
    pub fn new(
        ctx: &Context,
        renderer: &'r Renderer,
        scene: &Scene,
        settings: &RenderSettings,
        base: Camera,
        path: CameraPath,
        options: SequenceOptions,
    ) -> crate::Result<Self> {
        // Before anything is allocated: the frame's buffers, and with reuse the sample cache
        // and its per-pixel buffers on top, against the device's limits and heap.
        let in_use = ctx.allocated_bytes();
        if options.reuse.any() {
            Reprojector::check_device(settings, ctx.info(), options.path, in_use)
        } else {
            settings.check_device(ctx.info(), options.path, false, in_use)
        }
        .map_err(|e| VkError::Limit(e.to_string()))?;
        let reprojector = if options.reuse.any() {
            Some(Reprojector::new(
                ctx,
                renderer,
                options.path,
                settings,
                options.reuse,
            )?)
        } else {
            None
        };
        // Reprojection reads positions and motion from the full G-buffer; full renders of a
        // reusing sequence (first frame, references) rasterize the same layout so that a static
        // camera reproduces them exactly.
        let mut settings = settings.clone();
        if options.reuse.any() {
            settings.gbuffer = gbuffer::GbufferLayout::Full;
        }
        let draws = gbuffer::draws(scene);
        let full = FrameTargets::new(ctx, renderer, options.path, &settings, &draws, false)?;
        let burst = BurstResources::new(
            ctx,
            &settings,
            1,
            RingContents {
                rgba8: true,
                color: true,
                aov: false,
                states: true,
            },
            options.reference && options.reuse.any(),
        )?;
        Ok(Self {
            draws,
            settings,
            base,
            path,
            options,
            reprojector,
            full,
            burst,
            next: None,
        })
    }

    /// Makes room for bursts of up to `frames` frames whose ring slots hold `contents` (one
    /// allocation, before the first burst). Returns the burst length actually prepared: at
    /// most `frames`, fewer when the ring would exceed `max_ring_bytes`.
    pub fn prepare_bursts(
        &mut self,
        ctx: &Context,
        frames: u32,
        contents: RingContents,
        max_ring_bytes: u64,
    ) -> crate::Result<u32> {
        let slot = FrameRing::slot_bytes(self.settings.pixels(), contents)
            + if self.separate_references() {
                FrameRing::slot_bytes(self.settings.pixels(), REFERENCE_CONTENTS)
            } else {
                0
            };
        let frames = frames.clamp(1, (max_ring_bytes / slot.max(1)).clamp(1, 4096) as u32);
        ctx.check_memory("the burst's readback slots", slot * u64::from(frames))?;
        self.burst = BurstResources::new(
            ctx,
            &self.settings,
            frames,
            contents,
            self.separate_references(),
        )?;
        Ok(frames)
    }

    /// Reprojection scatters with two 32-bit atomic passes, as on devices without 64-bit
    /// atomics ([`Reprojector::use_two_pass_scatter`]).
    pub fn use_two_pass_scatter(&mut self) {
        if let Some(r) = self.reprojector.as_mut() {
            r.use_two_pass_scatter();
        }
    }

    /// Whether references are rendered apart from the frames (with reuse; without, a frame is
    /// its own full render and needs no reference slots).
    fn separate_references(&self) -> bool {
        self.options.reference && self.reprojector.is_some()
    }

    /// The longest burst [`Self::render_burst`] takes.
    pub fn burst_capacity(&self) -> u32 {
        self.burst.frames.slots()
    }

    /// The camera of frame `index`.
    pub fn camera(&self, index: u32) -> Camera {
        self.path.camera(&self.base, index)
    }

    /// Empties the sample cache: the next frame is a full render.
    pub fn reset(&mut self) {
        if let Some(r) = self.reprojector.as_mut() {
            r.reset();
        }
        self.next = None;
    }

    /// Renders frame `index` in its own submission. Frames rendered in order (`index` =
    /// previous + 1) reuse the previous frame's samples; any other index starts from an empty
    /// cache.
    pub fn render_frame(&mut self, ctx: &Context, index: u32) -> crate::Result<SequenceFrame> {
        let mut frames = self.render_burst(ctx, index..index.saturating_add(1))?;
        frames
            .pop()
            .ok_or_else(|| VkError::Limit("empty frame range".into()).into())
    }

    /// Renders frames `frames` back to back in one submission, no host work between them
    /// (with references, each frame's full render follows it in the same submission), then
    /// reads every frame's image, statistics and GPU times from the ring. The images are
    /// identical to rendering the frames one by one. At most [`Self::burst_capacity`] frames.
    pub fn render_burst(
        &mut self,
        ctx: &Context,
        frames: std::ops::Range<u32>,
    ) -> crate::Result<Vec<SequenceFrame>> {
        let count = frames.end.saturating_sub(frames.start);
        if count == 0 || count > self.burst_capacity() {
            return Err(VkError::Limit(format!(
                "a burst of {count} frames does not fit the prepared {} (Sequence::prepare_bursts)",
                self.burst_capacity()
            ))
            .into());
        }
        if self.next != Some(frames.start) {
            self.reset();
        }
        let cameras: Vec<Camera> = frames.clone().map(|k| self.camera(k)).collect();
        let mut history = Vec::with_capacity(cameras.len());
        let reference = self.separate_references();
        let Self {
            draws,
            reprojector,
            full,
            burst,
            ..
        } = self;
        let mut profiler = burst.profiler.take();
        let recorded = ctx.run("sequence frames", |cmd| {
            if let Some(p) = profiler.as_mut() {
                p.reset(cmd);
            }
            for (slot, camera) in cameras.iter().enumerate() {
                let slot = slot as u32;
                if let Some(p) = profiler.as_mut() {
                    p.begin_frame(cmd);
                }
                match reprojector.as_mut() {
                    Some(r) => {
                        history.push(r.has_history() && r.options().reuses());
                        r.record(
                            ctx,
                            cmd,
                            draws,
                            camera,
                            profiler.as_mut(),
                            Some((&burst.frames, slot)),
                        );
                    }
                    None => {
                        history.push(false);
                        full.record(
                            ctx,
                            cmd,
                            &full.gpu_frame(camera),
                            profiler.as_mut(),
                            Some((&burst.frames, slot)),
                        );
                    }
                }
                if let Some(p) = profiler.as_mut() {
                    p.end_frame(cmd);
                }
                if let (true, Some(ring)) = (reference, burst.references.as_ref()) {
                    if let Some(p) = profiler.as_mut() {
                        p.begin_frame(cmd);
                    }
                    full.record(
                        ctx,
                        cmd,
                        &full.gpu_frame(camera),
                        profiler.as_mut(),
                        Some((ring, slot)),
                    );
                    if let Some(p) = profiler.as_mut() {
                        p.end_frame(cmd);
                    }
                }
            }
            Ok(())
        });
        let timings = match (&recorded, profiler.as_ref()) {
            (Ok(()), Some(p)) => p.frame_results(),
            _ => Ok(Vec::new()),
        };
        burst.profiler = profiler;
        recorded?;
        let timings = timings?;
        self.next = Some(frames.end);
        let per_frame = if reference { 2 } else { 1 };
        let mut out = Vec::with_capacity(cameras.len());
        for (slot, (index, camera)) in frames.zip(cameras).enumerate() {
            let timing = timings.get(slot * per_frame).cloned().unwrap_or_default();
            let ref_timing = reference.then(|| {
                timings
                    .get(slot * per_frame + 1)
                    .cloned()
                    .unwrap_or_default()
            });
            out.push(self.frame_from_ring(
                slot as u32,
                index,
                camera,
                timing,
                ref_timing,
                history[slot],
            )?);
        }
        Ok(out)
    }

    fn frame_from_ring(
        &self,
        slot: u32,
        index: u32,
        camera: Camera,
        timing: FrameTiming,
        ref_timing: Option<FrameTiming>,
        reused_history: bool,
    ) -> crate::Result<SequenceFrame> {
        let ring = &self.burst.frames;
        let (mut output, sources, stats) = match self.reprojector.as_ref() {
            Some(r) => {
                let ReprojectedFrame {
                    output,
                    sources,
                    stats,
                } = r.output(ring, slot)?;
                (output, sources, stats)
            }
            None => {
                let output = self.full.output(ring, slot)?;
                let pixels = u64::from(output.width) * u64::from(output.height);
                let stats = ReuseStats {
                    pixels,
                    traced: pixels,
                    ..Default::default()
                };
                let sources = if ring.contents().states {
                    vec![PixelSource::Traced; pixels as usize]
                } else {
                    Vec::new()
                };
                (output, sources, stats)
            }
        };
        output.gpu_ms = merge_scopes(timing.passes);
        let (reference, reference_output) = if self.options.reference {
            // Without reuse the frame is itself the full render.
            let (full, full_ms) = match (self.burst.references.as_ref(), ref_timing) {
                (Some(refs), Some(t)) if self.reprojector.is_some() => {
                    let mut full = self.full.output(refs, slot)?;
                    full.gpu_ms = merge_scopes(t.passes);
                    (full, t.total_ms)
                }
                _ => (
                    RenderOutput {
                        width: output.width,
                        height: output.height,
                        color: output.color.clone(),
                        rgba8: output.rgba8.clone(),
                        aov: Vec::new(),
                        rays: output.rays,
                        samples: output.samples,
                        gpu_ms: output.gpu_ms.clone(),
                    },
                    timing.total_ms,
                ),
            };
            let diff = compare::compare(output.width, output.height, &full.rgba8, &output.rgba8);
            (
                Some(ReferenceComparison {
                    rays: full.rays,
                    ray_fraction: output.rays.total() as f64 / full.rays.total().max(1) as f64,
                    diff,
                    total_gpu_ms: full_ms,
                }),
                Some(full),
            )
        } else {
            (None, None)
        };
        Ok(SequenceFrame {
            index,
            camera,
            output,
            sources,
            stats,
            reference,
            reference_output,
            frame_gpu_ms: timing.total_ms,
            reused_history,
        })
    }

    /// Warms the GPU (and lavapipe's shader JIT) up before timed bursts: renders bursts of
    /// `frames` frames from `start` (cache emptied before each) until two consecutive bursts'
    /// mean frame times agree within [`WARM_UP_TOLERANCE`], at most [`WARM_UP_MAX_BURSTS`];
    /// then empties the cache again, so the timed run starts exactly as an untimed one would.
    pub fn warm_up(&mut self, ctx: &Context, start: u32, frames: u32) -> crate::Result<WarmUp> {
        let frames = frames.clamp(1, self.burst_capacity());
        let mut w = WarmUp {
            frames_per_burst: frames,
            ..Default::default()
        };
        while w.bursts < WARM_UP_MAX_BURSTS {
            self.reset();
            let burst = self.render_burst(ctx, start..start.saturating_add(frames))?;
            w.bursts += 1;
            let mean =
                burst.iter().map(|f| f.frame_gpu_ms).sum::<f64>() / burst.len().max(1) as f64;
            w.burst_mean_ms.push(mean);
            if let [.., a, b] = w.burst_mean_ms[..] {
                if super::burst::bursts_agree(&[a], &[b]) {
                    w.settled = true;
                    break;
                }
            }
        }
        self.reset();
        Ok(w)
    }
}

/// A chart of a sequence: rays per frame relative to a full render (and the shares of
/// traced and interpolated pixels) in the upper panel, mean FLIP against the full render in
/// the lower one. Frames without a reference plot the traced share only.
pub fn plot(frames: &[FrameSummary], title: &str) -> super::label::Canvas {
    use super::label::Canvas;
    let (w, panel_h, margin) = (720u32, 220u32, 48u32);
    let h = 2 * panel_h + 3 * margin;
    let mut c = Canvas::new(w, h, [250, 250, 250]);
    c.text(margin, 8, title, 1, [20, 20, 20]);
    let n = frames.len().max(2) as f32;
    let x_of = |i: usize| margin as f32 + (w - 2 * margin) as f32 * i as f32 / (n - 1.0);
    type Series<'a> = (&'a str, [u8; 3], Vec<Option<f32>>);
    let panels: [(&str, u32, f32, Vec<Series>); 2] = [
        (
            "share per frame (rays vs full render; pixels)",
            margin,
            1.0,
            vec![
                (
                    "rays/full",
                    [200, 30, 30],
                    frames
                        .iter()
                        .map(|f| f.reference.as_ref().map(|r| r.ray_fraction as f32))
                        .collect(),
                ),
                (
                    "traced px",
                    [30, 90, 200],
                    frames
                        .iter()
                        .map(|f| Some(f.traced_fraction as f32))
                        .collect(),
                ),
                (
                    "interpolated px",
                    [30, 160, 60],
                    frames
                        .iter()
                        .map(|f| Some(f.interpolated_fraction as f32))
                        .collect(),
                ),
            ],
        ),
        (
            "mean FLIP vs full render",
            2 * margin + panel_h,
            frames
                .iter()
                .filter_map(|f| f.reference.as_ref().map(|r| r.flip_mean))
                .fold(0.05f32, f32::max)
                * 1.1,
            vec![(
                "FLIP",
                [120, 40, 160],
                frames
                    .iter()
                    .map(|f| f.reference.as_ref().map(|r| r.flip_mean))
                    .collect(),
            )],
        ),
    ];
    for (label, top, y_max, series) in panels {
        let bottom = top + panel_h;
        let y_of = |v: f32| bottom as f32 - panel_h as f32 * (v / y_max).clamp(0.0, 1.0);
        for x in margin..w - margin {
            for y in [top, bottom] {
                set(&mut c, x as i64, y as i64, [160, 160, 160]);
            }
        }
        for y in top..=bottom {
            for x in [margin, w - margin] {
                set(&mut c, x as i64, y as i64, [160, 160, 160]);
            }
        }
        // Guide lines: the targets (25 % of a full frame's rays; FLIP 0.05).
        let guide = if top == margin { 0.25 } else { 0.05 };
        let gy = y_of(guide) as i64;
        for x in (margin..w - margin).step_by(4) {
            set(&mut c, x as i64, gy, [120, 120, 120]);
        }
        c.text(
            w - margin + 4,
            (gy - 4).max(0) as u32,
            &format!("{guide}"),
            1,
            [90, 90, 90],
        );
        c.text(margin, top - 12, label, 1, [20, 20, 20]);
        c.text(4, top, &format!("{y_max:.2}"), 1, [90, 90, 90]);
        c.text(4, bottom - 8, "0", 1, [90, 90, 90]);
        let mut legend_x = margin + 8;
        for (name, color, values) in &series {
            let mut last: Option<(f32, f32)> = None;
            for (i, v) in values.iter().enumerate() {
                let Some(v) = v else {
                    last = None;
                    continue;
                };
                let p = (x_of(i), y_of(*v));
                if let Some(a) = last {
                    line(&mut c, a, p, *color);
                }
                last = Some(p);
            }
            c.text(legend_x, top + 6, name, 1, *color);
            legend_x += (name.len() as u32 + 2) * 8;
        }
    }
    let last = frames.last().map(|f| f.frame).unwrap_or(0);
    let first = frames.first().map(|f| f.frame).unwrap_or(0);
    c.text(
        margin,
        h - margin + 8,
        &format!("frame {first}"),
        1,
        [20, 20, 20],
    );
    c.text(
        w - margin - 80,
        h - margin + 8,
        &format!("frame {last}"),
        1,
        [20, 20, 20],
    );
    c
}

fn set(c: &mut super::label::Canvas, x: i64, y: i64, color: [u8; 3]) {
    if x >= 0 && y >= 0 && (x as u32) < c.width && (y as u32) < c.height {
        let o = (y as usize * c.width as usize + x as usize) * 3;
        c.rgb[o..o + 3].copy_from_slice(&color);
    }
}

fn line(c: &mut super::label::Canvas, a: (f32, f32), b: (f32, f32), color: [u8; 3]) {
    let steps = (b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil().max(1.0) as i64;
    for s in 0..=steps {
        let t = s as f32 / steps as f32;
        let (x, y) = (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t);
        for d in 0..2 {
            set(c, x as i64, y as i64 + d, color);
        }
    }
}
