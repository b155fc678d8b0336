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
//!    the sample is checked against this frame's primary visibility (see [`RtVisibility`]):
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
mod record;

use options::counts;
pub use options::{
    PixelSource, ReprojectedFrame, ReuseOptions, ReuseStats, RtVisibility,
    DEFAULT_SUBSAMPLE_THRESHOLD, EDGE_PLANE_THRESHOLD, FILL_RADIUS, MAX_FILL_HOPS,
    NORMAL_DOT_THRESHOLD, PLANE_DISTANCE_THRESHOLD, SPECULAR_METALLIC, SPECULAR_ROUGHNESS,
};

use std::sync::Arc;

use ash::vk;

use crate::accel::Backend;
use crate::interface::reproject::{self as io, *};
use crate::interface::{bindings, push_bytes, BINDING_FRAME, BINDING_SCENE, BINDING_TEXTURES};
use crate::render::frame::{CameraSetup, GpuFrame};
use crate::render::passes::gbuffer::{self, GbufferPass, GBUFFER_FORMATS};
use crate::render::readback::{FrameRing, RingContents, RingSources};
use crate::render::settings::{RenderPath, RenderSettings, SamplerKind, SettingsError};
use crate::render::{merge_scopes, RenderOutput, Renderer};
use crate::scene::Camera;
use crate::vk::{
    memory_barrier, Binding, Buffer, ComputePipeline, Context, DescriptorSet, GpuProfiler, Image,
    MemoryLocation, VkError, VkResult,
};

/// A cache entry's and a shown sample's size (`src/interface/reproject.rs`).
const CACHE_ENTRY_BYTES: u64 = std::mem::size_of::<io::CacheEntry>() as u64;
const SHOWN_BYTES: u64 = std::mem::size_of::<io::Shown>() as u64;
/// Per pixel: the index of the sample that won it and its depth key.
const KEY_WINNER_BYTES: u64 = 8;
const ANCHOR_BYTES: u64 = std::mem::size_of::<io::Anchor>() as u64;

/// The stages that trace no rays, each its own shader (`shaders/temporal/temporal_<stage>.comp`)
/// and pipeline, all with one set layout; in the order a frame records them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
enum Stage {
    /// The first of the two 32-bit scatter passes: the nearest depth key per pixel.
    Scatter,
    /// The second: the lowest source index among the samples at that depth.
    Resolve,
    /// The sample each pixel shows, fills, and the frameless candidates' histogram.
    Shown,
    /// The frameless refresh window.
    Threshold,
    /// Decide, commit, count and list every pixel.
    Classify,
    /// Adaptive sub-sampling's interpolation at one level.
    Interpolate,
}

impl Stage {
    /// Every stage, in the order of their discriminants (the index of a stage's pipeline).
    const ALL: [Self; 6] = [
        Self::Scatter,
        Self::Resolve,
        Self::Shown,
        Self::Threshold,
        Self::Classify,
        Self::Interpolate,
    ];

    /// The stage's shader and pipeline name.
    fn shader(self) -> (&'static [u8], &'static str) {
        use crate::shaders as s;
        match self {
            Self::Scatter => (s::TEMPORAL_SCATTER_COMP, "temporal scatter"),
            Self::Resolve => (s::TEMPORAL_RESOLVE_COMP, "temporal resolve"),
            Self::Shown => (s::TEMPORAL_SHOWN_COMP, "temporal shown"),
            Self::Threshold => (s::TEMPORAL_THRESHOLD_COMP, "temporal threshold"),
            Self::Classify => (s::TEMPORAL_CLASSIFY_COMP, "temporal classify"),
            Self::Interpolate => (s::TEMPORAL_INTERPOLATE_COMP, "temporal interpolate"),
        }
    }
}

/// Side of the 8x8-pixel workgroups of the stages.
const TILE: u32 = 8;
/// Timestamp scopes one reprojected frame records (raster, scatter, fill, classify,
/// visibility, three trace levels, two interpolations, tonemap, and the frame itself), for
/// sizing a burst's profiler.
pub const SCOPES_PER_FRAME: u32 = 16;

fn primary_spirv(backend: Backend) -> &'static [u8] {
    match backend {
        Backend::Hw => crate::shaders::TEMPORAL_VISIBILITY_COMP_HW,
        Backend::Bvh => crate::shaders::TEMPORAL_VISIBILITY_COMP_BVH,
    }
}

fn trace_spirv(backend: Backend) -> &'static [u8] {
    match backend {
        Backend::Hw => crate::shaders::TEMPORAL_TRACE_COMP_HW,
        Backend::Bvh => crate::shaders::TEMPORAL_TRACE_COMP_BVH,
    }
}

/// G-buffer images: the raster pass's (hybrid) or placeholders (rt, which keeps its primary
/// hits in registers).
enum Visibility {
    Raster(Box<GbufferPass>),
    Traced(Vec<Image>),
}

impl Visibility {
    fn images(&self) -> &[Image] {
        match self {
            Self::Raster(g) => &g.images,
            Self::Traced(images) => images,
        }
    }
}

/// The reprojection passes and the sample cache of one resolution, for one [`Renderer`].
///
/// Like a full frame's targets it does not borrow the renderer, so a renderer whose scene is
/// updated in place between frames (an animated sequence) keeps its cache: its descriptor
/// sets point at the renderer's buffers, so the renderer must outlive it, and after a
/// renderer's ray backend changed, [`Self::update_scene`] rebinds it.
pub struct Reprojector {
    /// Diagonal of the scene bounds (ray offsets), as of the last [`Self::update_scene`].
    scene_scale: f32,
    path: RenderPath,
    options: ReuseOptions,
    settings: RenderSettings,
    /// The stages' pipelines, indexed by [`Stage`] (sharing one set layout).
    stages: Vec<Arc<ComputePipeline>>,
    primary: Arc<ComputePipeline>,
    trace: Arc<ComputePipeline>,
    /// Descriptor sets of `stages`, `primary`, `trace`.
    sets: [DescriptorSet; 3],
    frame: Buffer,
    params: Buffer,
    caches: [Buffer; 2],
    /// Per cache parity: the samples' anchors (`interface::reproject::Anchor`), with
    /// [`Self::track_moving_geometry`]; placeholders of one anchor otherwise.
    anchors: [Buffer; 2],
    /// Whether samples move with their objects ([`Self::track_moving_geometry`]).
    moving: bool,
    /// Per pixel: the winning sample's index and its depth key (interleaved u32 pairs).
    key_winner: Buffer,
    /// The one-pass scatter and its descriptor set, where the device has 64-bit buffer
    /// atomics.
    scatter64: Option<(Arc<ComputePipeline>, DescriptorSet)>,
    state: Buffer,
    color: Buffer,
    jobs: Buffer,
    shown: Buffer,
    counters: Buffer,
    /// Indirect dispatch of the tracing passes, sized by their job lists.
    args: Buffer,
    visibility: Visibility,
    /// The frame's display pixels (RGBA8), written with the colour (tonemapping fused into
    /// the passes that write colour).
    display: Buffer,
    /// One slot: what [`Self::render`] reads back (taken while recording into it).
    readback: Option<FrameRing>,
    /// Timestamps of [`Self::render`]'s single frames.
    profiler: Option<GpuProfiler>,
    parity: usize,
    has_history: bool,
    /// Whether the rt path's visibility images are in GENERAL layout already: they stay
    /// there, so only the first frame transitions them (every pixel a pass reads from them
    /// is written earlier in the same frame).
    visibility_in_general: bool,
    prev_view_proj: Option<[f32; 16]>,
}

impl Reprojector {
    /// Creates the passes and an empty cache for images of `settings` on `path`.
    /// Reprojection caches one sample per pixel at its centre: `settings` must use one
    /// sample per pixel with the `center` sampler.
    pub fn new(
        ctx: &Context,
        renderer: &Renderer,
        path: RenderPath,
        settings: &RenderSettings,
        options: ReuseOptions,
    ) -> crate::Result<Self> {
        Self::check_device(
            settings,
            ctx.info(),
            path,
            options.moving_geometry,
            ctx.allocated_bytes(),
        )
        .map_err(|e| VkError::Limit(e.to_string()))?;
        options.validate().map_err(VkError::Limit)?;
        if settings.spp != 1 || settings.sampler != SamplerKind::Center {
            return Err(VkError::Limit(
                "reprojection, frameless rendering and adaptive sub-sampling cache one sample per pixel: use --spp 1 --sampler center".into(),
            )
            .into());
        }
        let subgroup = ctx.info().subgroup_size;
        if options.frameless_percent.is_some() && subgroup % REFRESH_SEGMENT != 0 {
            return Err(VkError::Limit(format!(
                "--frameless counts candidates per {REFRESH_SEGMENT}-pixel row segment with one cluster of subgroup invocations, but '{}' has subgroups of {subgroup}",
                ctx.info().name
            ))
            .into());
        }
        let pass = renderer.pass_context();
        let materials = pass.scene.materials.size()
            / std::mem::size_of::<crate::scene::layout::GpuMaterial>() as u64;
        if options.reuses() && materials > u64::from(MAX_CACHE_MATERIALS) {
            return Err(VkError::Limit(format!(
                "reprojection caches a 16-bit material index per sample: the scene has {materials} materials (at most {MAX_CACHE_MATERIALS})"
            ))
            .into());
        }
        let extent = vk::Extent2D {
            width: settings.width,
            height: settings.height,
        };
        let pixels = u64::from(settings.width) * u64::from(settings.height);
        let none = vk::BufferUsageFlags::empty();
        // Written by the frame's own commands (vkCmdUpdateBuffer), so frames can be recorded
        // back to back.
        let uniform = |name: &str, size: usize| {
            Buffer::new(
                ctx,
                name,
                size as u64,
                vk::BufferUsageFlags::UNIFORM_BUFFER,
                MemoryLocation::GpuOnly,
            )
        };
        let storage =
            |name: &str, size: u64| Buffer::new(ctx, name, size, none, MemoryLocation::GpuOnly);
        let frame = uniform("reproject frame", std::mem::size_of::<GpuFrame>())?;
        let params = uniform("reproject params", std::mem::size_of::<GpuParams>())?;
        let caches = [
            storage("reproject cache 0", pixels * CACHE_ENTRY_BYTES)?,
            storage("reproject cache 1", pixels * CACHE_ENTRY_BYTES)?,
        ];
        // Placeholders until track_moving_geometry(): static scenes never read them.
        let anchors = [
            storage("reproject anchors 0", ANCHOR_BYTES)?,
            storage("reproject anchors 1", ANCHOR_BYTES)?,
        ];
        let key_winner = storage(
            "reproject winners and depth keys",
            pixels * KEY_WINNER_BYTES,
        )?;
        let state = storage("reproject states", pixels * 4)?;
        let color = storage("reproject colour", pixels * 16)?;
        let display = storage("reproject display pixels", pixels * 4)?;
        let shown = storage("reproject shown samples", pixels * SHOWN_BYTES)?;
        let jobs = storage("reproject job lists", u64::from(JOB_LISTS) * pixels * 4)?;
        let counters = storage("reproject counters", u64::from(RP_COUNTER_SLOTS) * 4)?;
        let args = Buffer::new(
            ctx,
            "reproject dispatch",
            u64::from(JOB_LISTS) * 16,
            vk::BufferUsageFlags::INDIRECT_BUFFER,
            MemoryLocation::GpuOnly,
        )?;
        let visibility = match path {
            RenderPath::Hybrid => {
                // The cache stores positions and motion, so reprojection rasterizes the full
                // G-buffer.
                Visibility::Raster(Box::new(GbufferPass::new(
                    ctx,
                    &pass,
                    &frame,
                    extent,
                    gbuffer::GbufferLayout::Full,
                )?))
            }
            // The rt path keeps its primary hits in registers (temporal_visibility.comp): 1x1
            // placeholders for the bindings the passes share with the hybrid path.
            RenderPath::RayTraced => Visibility::Traced(
                GBUFFER_FORMATS
                    .iter()
                    .enumerate()
                    .map(|(i, &f)| {
                        Image::new(
                            ctx,
                            &format!("reproject G-buffer placeholder {i}"),
                            vk::Extent2D {
                                width: 1,
                                height: 1,
                            },
                            f,
                            vk::ImageUsageFlags::STORAGE,
                            1,
                        )
                    })
                    .collect::<VkResult<Vec<_>>>()?,
            ),
        };
        let layout = |ray_binding: Binding| {
            let storage = Binding::StorageBuffer;
            let mut b = vec![
                (BINDING_SCENE, Binding::UniformBuffer),
                (
                    BINDING_TEXTURES,
                    Binding::SampledImages(pass.texture_capacity()),
                ),
                (crate::interface::BINDING_RAY_BACKEND, ray_binding),
                (BINDING_FRAME, Binding::UniformBuffer),
                (BINDING_RP_PARAMS, Binding::UniformBuffer),
                (BINDING_RP_KEY_WINNER, storage),
                (BINDING_RP_COUNTERS, storage),
                (BINDING_RP_DISPATCH_ARGS, storage),
            ];
            b.extend(
                (0..GBUFFER_FORMATS.len() as u32)
                    .map(|i| (BINDING_RP_GBUFFER + i, Binding::StorageImage)),
            );
            bindings(&b)
        };
        let push_size = |bytes: usize| bytes as u32;
        let backend = pass.backend.kind();
        let stages = Stage::ALL
            .iter()
            .map(|&stage| {
                let (spirv, name) = stage.shader();
                ComputePipeline::cached(
                    ctx,
                    name,
                    spirv,
                    &layout(Binding::Unused),
                    push_size(std::mem::size_of::<ReprojectPush>()),
                )
            })
            .collect::<VkResult<Vec<_>>>()?;
        let primary = ComputePipeline::cached(
            ctx,
            "reproject visibility",
            primary_spirv(backend),
            &layout(pass.backend.binding()),
            push_size(std::mem::size_of::<VisibilityPush>()),
        )?;
        let trace = ComputePipeline::cached(
            ctx,
            "reproject trace",
            trace_spirv(backend),
            &layout(pass.backend.binding()),
            push_size(std::mem::size_of::<TracePush>()),
        )?;
        // One pass instead of two for the scatter where the device has 64-bit atomics.
        let scatter64 = if ctx.features().buffer_int64_atomics {
            Some(ComputePipeline::cached(
                ctx,
                "reproject scatter (64-bit atomics)",
                crate::shaders::TEMPORAL_SCATTER64_COMP,
                &layout(Binding::Unused),
                0,
            )?)
        } else {
            None
        };
        // One set per pipeline: the buffers that alternate between frames (the caches and
        // anchors) are reached through the addresses in the params, written every frame.
        let make = |pipeline: &ComputePipeline, rays: bool| -> VkResult<DescriptorSet> {
            let set = pipeline.allocate_set()?;
            if rays {
                pass.bind_scene(&set);
            } else {
                pass.scene.bind(&set);
                set.sampled_images(BINDING_TEXTURES, pass.textures);
            }
            let storage = Binding::StorageBuffer;
            set.buffer(BINDING_FRAME, &frame, Binding::UniformBuffer)
                .buffer(BINDING_RP_PARAMS, &params, Binding::UniformBuffer)
                .buffer(BINDING_RP_KEY_WINNER, &key_winner, storage)
                .buffer(BINDING_RP_COUNTERS, &counters, storage)
                .buffer(BINDING_RP_DISPATCH_ARGS, &args, storage);
            for (i, image) in visibility.images().iter().enumerate() {
                set.storage_image(BINDING_RP_GBUFFER + i as u32, image.view());
            }
            Ok(set)
        };
        let sets = [
            make(&stages[0], false)?,
            make(&primary, true)?,
            make(&trace, true)?,
        ];
        let scatter64 = match scatter64 {
            Some(p) => {
                let set = make(&p, false)?;
                Some((p, set))
            }
            None => None,
        };
        let readback = FrameRing::new(
            ctx,
            "reproject readback",
            1,
            pixels,
            RingContents {
                rgba8: true,
                color: options.linear_color,
                aov: false,
                states: true,
            },
        )?;
        let readback = Some(readback);
        let profiler = GpuProfiler::new(ctx, SCOPES_PER_FRAME).ok();
        let mut reprojector = Self {
            scene_scale: renderer.scene_scale(),
            path,
            options,
            settings: settings.clone(),
            stages,
            primary,
            trace,
            sets,
            frame,
            params,
            caches,
            anchors,
            moving: false,
            key_winner,
            scatter64,
            state,
            color,
            jobs,
            shown,
            counters,
            args,
            visibility,
            display,
            readback,
            profiler,
            parity: 0,
            has_history: false,
            visibility_in_general: false,
            prev_view_proj: None,
        };
        if options.moving_geometry {
            reprojector.track_moving_geometry(ctx)?;
        }
        Ok(reprojector)
    }

    /// Device memory of the reprojection buffers and images for `settings` (two caches,
    /// per-pixel keys, winners, states, colour, jobs, tonemapped output, and G-buffer images:
    /// the hybrid path's raster pass needs them; for the rt path, whose are 1x1, the estimate
    /// stays an upper bound).
    ///
    /// With `moving_geometry` the samples' anchors come on top ([`Self::anchor_bytes`]).
    pub fn estimate_bytes(settings: &RenderSettings, moving_geometry: bool) -> u64 {
        let pixels = u64::from(settings.width) * u64::from(settings.height);
        let gbuffer: u64 = GBUFFER_FORMATS
            .iter()
            .map(|&f| match f {
                vk::Format::R16G16B16A16_SFLOAT => 8,
                _ => 16,
            })
            .sum();
        // Per pixel: two caches, the shown records, winner + depth key, state, colour, display
        // pixel, one word per job list, the G-buffer images.
        let per_pixel = 2 * CACHE_ENTRY_BYTES
            + SHOWN_BYTES
            + KEY_WINNER_BYTES
            + 4
            + 16
            + 4
            + 4 * u64::from(JOB_LISTS)
            + gbuffer;
        let anchors = if moving_geometry {
            Self::anchor_bytes(settings)
        } else {
            0
        };
        pixels.saturating_mul(per_pixel).saturating_add(anchors)
    }

    /// Device memory of the samples' anchors on a scene whose geometry moves: two buffers
    /// (one per cache parity) of one [`io::Anchor`] (16 bytes) per pixel.
    pub fn anchor_bytes(settings: &RenderSettings) -> u64 {
        settings.pixels().saturating_mul(2 * ANCHOR_BYTES)
    }

    /// The largest buffer the reprojection reaches through a buffer reference (either sample
    /// cache: `size_of::<CacheEntry>()`, 36 bytes per pixel), to compare with
    /// `maxMemoryAllocationSize`. (The caches, states, shown records, job lists and colours are
    /// not bound as descriptors, so `maxStorageBufferRange` does not limit them.)
    pub fn largest_buffer_bytes(settings: &RenderSettings) -> u64 {
        settings.pixels().saturating_mul(CACHE_ENTRY_BYTES)
    }

    /// Checks, before anything is allocated, that a reprojector for `settings` on `path` fits
    /// the device `info` with `in_use` bytes already allocated: the checks of a full render
    /// of the same path ([`RenderSettings::check_device`], without AOVs; it also covers the one
    /// per-pixel buffer the reprojection binds as a descriptor, the depth keys and winners at
    /// 8 bytes per pixel, smaller than the full render's bound 16-byte pixels), the buffers
    /// reached through buffer references against `maxMemoryAllocationSize`, and
    /// [`Self::estimate_bytes`] plus the full render's estimate against the largest device
    /// heap (the cache and the full render live together: a sequence with `--reference` makes
    /// one per frame), the anchors included with `moving_geometry`
    /// ([`ReuseOptions::moving_geometry`]). [`Self::new`] runs it first, and so does the sequence
    /// driver before it allocates anything.
    pub fn check_device(
        settings: &RenderSettings,
        info: &crate::vk::DeviceInfo,
        path: RenderPath,
        moving_geometry: bool,
        in_use: u64,
    ) -> Result<(), SettingsError> {
        settings.check_device(info, path, false, in_use)?;
        let mib = |b: u64| b.div_ceil(1 << 20);
        let (w, h) = (settings.width, settings.height);
        let fix = "lower the resolution or render without --reproject, --frameless and --adaptive-subsample";
        let largest = Self::largest_buffer_bytes(settings);
        let allocation = info.max_memory_allocation_size;
        if largest > allocation {
            return Err(SettingsError(format!(
                "resolution {w}x{h} with reuse between frames needs a {} MiB sample cache ({CACHE_ENTRY_BYTES} bytes per pixel), but '{}' allocates at most {} MiB at once (maxMemoryAllocationSize); {fix}",
                mib(largest),
                info.name,
                mib(allocation)
            )));
        }
        let cache = Self::estimate_bytes(settings, moving_geometry);
        let full = settings.estimate_bytes(path, false);
        let heap = info.largest_device_heap();
        if cache.saturating_add(full).saturating_add(in_use) > heap {
            return Err(SettingsError(format!(
                "{w}x{h} with reuse between frames needs about {} MiB of device memory for the sample cache and its per-pixel buffers{} plus {} MiB for a full render, on top of {} MiB in use, more than the {} MiB device heap of '{}'; {fix}",
                mib(cache),
                if moving_geometry {
                    " (with the anchors that move samples with their objects)"
                } else {
                    ""
                },
                mib(full),
                mib(in_use),
                mib(heap),
                info.name
            )));
        }
        Ok(())
    }

    /// Makes cached samples move with their objects, for a scene whose geometry moves between
    /// frames (animated transforms, skins, morph targets): allocates the anchor
    /// buffers (16 bytes per pixel, twice) and empties the cache. Each sample then remembers
    /// its instance, triangle and barycentrics, and the scatter recomputes its position and
    /// normal from the frame's transforms and vertices before projecting it
    /// (`shaders/temporal/anchor.glsl`).
    pub fn track_moving_geometry(&mut self, ctx: &Context) -> crate::Result<()> {
        if self.moving {
            return Ok(());
        }
        let bytes = self.settings.pixels().saturating_mul(ANCHOR_BYTES);
        ctx.check_memory(
            "the reprojection's sample anchors",
            Self::anchor_bytes(&self.settings),
        )?;
        let storage = |name: &str| {
            Buffer::new(
                ctx,
                name,
                bytes,
                vk::BufferUsageFlags::empty(),
                MemoryLocation::GpuOnly,
            )
        };
        self.anchors = [
            storage("reproject anchors 0")?,
            storage("reproject anchors 1")?,
        ];
        self.moving = true;
        self.reset();
        Ok(())
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
        let [_, primary, trace] = &self.sets;
        renderer.pass_context().bind_scene(primary);
        renderer.pass_context().bind_scene(trace);
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
        self.scatter64 = None;
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
        draws: &[gbuffer::Draw],
        camera: &Camera,
    ) -> crate::Result<ReprojectedFrame> {
        let mut profiler = self.profiler.take();
        let readback = self
            .readback
            .take()
            .ok_or_else(|| VkError::Limit("reprojection readback in use".into()))?;
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
