//! The technique's per-resolution resources: the two sample caches and their anchors, the
//! per-pixel buffers, counters and dispatch arguments, and the G-buffer ([`Resources`]); what
//! they cost ([`Reprojector::estimate_bytes`]) and whether they fit
//! ([`Reprojector::check_device`]), checked with the rest of the inputs before anything is
//! allocated ([`Reprojector::validate`]).

use ash::vk;

use super::options::check_sampling;
use super::{Reprojector, ReuseOptions};
use crate::interface::reproject::{
    self as io, JOB_LISTS, MAX_CACHE_MATERIALS, REFRESH_SEGMENT, RP_COUNTER_SLOTS,
};
use crate::render::frame::GpuFrame;
use crate::render::passes::gbuffer::{self, GbufferPass, GBUFFER_FORMATS};
use crate::render::settings::{RenderPath, RenderSettings};
use crate::render::{PassContext, Renderer};
use crate::vk::{Buffer, Context, Image, MemoryLocation, VkError, VkResult};

/// A cache entry's and a shown sample's size (`src/interface/reproject.rs`).
pub(super) const CACHE_ENTRY_BYTES: u64 = std::mem::size_of::<io::CacheEntry>() as u64;
const SHOWN_BYTES: u64 = std::mem::size_of::<io::Shown>() as u64;
/// Per pixel: the index of the sample that won it and its depth key.
const KEY_WINNER_BYTES: u64 = 8;
const ANCHOR_BYTES: u64 = std::mem::size_of::<io::Anchor>() as u64;

/// G-buffer images: the raster pass's (hybrid) or placeholders (rt, which keeps its primary
/// hits in registers).
pub(super) enum Gbuffer {
    Raster(Box<GbufferPass>),
    Traced(Vec<Image>),
}

impl Gbuffer {
    pub(super) fn images(&self) -> &[Image] {
        match self {
            Self::Raster(g) => &g.images,
            Self::Traced(images) => images,
        }
    }
}

/// Every buffer and image of one resolution that the passes share.
pub(super) struct Resources {
    /// The frame uniform (camera, previous view-projection), written by each frame's commands.
    pub(super) frame: Buffer,
    /// The `Params` uniform (flags, thresholds, the per-pixel buffers' addresses).
    pub(super) params: Buffer,
    /// The sample caches, one read and one written per frame (by parity).
    pub(super) caches: [Buffer; 2],
    /// Per cache parity: the samples' anchors (`interface::reproject::Anchor`), with
    /// [`Reprojector::track_moving_geometry`]; placeholders of one anchor otherwise.
    pub(super) anchors: [Buffer; 2],
    /// Per pixel: the winning sample's index and its depth key (interleaved u32 pairs).
    pub(super) key_winner: Buffer,
    /// Per pixel: the `PX_*` state.
    pub(super) state: Buffer,
    /// Per pixel: linear colour.
    pub(super) color: Buffer,
    /// The job lists.
    pub(super) jobs: Buffer,
    /// Per pixel: the sample it shows after the scatter (`Shown`).
    pub(super) shown: Buffer,
    /// Counter slots (`C_*`).
    pub(super) counters: Buffer,
    /// Indirect dispatch of the tracing passes, sized by their job lists.
    pub(super) args: Buffer,
    /// The G-buffer images (and the hybrid path's raster pass).
    pub(super) gbuffer: Gbuffer,
    /// The frame's display pixels (RGBA8), written with the colour (tonemapping fused into
    /// the passes that write colour).
    pub(super) display: Buffer,
}

impl Resources {
    /// Allocates an empty cache and the per-pixel buffers for images of `settings` on `path`
    /// (anchors as placeholders: [`Reprojector::track_moving_geometry`] allocates them).
    pub(super) fn allocate(
        ctx: &Context,
        pass: &PassContext<'_>,
        path: RenderPath,
        settings: &RenderSettings,
    ) -> crate::Result<Self> {
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
        let params = uniform("reproject params", std::mem::size_of::<io::GpuParams>())?;
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
        let gbuffer = match path {
            RenderPath::Hybrid => {
                // The cache stores positions and motion, so reprojection rasterizes the full
                // G-buffer.
                Gbuffer::Raster(Box::new(GbufferPass::new(
                    ctx,
                    pass,
                    &frame,
                    extent,
                    gbuffer::GbufferLayout::Full,
                )?))
            }
            // The rt path keeps its primary hits in registers (temporal_verify.comp): 1x1
            // placeholders for the bindings the passes share with the hybrid path.
            RenderPath::RayTraced => Gbuffer::Traced(
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
        Ok(Self {
            frame,
            params,
            caches,
            anchors,
            key_winner,
            state,
            color,
            jobs,
            shown,
            counters,
            args,
            gbuffer,
            display,
        })
    }
}

impl Reprojector {
    /// Checks everything [`Self::new`] needs before anything is allocated: the sampling
    /// ([`check_sampling`]), the options' ranges, the device's memory and limits
    /// ([`Self::check_device`]), its subgroups (frameless rendering) and the scene's material
    /// count (16 bits per cached sample).
    pub(super) fn validate(
        ctx: &Context,
        renderer: &Renderer,
        path: RenderPath,
        settings: &RenderSettings,
        options: &ReuseOptions,
    ) -> crate::Result<()> {
        Self::check_device(
            settings,
            ctx.info(),
            path,
            options.moving_geometry,
            ctx.allocated_bytes(),
        )?;
        options.validate()?;
        check_sampling(settings)?;
        let subgroup = ctx.info().subgroup_size;
        if options.frameless_percent.is_some() && subgroup % REFRESH_SEGMENT != 0 {
            return Err(VkError::MissingFeature {
                device: ctx.info().name.clone(),
                feature: format!(
                    "subgroups of a multiple of {REFRESH_SEGMENT} invocations (it has {subgroup}; --frameless counts candidates per {REFRESH_SEGMENT}-pixel row segment with one cluster of subgroup invocations)"
                ),
            }
            .into());
        }
        let materials = renderer.pass_context().scene.materials.size()
            / std::mem::size_of::<crate::scene::layout::GpuMaterial>() as u64;
        if options.reuses() && materials > u64::from(MAX_CACHE_MATERIALS) {
            return Err(VkError::Limit {
                what: format!(
                    "reprojection caches a 16-bit material index per sample: the scene has {materials} materials (at most {MAX_CACHE_MATERIALS})"
                ),
                needed: materials,
                available: MAX_CACHE_MATERIALS.into(),
            }
            .into());
        }
        Ok(())
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
    ) -> crate::Result<()> {
        settings.check_device(info, path, false, in_use)?;
        let mib = |b: u64| b.div_ceil(1 << 20);
        let (w, h) = (settings.width, settings.height);
        let fix = "lower the resolution or render without --reproject, --frameless and --adaptive-subsample";
        let largest = Self::largest_buffer_bytes(settings);
        let allocation = info.max_memory_allocation_size;
        if largest > allocation {
            return Err(VkError::Limit {
                what: format!(
                "resolution {w}x{h} with reuse between frames needs a {} MiB sample cache ({CACHE_ENTRY_BYTES} bytes per pixel), but '{}' allocates at most {} MiB at once (maxMemoryAllocationSize); {fix}",
                mib(largest),
                info.name,
                mib(allocation)
            ),
                needed: largest,
                available: allocation,
            }
            .into());
        }
        let cache = Self::estimate_bytes(settings, moving_geometry);
        let full = settings.estimate_bytes(path, false);
        let heap = info.largest_device_heap();
        if cache.saturating_add(full).saturating_add(in_use) > heap {
            return Err(VkError::Limit {
                what: format!(
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
            ),
                needed: cache.saturating_add(full).saturating_add(in_use),
                available: heap,
            }
            .into());
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
        self.res.anchors = [
            storage("reproject anchors 0")?,
            storage("reproject anchors 1")?,
        ];
        self.moving = true;
        self.reset();
        Ok(())
    }
}
