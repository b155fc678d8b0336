//! Compute rasterizer of the hybrid path's visibility buffer (`--raster compute`): the same
//! (instance, primitive) image `gbuffer_visibility.frag` writes, produced by compute shaders instead of
//! the graphics pipeline, for GPUs whose graphics units are scarce next to their compute units
//! (H100 and H200 run graphics on 2 of 66 TPCs).
//!
//! Stages (`shaders/raster_compute/raster_*.comp`, rules in `shaders/common/raster.glsl`), tile-binned as in
//! Laine & Karras 2011 ("High-Performance Software Rasterization on GPUs") for every triangle
//! that is not small:
//! 1. `raster_triangles`: one invocation per scene triangle transforms, culls and sets it up;
//!    small unclipped triangles are rasterized on the spot, the others are queued;
//! 2. `raster_bin` (three pipelines of one shader): count the 16×16-pixel tiles each queued
//!    triangle's bounding box touches (after near-plane and guard-band clipping), scan the
//!    counts into per-tile offsets, fill per-tile triangle lists;
//! 3. `raster_tiles`: one workgroup per tile, one invocation per pixel, walks the tile's list
//!    with coverage and depth in registers and makes one depth test per pixel;
//! 4. `raster_resolve`: per pixel, the winning global triangle id becomes (instance, primitive).
//!
//! The depth test is a per-pixel atomic minimum of `depth bits << 32 | triangle id` where the
//! device has `shaderBufferInt64Atomics`, else two passes of 32-bit atomics (depth, then the
//! lowest id at that depth). Both resolve ties to the lowest id.

use std::sync::Arc;

use ash::vk;

use super::draw_list::Draw;
use crate::render::PassContext;
use crate::vk::{
    memory_barrier, Binding, Buffer, ComputePipeline, Context, DescriptorSet, Image,
    MemoryLocation, VkError, VkResult,
};

/// What runs the hybrid path's visibility pass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RasterMode {
    /// The graphics pipeline (`gbuffer.vert` + `gbuffer_visibility.frag`).
    #[default]
    Graphics,
    /// The compute rasterizer of this module (64-bit atomics where the device has them).
    Compute,
    /// The compute rasterizer on its 32-bit-atomic fallback even where 64-bit atomics exist
    /// (how devices without `shaderBufferInt64Atomics` run `compute`; for tests and checks).
    #[value(name = "compute-atomic32")]
    #[serde(rename = "compute-atomic32")]
    ComputeAtomic32,
}

impl RasterMode {
    /// `"graphics"` or `"compute"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Graphics => "graphics",
            Self::Compute => "compute",
            Self::ComputeAtomic32 => "compute-atomic32",
        }
    }
}

/// What the user asked for with `--raster`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RasterChoice {
    /// The faster of the two on this device, measured once per device and driver
    /// ([`crate::device_select::autotune`]); graphics under `RQR_NO_AUTOTUNE=1`.
    #[default]
    Auto,
    /// The graphics pipeline.
    Graphics,
    /// The compute rasterizer.
    Compute,
    /// The compute rasterizer on its 32-bit-atomic fallback.
    #[value(name = "compute-atomic32")]
    #[serde(rename = "compute-atomic32")]
    ComputeAtomic32,
}

impl RasterChoice {
    /// The forced mode, or `None` for `auto`.
    pub fn forced(self) -> Option<RasterMode> {
        match self {
            Self::Auto => None,
            Self::Graphics => Some(RasterMode::Graphics),
            Self::Compute => Some(RasterMode::Compute),
            Self::ComputeAtomic32 => Some(RasterMode::ComputeAtomic32),
        }
    }
}

/// How the compute rasterizer resolves the depth test.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthAtomics {
    /// One pass of 64-bit `atomicMin(depth << 32 | id)` (`shaderBufferInt64Atomics`).
    Int64,
    /// Two passes of 32-bit atomics: depth, then the lowest id at the minimum depth.
    Int32,
}

impl DepthAtomics {
    /// The one-pass path when the device has 64-bit buffer atomics, else the fallback.
    pub fn best(ctx: &Context) -> Self {
        if ctx.features().buffer_int64_atomics {
            Self::Int64
        } else {
            Self::Int32
        }
    }
}

use crate::interface::{
    self as io, bindings, push_bytes, RasterDraw, RasterPush, DRAW_ALPHA_TEST, DRAW_CULL_BACK,
    DRAW_MIRRORED,
};

/// Workgroups of `raster_bin.comp`'s count and fill stages (256 invocations each, looping over
/// the queue).
const BIN_WORKGROUPS: u32 = 128;
/// Side of a screen tile of the binned stages.
const TILE_SIZE: u32 = io::RASTER_TILE_SIZE;
/// Entries of the per-tile triangle lists. A (triangle, tile) pair beyond it is rasterized by
/// the binning invocation itself (correct, slower), so this bounds memory, not the scene.
const BIN_CAPACITY: u64 = 1 << 21;
/// Environment variable that lowers the tile lists' capacity (2²¹ entries; tests of the
/// overflow path).
pub const BIN_CAPACITY_ENV: &str = "RQR_RASTER_BIN_CAPACITY";
/// Most workgroups of `raster_triangles.comp` (grid-stride beyond).
const MAX_TRIANGLE_WORKGROUPS: u32 = 65_535;

/// The compute rasterizer's pipelines and buffers for one image size and scene.
pub struct ComputeRaster {
    triangles: Arc<ComputePipeline>,
    /// `raster_bin.comp`: count, scan, fill.
    bin: [Arc<ComputePipeline>; 3],
    tiles: Arc<ComputePipeline>,
    resolve: Arc<ComputePipeline>,
    /// Per pipeline: triangles, count, scan, fill, tiles, resolve.
    sets: [DescriptorSet; 6],
    depth_ids: Buffer,
    _draws: Buffer,
    queue: Buffer,
    bins: Buffer,
    tile_grid: [u32; 2],
    triangle_count: u32,
    draw_count: u32,
    atomics: DepthAtomics,
    extent: vk::Extent2D,
}

impl ComputeRaster {
    /// Creates the rasterizer for `draws` at `extent`, writing `visibility` (an `R32G32_UINT`
    /// storage image); `frame` is the Frame uniform (camera, jitter).
    pub fn new(
        ctx: &Context,
        pass: &PassContext<'_>,
        frame: &Buffer,
        extent: vk::Extent2D,
        draws: &[Draw],
        visibility: &Image,
        atomics: DepthAtomics,
    ) -> VkResult<Self> {
        if atomics == DepthAtomics::Int64 && !ctx.features().buffer_int64_atomics {
            return Err(VkError::MissingFeature {
                device: ctx.info().name.clone(),
                feature: "shaderBufferInt64Atomics (the 64-bit atomic compute rasterizer)".into(),
            });
        }
        let mut table = Vec::with_capacity(draws.len());
        let mut triangles = 0u64;
        for d in draws {
            let mut flags = 0;
            if d.cull_back {
                flags |= DRAW_CULL_BACK;
            }
            if d.mirrored {
                flags |= DRAW_MIRRORED;
            }
            if d.alpha_test {
                flags |= DRAW_ALPHA_TEST;
            }
            table.push(RasterDraw {
                first_triangle: triangles as u32,
                instance: d.instance,
                flags,
            });
            triangles += u64::from(d.vertex_count / 3);
        }
        // Global ids are 32-bit and 0xFFFFFFFF means "empty".
        let triangle_count = u32::try_from(triangles)
            .ok()
            .filter(|&n| n < u32::MAX)
            .ok_or_else(|| {
                VkError::Limit {
                    what: format!(
                        "the compute rasterizer numbers triangles in 32 bits; the scene draws {triangles}"
                    ),
                    needed: triangles,
                    available: u64::from(u32::MAX) - 1,
                }
            })?;
        let pixels = u64::from(extent.width) * u64::from(extent.height);
        let depth_bytes = pixels * 8;
        let queue_bytes = (u64::from(triangle_count) + 1) * 4;
        let tile_grid = [
            extent.width.div_ceil(TILE_SIZE),
            extent.height.div_ceil(TILE_SIZE),
        ];
        let tile_count = u64::from(tile_grid[0]) * u64::from(tile_grid[1]);
        let capacity = std::env::var(BIN_CAPACITY_ENV)
            .ok()
            .and_then(|v| v.parse::<u64>().ok())
            .map_or(BIN_CAPACITY, |c| c.clamp(1, BIN_CAPACITY));
        let bin_bytes = (3 * tile_count + capacity) * 4;
        ctx.check_memory("compute rasterizer", depth_bytes + queue_bytes + bin_bytes)?;
        let depth_ids = Buffer::new(
            ctx,
            "raster depth|id",
            depth_bytes,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::GpuOnly,
        )?;
        let queue = Buffer::new(
            ctx,
            "raster big-triangle queue",
            queue_bytes,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::GpuOnly,
        )?;
        let bins = Buffer::new(
            ctx,
            "raster tile bins",
            bin_bytes,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::GpuOnly,
        )?;
        let draws_buffer = if table.is_empty() {
            Buffer::new(
                ctx,
                "raster draws",
                4,
                vk::BufferUsageFlags::empty(),
                MemoryLocation::GpuOnly,
            )?
        } else {
            Buffer::from_slice(ctx, "raster draws", &table, vk::BufferUsageFlags::empty())?
        };
        let layout = bindings(&[
            (io::BINDING_SCENE, Binding::UniformBuffer),
            (
                io::BINDING_TEXTURES,
                Binding::SampledImages(pass.texture_capacity()),
            ),
            (io::BINDING_FRAME, Binding::UniformBuffer),
            (io::BINDING_RASTER_DEPTH_IDS, Binding::StorageBuffer),
            (io::BINDING_RASTER_DRAWS, Binding::StorageBuffer),
            (io::BINDING_RASTER_BIG, Binding::StorageBuffer),
            (io::BINDING_RASTER_VISIBILITY, Binding::StorageImage),
            (io::BINDING_RASTER_BINS, Binding::StorageBuffer),
        ]);
        use crate::shaders as s;
        let (tri_spv, bin_spv, tiles_spv, resolve_spv) = match atomics {
            DepthAtomics::Int64 => (
                s::RASTER_TRIANGLES_COMP_ATOMIC64,
                s::RASTER_BIN_COMP_ATOMIC64,
                s::RASTER_TILES_COMP_ATOMIC64,
                s::RASTER_RESOLVE_COMP_ATOMIC64,
            ),
            DepthAtomics::Int32 => (
                s::RASTER_TRIANGLES_COMP_ATOMIC32,
                s::RASTER_BIN_COMP_ATOMIC32,
                s::RASTER_TILES_COMP_ATOMIC32,
                s::RASTER_RESOLVE_COMP_ATOMIC32,
            ),
        };
        let push_size = std::mem::size_of::<RasterPush>() as u32;
        let make =
            |name: &str, spv: &[u8]| ComputePipeline::cached(ctx, name, spv, &layout, push_size);
        let bin_stage = |stage: u32| {
            ComputePipeline::cached_specialized(
                ctx,
                "raster bin",
                bin_spv,
                &layout,
                push_size,
                &[stage],
            )
        };
        let triangles = make("raster triangles", tri_spv)?;
        let bin = [
            bin_stage(io::RASTER_BIN_COUNT)?,
            bin_stage(io::RASTER_BIN_SCAN)?,
            bin_stage(io::RASTER_BIN_FILL)?,
        ];
        let tiles = make("raster tiles", tiles_spv)?;
        let resolve = make("raster resolve", resolve_spv)?;
        let bind = |p: &ComputePipeline| -> VkResult<DescriptorSet> {
            let set = p.allocate_set()?;
            pass.scene.bind(&set);
            set.sampled_images(io::BINDING_TEXTURES, pass.textures)
                .buffer(io::BINDING_FRAME, frame, Binding::UniformBuffer)
                .buffer(
                    io::BINDING_RASTER_DEPTH_IDS,
                    &depth_ids,
                    Binding::StorageBuffer,
                )
                .buffer(
                    io::BINDING_RASTER_DRAWS,
                    &draws_buffer,
                    Binding::StorageBuffer,
                )
                .buffer(io::BINDING_RASTER_BIG, &queue, Binding::StorageBuffer)
                .storage_image(io::BINDING_RASTER_VISIBILITY, visibility.view())
                .buffer(io::BINDING_RASTER_BINS, &bins, Binding::StorageBuffer);
            Ok(set)
        };
        let sets = [
            bind(&triangles)?,
            bind(&bin[0])?,
            bind(&bin[1])?,
            bind(&bin[2])?,
            bind(&tiles)?,
            bind(&resolve)?,
        ];
        Ok(Self {
            triangles,
            bin,
            tiles,
            resolve,
            sets,
            depth_ids,
            _draws: draws_buffer,
            queue,
            bins,
            tile_grid,
            triangle_count,
            draw_count: table.len() as u32,
            atomics,
            extent,
        })
    }

    /// Which depth-test path this rasterizer runs.
    pub fn atomics(&self) -> DepthAtomics {
        self.atomics
    }

    /// Records the rasterization; the visibility image must be in `GENERAL` layout.
    pub fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let device = ctx.device();
        // SAFETY: recording command buffer; both buffers are ours and have TRANSFER_DST.
        unsafe {
            device.cmd_fill_buffer(cmd, self.depth_ids.raw(), 0, vk::WHOLE_SIZE, u32::MAX);
            device.cmd_fill_buffer(cmd, self.queue.raw(), 0, 4, 0);
            // The per-tile counts start at zero (offsets and cursors are written by the scan).
            let counts = 4 * u64::from(self.tile_grid[0]) * u64::from(self.tile_grid[1]);
            device.cmd_fill_buffer(cmd, self.bins.raw(), 0, counts, 0);
        }
        memory_barrier(device, cmd);
        let passes: &[u32] = match self.atomics {
            DepthAtomics::Int64 => &[0],
            DepthAtomics::Int32 => &[0, 1],
        };
        let triangle_groups = self
            .triangle_count
            .div_ceil(64)
            .clamp(1, MAX_TRIANGLE_WORKGROUPS);
        for &pass_kind in passes {
            let push = RasterPush {
                triangle_count: self.triangle_count,
                draw_count: self.draw_count,
                pass_kind,
            };
            let push = push_bytes(&push);
            if self.triangle_count > 0 {
                self.triangles
                    .dispatch(cmd, Some(&self.sets[0]), push, [triangle_groups, 1, 1]);
                memory_barrier(device, cmd);
                // The id pass of the atomic32 path keeps the depth pass's counts but fills the
                // lists again: the pairs over capacity are rasterized by the fill itself, and
                // must be in this pass too.
                let first_stage = if pass_kind == 0 { 0 } else { 1 };
                for (stage, groups) in [(0, BIN_WORKGROUPS), (1, 1), (2, BIN_WORKGROUPS)]
                    .into_iter()
                    .skip(first_stage)
                {
                    self.bin[stage].dispatch(
                        cmd,
                        Some(&self.sets[1 + stage]),
                        push,
                        [groups, 1, 1],
                    );
                    memory_barrier(device, cmd);
                }
                self.tiles.dispatch(
                    cmd,
                    Some(&self.sets[4]),
                    push,
                    [self.tile_grid[0], self.tile_grid[1], 1],
                );
                memory_barrier(device, cmd);
            }
        }
        let push = RasterPush {
            triangle_count: self.triangle_count,
            draw_count: self.draw_count,
            pass_kind: 0,
        };
        self.resolve.dispatch(
            cmd,
            Some(&self.sets[5]),
            push_bytes(&push),
            [
                self.extent.width.div_ceil(8),
                self.extent.height.div_ceil(8),
                1,
            ],
        );
    }
}
