//! Temporal reprojection, frameless rendering and adaptive sub-sampling over a sequence of
//! camera positions (`shaders/temporal/`).
//!
//! A [`Reprojector`] keeps a per-pixel cache of the last frame's samples: linear colour and
//! its display value, world position of the primary hit (or the ray direction of a miss),
//! geometric normal (octahedral, one word), and flags, age and material in one word: nine
//! words per pixel
//! (`interface::reproject::CacheEntry`). Each frame:
//!
//! 1. **Scatter**: every cached sample is projected into the new camera. The nearest sample
//!    per pixel wins (one 64-bit `atomicMin` of depth bits << 32 | source index, or two
//!    32-bit passes without 64-bit atomics, so ties resolve deterministically; the depth key's
//!    low bits say where in the pixel the sample fell). A pixel no sample landed on takes the
//!    sample of an edge-sharing neighbour that falls nearest to its centre within
//!    [`FILL_RADIUS`] (otherwise empty pixels multiply along the seams between regions whose
//!    samples have different sub-pixel offsets), read from the neighbours' keys; it is still
//!    checked like any other.
//! 2. **Decide** per pixel: no sample (disocclusion, screen edge, first frame) → trace;
//!    a view-dependent sample (mirror/metal, transmissive, blended, or a path that spawned
//!    reflection/refraction rays) → trace; a sample older than `max_age` → trace; otherwise
//!    the sample is checked against this frame's primary visibility (see [`PrimaryRayCheck`]):
//!    rejected when the plane distance over the view depth exceeds
//!    [`PLANE_DISTANCE_THRESHOLD`], the normals' dot is below [`NORMAL_DOT_THRESHOLD`], the
//!    material differs, or the new surface is itself view-dependent.
//! 3. **Frameless** (optional): re-trace at least a given share of all pixels per frame: the
//!    pixels that must be traced count first, and the rest of the budget sweeps through the
//!    candidates in a fixed stratified order of 8-pixel row segments (interleaved gradient
//!    noise), each frame continuing where the previous one stopped, so the refresh spreads
//!    evenly over the image and reaches every pixel once per sweep.
//! 4. **Trace** the rest with the shared Whitted loop, or with **adaptive sub-sampling**
//!    (optional): trace every 4×4 block's corners and centre, interpolate the blocks whose
//!    samples are similar, recurse into 2×2 blocks, then trace what is left. On the rt path,
//!    an interpolated pixel is cached only where its block's samples lie on one plane (where
//!    its ray meets that plane); otherwise its entry stays empty, and next frame the pixel is
//!    filled from a neighbour's sample or traced.
//!
//! Every pass after the decision works through a job list in tile order (pixels to verify,
//! to trace, pending interpolation), dispatched indirectly by its length, so its
//! cost follows its jobs.
//!
//! On a scene whose geometry moves between frames ([`Reprojector::track_moving_geometry`]),
//! every sample also keeps an anchor (instance, triangle, barycentrics; a side buffer
//! bound only for such scenes), and the scatter first moves it to where that point is in this
//! frame (this frame's instance transform and skinned/morphed vertices), so a sample on a moving
//! object lands where the object went and then meets the same tests as any other
//! (`shaders/temporal/anchor.glsl`).
//!
//! Reused samples keep the world position where their colour was computed (as in the Render
//! Cache, Walter et al. 1999), so the error of a reused pixel stays within its footprint and
//! does not drift. Fills and interpolated pixels are cached at their own primary hit, flagged
//! so that fills never copy them ([`MAX_FILL_HOPS`]): no colour moves more than one fill
//! radius from where it was computed.

mod options;
mod pipelines;
mod record;
mod resources;

use options::counts;
pub use options::{
    check_sampling, PixelSource, PrimaryRayCheck, ReprojectedFrame, ReuseOptions, ReuseStats,
    DEFAULT_SUBSAMPLE_THRESHOLD, EDGE_PLANE_THRESHOLD, FILL_RADIUS, MAX_FILL_HOPS,
    NORMAL_DOT_THRESHOLD, PLANE_DISTANCE_THRESHOLD, SPECULAR_METALLIC, SPECULAR_ROUGHNESS,
};
use pipelines::{Pipelines, Stage};
use resources::{Gbuffer, Resources};

use crate::interface::push_bytes;
use crate::interface::reproject::*;
use crate::render::frame::{CameraSetup, GpuFrame};
use crate::render::passes::draw_list;
use crate::render::readback::{FrameRing, RingContents, RingSources};
use crate::render::settings::{RenderPath, RenderSettings};
use crate::render::{merge_scopes, RenderOutput, Renderer};
use crate::scene::Camera;
use crate::vk::{memory_barrier, ComputePipeline, Context, DescriptorSet, GpuProfiler, VkError};

/// Side of the 8x8-pixel workgroups of the stages.
const TILE: u32 = 8;
/// Timestamp scopes one reprojected frame records (raster, scatter, fill, classify,
/// visibility, three trace levels, two interpolations, tonemap, and the frame itself), for
/// sizing a burst's profiler.
pub const SCOPES_PER_FRAME: u32 = 16;

/// The reprojection passes and the sample cache of one resolution, for one [`Renderer`].
///
/// Like a full frame's targets it does not borrow the renderer, so a renderer whose scene is
/// updated in place between frames (an animated sequence) keeps its cache: its descriptor
/// sets point at the renderer's buffers, so the renderer must outlive it, and after a
/// renderer's ray backend changed, [`Self::update_scene`] rebinds it.
pub struct Reprojector {
    /// Diagonal of the scene bounds (ray offsets), as of the last [`Self::update_scene`].
    scene_scale: f32,
    /// Whether the scene has emissive triangles (the frame uniform's flags).
    emissive_geometry: bool,
    path: RenderPath,
    options: ReuseOptions,
    settings: RenderSettings,
    /// The caches, per-pixel buffers and G-buffer.
    res: Resources,
    /// The passes' pipelines and descriptor sets.
    pipes: Pipelines,
    /// Whether samples move with their objects ([`Self::track_moving_geometry`]).
    moving: bool,
    /// One slot: what [`Self::render`] reads back (taken while recording into it).
    readback: Option<FrameRing>,
    /// Timestamps of [`Self::render`]'s single frames.
    profiler: Option<GpuProfiler>,
    parity: usize,
    has_history: bool,
    /// Whether the rt path's G-buffer images are in GENERAL layout already: they stay
    /// there, so only the first frame transitions them (every pixel a pass reads from them
    /// is written earlier in the same frame).
    gbuffer_in_general: bool,
    prev_view_proj: Option<[f32; 16]>,
    /// Frames recorded: the camera sample number of the next (distributed shading draws new
    /// random numbers every frame).
    frames_recorded: u32,
}

impl Reprojector {
    /// Creates the passes and an empty cache for images of `settings` on `path`: validates
    /// every input first ([`Self::check_device`] among them; reprojection caches one sample
    /// per pixel at its centre, so `settings` must use one sample per pixel with the `center`
    /// sampler: [`check_sampling`]), then allocates the resources, then builds the pipelines.
    pub fn new(
        ctx: &Context,
        renderer: &Renderer,
        path: RenderPath,
        settings: &RenderSettings,
        options: ReuseOptions,
    ) -> crate::Result<Self> {
        Self::validate(ctx, renderer, path, settings, &options)?;
        let pass = renderer.pass_context();
        let res = Resources::allocate(ctx, &pass, path, settings)?;
        let pipes = Pipelines::build(ctx, &pass, &res, settings.shading)?;
        let readback = FrameRing::new(
            ctx,
            "reproject readback",
            1,
            settings.pixels(),
            RingContents {
                rgba8: true,
                color: options.linear_color,
                aov: false,
                states: true,
            },
        )?;
        let mut reprojector = Self {
            scene_scale: renderer.scene_scale(),
            emissive_geometry: renderer.scene_traits().emissive_geometry,
            path,
            options,
            settings: settings.clone(),
            res,
            pipes,
            moving: false,
            readback: Some(readback),
            profiler: GpuProfiler::new(ctx, SCOPES_PER_FRAME).ok(),
            parity: 0,
            has_history: false,
            gbuffer_in_general: false,
            prev_view_proj: None,
            frames_recorded: 0,
        };
        if options.moving_geometry {
            reprojector.track_moving_geometry(ctx)?;
        }
        Ok(reprojector)
    }

    /// Whether cached samples move with their objects ([`Self::track_moving_geometry`]).
    pub fn tracks_moving_geometry(&self) -> bool {
        self.moving
    }

    /// Takes `renderer`'s scene as updated in place for the next frame (an animated frame):
    /// its scale, and its ray backend, which an update may have built again. The cache is
    /// kept.
    pub fn update_scene(&mut self, renderer: &Renderer) {
        self.scene_scale = renderer.scene_scale();
        self.emissive_geometry = renderer.scene_traits().emissive_geometry;
        self.pipes.rebind_scene(&renderer.pass_context());
    }

    /// Empties the cache: the next frame traces every pixel (the start of a frame range).
    pub fn reset(&mut self) {
        self.has_history = false;
        self.prev_view_proj = None;
    }

    /// The reuse options.
    pub fn options(&self) -> &ReuseOptions {
        &self.options
    }

    /// Scatters with two 32-bit atomic passes even where the device has 64-bit atomics (the
    /// path of devices without them; both give the same images, which the tests check).
    pub fn use_two_pass_scatter(&mut self) {
        self.pipes.scatter64 = None;
    }

    /// Whether the next frame reuses cached samples (false at the start of a range).
    pub fn has_history(&self) -> bool {
        self.has_history
    }

    /// The image, rays, pixel sources and statistics a frame copied into `ring`'s slot
    /// `slot`, after its submission completed (`gpu_ms` left empty; sources empty when the
    /// ring holds no states).
    pub fn output(&self, ring: &FrameRing, slot: u32) -> crate::Result<ReprojectedFrame> {
        let s = &self.settings;
        let c = ring.counters(slot)?;
        let states = ring.states(slot)?;
        let sources = states
            .iter()
            .map(|st| match st & PX_KIND_MASK {
                PX_REUSE => PixelSource::Reused,
                PX_INTERP => PixelSource::Interpolated,
                PX_TRACED => PixelSource::Traced,
                other => {
                    log::error!("reprojection left a pixel in state {other}");
                    PixelSource::Traced
                }
            })
            .collect();
        let (rays, samples, stats) = counts(&c, s.pixels());
        Ok(ReprojectedFrame {
            output: RenderOutput {
                width: s.width,
                height: s.height,
                color: ring.color(slot)?,
                rgba8: ring.rgba8(slot)?,
                aov: Vec::new(),
                rays,
                samples,
                gpu_ms: Vec::new(),
            },
            sources,
            stats,
        })
    }

    /// Renders one frame through `camera` in its own submission, reusing what the cache
    /// allows, and caches its samples for the next call. `draws` are the scene's raster draws
    /// (hybrid path; ignored by the rt path).
    pub fn render(
        &mut self,
        ctx: &Context,
        draws: &[draw_list::Draw],
        camera: &Camera,
    ) -> crate::Result<ReprojectedFrame> {
        let mut profiler = self.profiler.take();
        let readback = self
            .readback
            .take()
            .ok_or_else(|| VkError::Invalid("reprojection readback in use".into()))?;
        let recorded = ctx.run("reprojected frame", |cmd| {
            if let Some(p) = profiler.as_mut() {
                p.reset(cmd);
            }
            self.record(
                ctx,
                cmd,
                draws,
                camera,
                profiler.as_mut(),
                Some((&readback, 0)),
            );
            Ok(())
        });
        let frame = recorded
            .map_err(crate::Error::from)
            .and_then(|()| self.output(&readback, 0));
        self.readback = Some(readback);
        self.profiler = profiler;
        let mut frame = frame?;
        if let Some(p) = &self.profiler {
            frame.output.gpu_ms = merge_scopes(p.results()?);
        }
        Ok(frame)
    }
}
