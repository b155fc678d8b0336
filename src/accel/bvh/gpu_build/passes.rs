//! Records, pipelines and scratch arrays of the GPU build passes.

use std::sync::Arc;

use super::STATE_WORDS;
use crate::accel::bvh::layout::BvhNode;
use crate::vk::{vk, Buffer, ComputePipeline, Context, MemoryLocation, VkError};

// The records and push constants of the build passes are in the host/shader interface.
pub(super) use crate::interface::bvh::{
    BvhBuildPush as Push, BvhBuildRefs as GpuBuildRefs, BvhRelocatePush as RelocatePush,
    BvhScanPush as ScanPush, BvhTlasLinksPush as TlasLinksPush,
};

pub(super) struct Pipelines {
    pub(super) morton: Arc<ComputePipeline>,
    pub(super) hist: Arc<ComputePipeline>,
    pub(super) scatter: Arc<ComputePipeline>,
    pub(super) scan_reduce: Arc<ComputePipeline>,
    pub(super) scan_top: Arc<ComputePipeline>,
    pub(super) scan_down: Arc<ComputePipeline>,
    pub(super) nn: Arc<ComputePipeline>,
    pub(super) merge: Arc<ComputePipeline>,
    pub(super) compact: Arc<ComputePipeline>,
    pub(super) ploc_prepare: Arc<ComputePipeline>,
    pub(super) collapse_init: Arc<ComputePipeline>,
    pub(super) collapse: Arc<ComputePipeline>,
    pub(super) collapse_prepare: Arc<ComputePipeline>,
    pub(super) relocate: Arc<ComputePipeline>,
    pub(super) tlas_links: Arc<ComputePipeline>,
}

impl Pipelines {
    pub(super) fn new(ctx: &Context) -> Result<Self, VkError> {
        use crate::shaders as s;
        let p = |name: &str, spirv: &[u8], push: usize| {
            ComputePipeline::cached(ctx, name, spirv, &[], push as u32)
        };
        let push = std::mem::size_of::<Push>();
        let scan = std::mem::size_of::<ScanPush>();
        Ok(Self {
            morton: p("bvh build morton", s::BVH_BUILD_MORTON_COMP, push)?,
            hist: p("bvh build radix hist", s::BVH_BUILD_RADIX_HIST_COMP, push)?,
            scatter: p(
                "bvh build radix scatter",
                s::BVH_BUILD_RADIX_SCATTER_COMP,
                push,
            )?,
            scan_reduce: p("bvh build scan reduce", s::BVH_BUILD_SCAN_REDUCE_COMP, scan)?,
            scan_top: p("bvh build scan top", s::BVH_BUILD_SCAN_TOP_COMP, scan)?,
            scan_down: p("bvh build scan down", s::BVH_BUILD_SCAN_DOWN_COMP, scan)?,
            nn: p("bvh build ploc nn", s::BVH_BUILD_PLOC_NN_COMP, push)?,
            merge: p("bvh build ploc merge", s::BVH_BUILD_PLOC_MERGE_COMP, push)?,
            compact: p(
                "bvh build ploc compact",
                s::BVH_BUILD_PLOC_COMPACT_COMP,
                push,
            )?,
            ploc_prepare: p(
                "bvh build ploc prepare",
                s::BVH_BUILD_PLOC_PREPARE_COMP,
                push,
            )?,
            collapse_init: p(
                "bvh build collapse init",
                s::BVH_BUILD_COLLAPSE_INIT_COMP,
                push,
            )?,
            collapse: p("bvh build collapse", s::BVH_BUILD_COLLAPSE_COMP, push)?,
            collapse_prepare: p(
                "bvh build collapse prepare",
                s::BVH_BUILD_COLLAPSE_PREPARE_COMP,
                push,
            )?,
            relocate: p(
                "bvh build relocate",
                s::BVH_BUILD_RELOCATE_COMP,
                std::mem::size_of::<RelocatePush>(),
            )?,
            tlas_links: p(
                "bvh build tlas links",
                s::BVH_BUILD_TLAS_LINKS_COMP,
                std::mem::size_of::<TlasLinksPush>(),
            )?,
        })
    }
}

/// Radix-sort blocks (256 keys) of `n` keys.
pub(super) fn sort_blocks(n: u64) -> u64 {
    n.div_ceil(256).max(1)
}

/// Words of the flags array: PLOC keep flags (n) or radix histograms (16 per block).
pub(super) fn flag_words(n: u64) -> u64 {
    n.max(16 * sort_blocks(n))
}

/// Byte sizes of the scratch arrays for geometries of up to `n` triangles, in the order of
/// [`Scratch::new`].
pub(super) fn scratch_sizes(n: u64) -> [(&'static str, u64); 15] {
    let n = n.max(1);
    let binary = 2 * n - 1;
    [
        ("input triangles", 40 * n),
        ("boxes", 24 * binary),
        ("children", 8 * n),
        ("info", 4 * binary),
        ("cost", 4 * binary),
        ("keys0", 4 * n),
        ("keys1", 4 * n),
        ("vals0", 4 * n),
        ("vals1", 4 * n),
        ("flags", 4 * flag_words(n)),
        ("sums", 4 * (flag_words(n).div_ceil(1024) + 1)),
        // A 4-wide tree has at most one node per binary inner node (n - 1), or one in all.
        ("wide nodes", std::mem::size_of::<BvhNode>() as u64 * n),
        // Items of one level are disjoint subtrees of at least two triangles each.
        ("queue0", 16 * (n / 2 + 1)),
        ("queue1", 16 * (n / 2 + 1)),
        // Per inner binary node, its subtree's 4-wide node count (depth-first placement).
        ("wide node counts", 4 * n),
    ]
}

/// Peak scratch bytes of a GPU build whose largest geometry has `n` triangles (plus the
/// state and refs records).
pub fn scratch_bytes(n: usize) -> u64 {
    scratch_sizes(n as u64).iter().map(|s| s.1).sum::<u64>()
        + (STATE_WORDS * 4 + std::mem::size_of::<GpuBuildRefs>()) as u64
}

/// The scratch arrays, sized for the largest geometry and reused for every one.
pub(super) struct Scratch {
    pub(super) arrays: Vec<Buffer>,
    pub(super) state: Buffer,
    pub(super) refs: Buffer,
}

impl Scratch {
    pub(super) fn new(ctx: &Context, n: usize) -> Result<Self, VkError> {
        let arrays = scratch_sizes(n as u64)
            .iter()
            .map(|(name, bytes)| {
                Buffer::new(
                    ctx,
                    &format!("bvh build {name}"),
                    *bytes,
                    vk::BufferUsageFlags::empty(),
                    MemoryLocation::GpuOnly,
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        let state = Buffer::new(
            ctx,
            "bvh build state",
            (STATE_WORDS * 4) as u64,
            vk::BufferUsageFlags::INDIRECT_BUFFER,
            MemoryLocation::CpuToGpu,
        )?;
        let refs = Buffer::new(
            ctx,
            "bvh build refs",
            std::mem::size_of::<GpuBuildRefs>() as u64,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::CpuToGpu,
        )?;
        Ok(Self {
            arrays,
            state,
            refs,
        })
    }

    pub(super) fn read_state(&self, ctx: &Context) -> Result<Vec<u32>, VkError> {
        self.state.read(ctx)
    }
}
