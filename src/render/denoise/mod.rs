//! Denoising of distributed shading (`--denoise`): SVGF (Schied et al. 2017) on the frame's
//! own buffers, recorded between the shading passes and tonemapping of every frame
//! ([`crate::render::FrameTargets`]).
//!
//! 1. **Split**: the shading passes split each pixel's colour
//!    ([`crate::interface::denoise::DenoiseGuide`]) into light through the first vertex's
//!    diffuse lobe, the rest of its reflected light, and what needs no filter (emission,
//!    misses), with the vertex's diffuse and specular albedo. The AOVs of a jittered sequence
//!    come from one more ray through the pixel centre, so that the history test sees the same
//!    surface every frame.
//! 2. **Temporal accumulation** (`denoise_temporal.comp`): the previous frame's light is
//!    reprojected through the previous camera and pose (moving objects included), tested
//!    against the pixel's surface as temporal reuse tests its samples, resampled bilinearly
//!    (Catmull-Rom where the whole 4×4 neighbourhood matches), and blended with weight
//!    1 / history length, never below 1 / `--history-cap` ([`MOVING_HISTORY_CAP`] while the
//!    history moves between texels, when the specular and unfiltered history is also
//!    clamped to the range of this frame's 3×3 neighbourhood, and the diffuse history too
//!    while anything in the scene moves: a moving shadow); a disoccluded pixel starts
//!    again, and so does every pixel after a camera cut ([`is_camera_cut`]). The accumulated
//!    light is then divided by the accumulated albedos (demodulated): the mean of products,
//!    so that with no spatial filter the output is exactly the mean of the frames.
//! 3. **Variance** (`denoise_variance.comp`): from the accumulated luminance moments, or a 7×7
//!    spatial estimate for pixels with under 4 frames of history.
//! 4. **À-trous** (`denoise_atrous.comp`): [`ATROUS_ITERATIONS`] iterations, taps 1, 2, 4, 8
//!    and 16 pixels apart, stopping at normal, depth-plane and luminance edges; a pixel with f
//!    frames of history takes those up to [`SPATIAL_REACH`] / f pixels apart, so a converged
//!    one is not filtered. The next frame blends with the accumulation, not with the filtered
//!    image, so a static view converges to the unbiased mean.
//! 5. **Remodulate** (`denoise_remodulate.comp`) into the colour tonemapping reads.
//!
//! `temporal` runs 1, 2 and 5; `svgf` all five. A single frame (no history) gets the spatial
//! filter alone.

use std::cell::Cell;
use std::sync::Arc;

use ash::vk;
use glam::Mat4;

use crate::interface::denoise::{
    DenoiseAtrousPush, DenoiseHistory, DenoiseMoments, DenoiseParams, DenoiseSurface,
    BINDING_DENOISE_PARAMS, DN_HISTORY, DN_WEIGHTED_COLOR,
};
use crate::interface::{self as io, bindings, push_bytes};
use crate::render::{GpuFrame, PassContext, RenderSettings};
use crate::vk::{
    memory_barrier, Binding, Buffer, ComputePipeline, Context, DescriptorSet, GpuProfiler,
    MemoryLocation, VkResult,
};

/// What `--denoise` runs on a distributed frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum DenoiseMode {
    /// The frame as shaded.
    #[default]
    None,
    /// Temporal accumulation of the demodulated light on the reprojected history.
    Temporal,
    /// Temporal accumulation, variance estimate and the edge-aware à-trous filter (SVGF).
    Svgf,
}

impl DenoiseMode {
    /// The `--denoise` name.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Temporal => "temporal",
            Self::Svgf => "svgf",
        }
    }

    /// Whether a denoiser runs.
    pub fn enabled(self) -> bool {
        self != Self::None
    }
}

/// Default `--history-cap` (frames).
pub const DEFAULT_HISTORY_CAP: u32 = 32;
/// Largest `--history-cap`.
pub const MAX_HISTORY_CAP: u32 = 1024;
/// À-trous iterations (taps 1, 2, 4, 8 and 16 pixels apart), as NRD's ReLAX.
pub const ATROUS_ITERATIONS: u32 = 5;
/// The spatial filter's reach in pixels, over the history length: a pixel with f frames
/// behind it takes the à-trous iterations whose taps lie at most `SPATIAL_REACH / f` pixels
/// apart (a fresh pixel all five; none from 17 frames on, where the accumulation alone has
/// less error than the filter's bias adds).
pub const SPATIAL_REACH: f32 = 16.0;
/// Longest history a pixel keeps while its history is resampled between texels (a moving
/// view or object): each resampling blurs it a little, and the blur compounds over the
/// history's length.
pub const MOVING_HISTORY_CAP: u32 = 4;
/// The same for the specular light: reflections move otherwise than the surface whose motion
/// the history follows, so its history lags them, and a shorter one lags less than it adds
/// noise (with the history clamped to the neighbourhood, orbit FLIP at 512² with 2 against 4:
/// built-in room 0.644× against 0.668×, DamagedHelmet 0.340× against 0.375×, the Cornell box
/// 0.411× against 0.412×; 3 and 8 worse than 2, 1 worse than 4). Not clamped: 0.555×, 0.342×,
/// 0.381×.
pub const MOVING_SPECULAR_HISTORY_CAP: u32 = 2;
/// Smallest blend weight of the luminance moments (Falcor's SVGF pass).
pub const MOMENTS_ALPHA: f32 = 0.2;
/// Luminance edge-stopping scale: a neighbour whose luminance differs by this many standard
/// deviations of the pixel's estimate keeps 1/e of its weight. The SVGF paper's σ_l; against
/// Falcor's 10 it lowers or keeps every denoising benchmark's error (one frame, orbit,
/// ghosting: BENCHMARKS.md), where 2 helps some scenes and hurts the built-in room's orbit.
pub const PHI_COLOR: f32 = 4.0;
/// Depth edge-stopping scale: a neighbour this far off the pixel's tangent plane, relative to
/// its distance from the pixel (the sine of the angle), keeps 1/e of its weight.
pub const PHI_PLANE: f32 = 0.1;
/// A camera whose position jumps by more than this fraction of the scene's diagonal between
/// two frames has cut to another shot ([`is_camera_cut`]).
pub const CUT_DISTANCE: f32 = 0.25;
/// A camera whose view direction turns by more than this many degrees between two frames has cut.
pub const CUT_ANGLE_DEG: f32 = 30.0;

/// GPU timestamp scope names of the denoiser's passes (keys of `RenderOutput::gpu_ms`).
pub const SCOPE_TEMPORAL: &str = "denoise temporal";
/// Variance estimate.
pub const SCOPE_VARIANCE: &str = "denoise variance";
/// À-trous iterations (their times summed).
pub const SCOPE_ATROUS: &str = "denoise atrous";
/// Remodulation.
pub const SCOPE_REMODULATE: &str = "denoise remodulate";
/// Timestamp scopes one denoised frame records.
pub const SCOPES: u32 = 3 + ATROUS_ITERATIONS;

/// Bytes per pixel the denoiser allocates (memory estimates): surfaces and moments twice,
/// history twice, accumulation, two ping-pong buffers (2 `vec4` each), the guide and the
/// output colour.
pub fn bytes_per_pixel() -> u64 {
    let surface = std::mem::size_of::<DenoiseSurface>() as u64;
    let moments = std::mem::size_of::<DenoiseMoments>() as u64;
    let pair = 32;
    let history = std::mem::size_of::<DenoiseHistory>() as u64;
    let guide = std::mem::size_of::<io::denoise::DenoiseGuide>() as u64;
    let edges = 16;
    2 * surface + 2 * moments + 2 * history + 3 * pair + guide + edges + 16
}

/// Whether the camera moved from `prev` to `next` (camera-to-world matrices) by more than a
/// continuous path does between two frames: a jump of over [`CUT_DISTANCE`] × `scene_scale`,
/// or a turn of over [`CUT_ANGLE_DEG`]. The history of a cut is dropped.
pub fn is_camera_cut(prev: &Mat4, next: &Mat4, scene_scale: f32) -> bool {
    let moved = (prev.w_axis.truncate() - next.w_axis.truncate()).length();
    let forward = |m: &Mat4| (-m.z_axis.truncate()).normalize_or_zero();
    let cos = forward(prev).dot(forward(next)).clamp(-1.0, 1.0);
    moved > CUT_DISTANCE * scene_scale.max(1e-6) || cos < CUT_ANGLE_DEG.to_radians().cos()
}

/// What one frame's commands need to know of the frames before it.
#[derive(Clone, Copy, Debug, Default)]
struct History {
    /// Frames recorded since the last reset; its parity picks the ping-pong halves.
    frames: u64,
    /// The last frame's camera-to-world and proj × view, when it may be reprojected.
    last: Option<(Mat4, Mat4)>,
}

/// The denoiser's pipelines, per-pixel buffers and history.
pub struct Denoiser {
    mode: DenoiseMode,
    history_cap: u32,
    width: u32,
    height: u32,
    weighted_color: bool,
    scene_scale: f32,
    temporal: Arc<ComputePipeline>,
    variance: Arc<ComputePipeline>,
    atrous: Arc<ComputePipeline>,
    remodulate: Arc<ComputePipeline>,
    sets: [DescriptorSet; 4],
    params: Buffer,
    /// The colour split the shading passes write ([`crate::interface::denoise::DenoiseGuide`]).
    pub guide: Buffer,
    /// Denoised linear colour, `vec4` per pixel, alpha 1 (what tonemapping reads).
    pub output: Buffer,
    surfaces: [Buffer; 2],
    moments: [Buffer; 2],
    history: [Buffer; 2],
    edges: Buffer,
    accumulated: Buffer,
    ping: Buffer,
    pong: Buffer,
    state: Cell<History>,
}

impl Denoiser {
    /// Pipelines and buffers for frames at `settings` (mode, history cap, resolution).
    /// `weighted_color`: the colour buffer holds Σ weight × colour and Σ weight (the hybrid
    /// path's accumulation).
    pub fn new(
        ctx: &Context,
        pass: &PassContext<'_>,
        settings: &RenderSettings,
        weighted_color: bool,
        scene_scale: f32,
    ) -> VkResult<Self> {
        let layout = bindings(&[
            (io::BINDING_SCENE, Binding::UniformBuffer),
            (
                io::BINDING_TEXTURES,
                Binding::SampledImages(pass.texture_capacity()),
            ),
            (BINDING_DENOISE_PARAMS, Binding::UniformBuffer),
        ]);
        let push = std::mem::size_of::<DenoiseAtrousPush>() as u32;
        let pipeline =
            |name: &str, spirv: &[u8]| ComputePipeline::cached(ctx, name, spirv, &layout, push);
        let temporal = pipeline(SCOPE_TEMPORAL, crate::shaders::DENOISE_TEMPORAL_COMP)?;
        let variance = pipeline(SCOPE_VARIANCE, crate::shaders::DENOISE_VARIANCE_COMP)?;
        let atrous = pipeline(SCOPE_ATROUS, crate::shaders::DENOISE_ATROUS_COMP)?;
        let remodulate = pipeline(SCOPE_REMODULATE, crate::shaders::DENOISE_REMODULATE_COMP)?;
        let params = Buffer::new(
            ctx,
            "denoise params",
            std::mem::size_of::<DenoiseParams>() as u64,
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            MemoryLocation::GpuOnly,
        )?;
        let pixels = settings.pixels();
        let buffer = |name: &str, bytes: u64| {
            Buffer::new(
                ctx,
                name,
                pixels * bytes,
                vk::BufferUsageFlags::empty(),
                MemoryLocation::GpuOnly,
            )
        };
        let surface_bytes = std::mem::size_of::<DenoiseSurface>() as u64;
        let moments_bytes = std::mem::size_of::<DenoiseMoments>() as u64;
        let guide_bytes = std::mem::size_of::<io::denoise::DenoiseGuide>() as u64;
        let history_bytes = std::mem::size_of::<DenoiseHistory>() as u64;
        let sets = [
            temporal.allocate_set()?,
            variance.allocate_set()?,
            atrous.allocate_set()?,
            remodulate.allocate_set()?,
        ];
        let denoiser = Self {
            mode: settings.denoise,
            history_cap: settings.history_cap,
            width: settings.width,
            height: settings.height,
            weighted_color,
            scene_scale,
            temporal,
            variance,
            atrous,
            remodulate,
            sets,
            guide: buffer("denoise guide", guide_bytes)?,
            output: buffer("denoised colour", 16)?,
            surfaces: [
                buffer("denoise surfaces", surface_bytes)?,
                buffer("denoise surfaces", surface_bytes)?,
            ],
            moments: [
                buffer("denoise moments", moments_bytes)?,
                buffer("denoise moments", moments_bytes)?,
            ],
            history: [
                buffer("denoise history", history_bytes)?,
                buffer("denoise history", history_bytes)?,
            ],
            edges: buffer("denoise edges", 16)?,
            accumulated: buffer("denoise accumulation", 32)?,
            ping: buffer("denoise ping", 32)?,
            pong: buffer("denoise pong", 32)?,
            params,
            state: Cell::new(History::default()),
        };
        denoiser.bind_scene(pass);
        Ok(denoiser)
    }

    /// Points the passes at `pass`'s scene and textures (again, after the scene changed).
    pub fn bind_scene(&self, pass: &PassContext<'_>) {
        for set in &self.sets {
            pass.scene.bind(set);
            set.sampled_images(io::BINDING_TEXTURES, pass.textures);
            set.buffer(BINDING_DENOISE_PARAMS, &self.params, Binding::UniformBuffer);
        }
    }

    /// What the denoiser runs.
    pub fn mode(&self) -> DenoiseMode {
        self.mode
    }

    /// Forgets the history: the next frame is filtered on its own.
    pub fn reset(&self) {
        self.state.set(History::default());
    }

    /// Records the denoiser for the frame seen through `frame`, whose shading passes wrote
    /// `color`, `aov` and [`Self::guide`]: the passes write [`Self::output`]. A frame whose
    /// camera cut from the last one ([`is_camera_cut`]) starts without history.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        frame: &GpuFrame,
        color: &Buffer,
        aov: &Buffer,
        profiler: Option<&mut GpuProfiler>,
    ) {
        let device = ctx.device();
        let camera = Mat4::from_cols_array(&frame.camera_to_world);
        let view_proj = Mat4::from_cols_array(&frame.view_proj);
        let state = self.state.get();
        let previous = state
            .last
            .filter(|(prev_camera, _)| !is_camera_cut(prev_camera, &camera, self.scene_scale));
        let now = (state.frames % 2) as usize;
        let before = 1 - now;
        let spatial = self.mode == DenoiseMode::Svgf;
        let mut flags = 0;
        if self.weighted_color {
            flags |= DN_WEIGHTED_COLOR;
        }
        if previous.is_some() {
            flags |= DN_HISTORY;
        }
        let params = DenoiseParams {
            view_proj: view_proj.to_cols_array(),
            prev_view_proj: previous.map_or(view_proj, |p| p.1).to_cols_array(),
            inv_view_proj: view_proj.inverse().to_cols_array(),
            width: self.width,
            height: self.height,
            flags,
            history_cap: self.history_cap,
            moments_alpha: MOMENTS_ALPHA,
            phi_color: PHI_COLOR,
            phi_plane: PHI_PLANE,
            plane_threshold: crate::render::temporal::PLANE_DISTANCE_THRESHOLD,
            normal_threshold: crate::render::temporal::NORMAL_DOT_THRESHOLD,
            spatial_reach: SPATIAL_REACH,
            moving_history_cap: MOVING_HISTORY_CAP.min(self.history_cap) as f32,
            moving_specular_history_cap: MOVING_SPECULAR_HISTORY_CAP.min(self.history_cap) as f32,
            color: color.address(),
            guide: self.guide.address(),
            aov: aov.address(),
            denoised: self.output.address(),
            surface: self.surfaces[now].address(),
            prev_surface: self.surfaces[before].address(),
            moments: self.moments[now].address(),
            prev_moments: self.moments[before].address(),
            history: self.history[now].address(),
            prev_history: self.history[before].address(),
            edges: self.edges.address(),
            accumulated: self.accumulated.address(),
            ping: self.ping.address(),
            pong: self.pong.address(),
        };
        self.state.set(History {
            frames: state.frames + 1,
            last: Some((camera, view_proj)),
        });
        self.params
            .record_update(device, cmd, bytemuck::bytes_of(&params));
        memory_barrier(device, cmd);
        let groups = [self.width.div_ceil(8), self.height.div_ceil(8), 1];
        let mut profiler = profiler;
        let mut run = |pipeline: &ComputePipeline,
                       set: &DescriptorSet,
                       scope: &str,
                       push: DenoiseAtrousPush| {
            if let Some(p) = profiler.as_deref_mut() {
                p.begin(cmd, scope);
            }
            pipeline.dispatch(cmd, Some(set), push_bytes(&push), groups);
            if let Some(p) = profiler.as_deref_mut() {
                p.end(cmd);
            }
            memory_barrier(device, cmd);
        };
        let none = DenoiseAtrousPush::default();
        run(&self.temporal, &self.sets[0], SCOPE_TEMPORAL, none);
        let filtered = if spatial {
            run(&self.variance, &self.sets[1], SCOPE_VARIANCE, none);
            let mut input = &self.ping;
            let mut output = &self.pong;
            for k in 0..ATROUS_ITERATIONS {
                let push = DenoiseAtrousPush {
                    source: input.address(),
                    target: output.address(),
                    step: 1 << k,
                    pad0: 0,
                };
                run(&self.atrous, &self.sets[2], SCOPE_ATROUS, push);
                std::mem::swap(&mut input, &mut output);
            }
            input
        } else {
            &self.accumulated
        };
        let push = DenoiseAtrousPush {
            source: filtered.address(),
            target: self.history[now].address(),
            ..Default::default()
        };
        run(&self.remodulate, &self.sets[3], SCOPE_REMODULATE, push);
    }

    /// Each pixel's history length after the last recorded frame (1: that frame alone, 0: a
    /// miss), read back from the device (for tests and diagnostics; waits).
    pub fn history_lengths(&self, ctx: &Context) -> VkResult<Vec<f32>> {
        let frames = self.state.get().frames;
        let last = ((frames + 1) % 2) as usize;
        let moments: Vec<DenoiseMoments> = self.moments[last].read(ctx)?;
        let pixels = (u64::from(self.width) * u64::from(self.height)) as usize;
        Ok(moments.iter().take(pixels).map(|m| m.frames).collect())
    }

    /// The guide the shading passes last wrote (for tests; waits).
    pub fn read_guide(&self, ctx: &Context) -> VkResult<Vec<io::denoise::DenoiseGuide>> {
        self.guide.read(ctx)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn a_small_orbit_step_is_not_a_cut_and_a_jump_is() {
        let at = |eye: Vec3| crate::scene::procedural::camera_to_world(eye, Vec3::ZERO, Vec3::Y);
        let a = at(Vec3::new(0.0, 1.0, 5.0));
        let turn = Mat4::from_rotation_y(0.5f32.to_radians());
        let b = turn * a;
        assert!(!is_camera_cut(&a, &b, 4.0));
        let far = at(Vec3::new(3.0, 1.0, 5.0));
        assert!(is_camera_cut(&a, &far, 4.0));
        let behind = at(Vec3::new(0.0, 1.0, -5.0));
        assert!(is_camera_cut(&a, &behind, 100.0), "a half turn is a cut");
    }
}
