//! GPU build of the bottom levels (`--bvh-build gpu`): compute shaders in
//! `shaders/bvh_build/` turn each geometry's triangles into the same 4-wide quantized node
//! layout the host build produces ([`super::layout`]), so the traversal shader is shared.
//!
//! Per geometry, in one command buffer with barriers between passes:
//! 1. **Morton**: box, SAH cost and 30-bit Morton code of every triangle's centroid.
//! 2. **Sort**: LSD radix sort of (code, triangle) pairs, 4 bits per pass (8 passes), each a
//!    per-block digit histogram, a three-step exclusive scan and a stable scatter.
//! 3. **Clustering**: PLOC (Meister & Bittner 2018) with the host build's search radius:
//!    nearest neighbour by merged-box area, merge of mutual neighbours, scan + compaction.
//!    Iterations run as indirect dispatches sized by the GPU; the host records them in chunks
//!    of `PLOC_CHUNK` and reads one counter between chunks. Merges also decide, bottom-up by
//!    SAH, which subtrees of at most `max_leaf_size` triangles become one leaf.
//! 4. **Collapse**: top-down, one dispatch per level of the 4-wide tree: each binary node
//!    opens its largest-area inner children until it has four (as `builder::flatten` does),
//!    copies leaf triangles into place and quantizes the child boxes like `BvhNode::new`.
//!    Nodes go to depth-first pre-order positions, the host build's layout (checked by
//!    [`super::locality::check_depth_first`]): the PLOC merges count, bottom-up, how many wide
//!    nodes each subtree becomes, so a node's children get their indices without a scan.
//!
//! The nodes of every bottom level are copied behind room reserved for the top level with
//! their links shifted (`relocate`); the top level is then built by the same passes over the
//! instances' world boxes ([`tlas`]), and rebuilt in place by [`GpuBvh::rebuild_tlas`].

use std::time::Instant;

use obvhs::aabb::Aabb as ObAabb;

mod passes;
pub mod tlas;

pub use passes::scratch_bytes;
use passes::{sort_blocks, GpuBuildRefs, Pipelines, Push, RelocatePush, ScanPush, Scratch};

use super::builder::{self, gather_geometry, max_abs, GeometryTris};
use super::layout::{BvhNode, BvhTriangle, LINK_FIRST_MASK, MAX_LEAF_PRIMITIVES};
use super::{BvhBuildOptions, BvhData, BvhError, BvhStats, GpuBvh, PlocSearch};
// Words of the state buffer, shared with the shaders.
use crate::interface::bvh::{
    STATE_ARGS_BLOCKS, STATE_ARGS_COLLAPSE, STATE_ARGS_ELEMS, STATE_ARGS_SINGLE, STATE_CLUSTERS,
    STATE_CLUSTERS_NEXT, STATE_ERROR, STATE_HIST_COUNT, STATE_ITERATIONS, STATE_MAX_DEPTH,
    STATE_MAX_STACK, STATE_QUEUE0, STATE_WIDE_COUNT, STATE_WORDS,
};
use crate::scene::Scene;
use crate::vk::{
    memory_barrier, vk, Buffer, ComputePipeline, Context, GpuProfiler, MemoryLocation,
};

/// Most triangles of one geometry the GPU build takes: its scans cover 1024 × 16384 elements.
pub const GPU_BUILD_MAX_TRIANGLES: usize = 1 << 24;

/// PLOC iterations recorded per submission (the host checks for convergence in between).
const PLOC_CHUNK: u32 = 16;
/// Collapse levels recorded per submission.
const COLLAPSE_CHUNK: u32 = 16;
/// More levels than any tree the traversal stack accepts can have (each level pushes ≥ 1).
const MAX_COLLAPSE_LEVELS: u32 = 128;

/// GPU milliseconds per build phase, summed over every bottom level.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct GpuBuildPhases {
    /// Leaf boxes and Morton codes.
    pub morton_ms: f64,
    /// Radix sort.
    pub sort_ms: f64,
    /// PLOC iterations.
    pub clustering_ms: f64,
    /// Collapse into 4-wide quantized nodes.
    pub collapse_ms: f64,
    /// Copy of every bottom level behind the top level.
    pub relocate_ms: f64,
    /// Top level (all its passes).
    pub tlas_ms: f64,
    /// PLOC iterations of the largest geometry.
    pub ploc_iterations: u32,
}

impl GpuBuildPhases {
    fn add(&mut self, results: &[(String, f64)]) {
        for (name, ms) in results {
            match name.as_str() {
                "morton" => self.morton_ms += ms,
                "sort" => self.sort_ms += ms,
                "clustering" => self.clustering_ms += ms,
                "collapse" => self.collapse_ms += ms,
                "relocate" => self.relocate_ms += ms,
                _ => {}
            }
        }
    }

    /// Sum of the phases.
    pub fn total_ms(&self) -> f64 {
        self.morton_ms
            + self.sort_ms
            + self.clustering_ms
            + self.collapse_ms
            + self.relocate_ms
            + self.tlas_ms
    }
}

/// One bottom level built on the GPU, nodes with local indices.
struct BuiltBlas {
    nodes: Buffer,
    node_count: u32,
    depth: u32,
    stack: u32,
    iterations: u32,
}

struct Builder<'a> {
    ctx: &'a Context,
    p: Pipelines,
    scratch: Scratch,
    refs: GpuBuildRefs,
    profiler: Option<GpuProfiler>,
    phases: GpuBuildPhases,
}

fn radius(search: PlocSearch) -> u32 {
    match search {
        PlocSearch::Minimum => 1,
        PlocSearch::Low => 6,
        PlocSearch::Medium => 14,
        PlocSearch::High => 24,
    }
}

impl<'a> Builder<'a> {
    /// Pipelines and scratch arrays for geometries of up to `max_n` triangles whose leaves go
    /// to the triangle array at `tris_out`.
    fn new(
        ctx: &'a Context,
        max_n: usize,
        tris_out: u64,
        opts: &BvhBuildOptions,
        max_leaf: u32,
    ) -> Result<Self, BvhError> {
        let scratch = Scratch::new(ctx, max_n)?;
        let addr = |i: usize| scratch.arrays[i].address();
        let refs = GpuBuildRefs {
            tris_in: addr(0),
            tris_out,
            boxes: addr(1),
            children: addr(2),
            info: addr(3),
            cost: addr(4),
            keys0: addr(5),
            keys1: addr(6),
            vals0: addr(7),
            vals1: addr(8),
            flags: addr(9),
            sums: addr(10),
            state: scratch.state.address(),
            nodes: addr(11),
            queue0: addr(12),
            queue1: addr(13),
            wide: addr(14),
            max_leaf,
            traversal_cost: opts.collapse_traversal_cost,
            radius: radius(opts.search),
            ..Default::default()
        };
        Ok(Self {
            ctx,
            p: Pipelines::new(ctx)?,
            scratch,
            refs,
            profiler: if ctx.features().timestamps {
                Some(GpuProfiler::new(ctx, 8)?)
            } else {
                None
            },
            phases: GpuBuildPhases::default(),
        })
    }

    fn push(&self, a: u32, b: u32) -> Push {
        Push {
            refs: self.scratch.refs.address(),
            a,
            b,
        }
    }

    fn barrier(&self, cmd: vk::CommandBuffer) {
        memory_barrier(self.ctx.device(), cmd);
    }

    fn begin(&mut self, cmd: vk::CommandBuffer, name: &str) {
        if let Some(p) = &mut self.profiler {
            p.begin(cmd, name);
        }
    }

    fn end(&mut self, cmd: vk::CommandBuffer) {
        if let Some(p) = &mut self.profiler {
            p.end(cmd);
        }
    }

    /// Runs `record` in one submission with the profiler reset first and its scopes added
    /// to the phase totals afterwards.
    fn run(
        &mut self,
        pass: &str,
        record: impl FnOnce(&mut Self, vk::CommandBuffer),
    ) -> Result<(), BvhError> {
        let ctx = self.ctx;
        ctx.run(pass, |cmd| {
            // Earlier submissions wrote or read the same scratch arrays.
            memory_barrier(ctx.device(), cmd);
            if let Some(p) = &mut self.profiler {
                p.reset(cmd);
            }
            record(self, cmd);
            self.end(cmd);
            Ok(())
        })?;
        if let Some(p) = &self.profiler {
            let results = p.results()?;
            self.phases.add(&results);
        }
        Ok(())
    }

    /// Exclusive scan of the `u32`s at `data`, whose count is the word at `count`; the total
    /// goes to the word at `total` (0: nowhere). `blocks`: direct workgroup count, or `None`
    /// for the indirect arguments the PLOC prepare pass wrote.
    fn record_scan(
        &self,
        cmd: vk::CommandBuffer,
        data: u64,
        count: u64,
        total: u64,
        blocks: Option<u32>,
    ) {
        let push = ScanPush {
            data,
            sums: self.scratch.arrays[10].address(),
            count,
            total,
        };
        let bytes = bytemuck::bytes_of(&push);
        let state = &self.scratch.state;
        // Direct with `blocks` workgroups (one for the top step), or indirect from the state.
        let dispatch = |pipeline: &ComputePipeline, direct: u32, indirect_word: u64| {
            match blocks {
                Some(_) => pipeline.dispatch(cmd, None, bytes, [direct, 1, 1]),
                None => pipeline.dispatch_indirect_at(cmd, None, bytes, state, indirect_word * 4),
            }
            self.barrier(cmd);
        };
        let b = blocks.unwrap_or(0);
        dispatch(&self.p.scan_reduce, b, STATE_ARGS_BLOCKS);
        dispatch(&self.p.scan_top, 1, STATE_ARGS_SINGLE);
        dispatch(&self.p.scan_down, b, STATE_ARGS_BLOCKS);
    }

    fn record_ploc_iterations(&self, cmd: vk::CommandBuffer, first: u32, count: u32) {
        let state = &self.scratch.state;
        let state_addr = state.address();
        for it in first..first + count {
            let parity = it % 2;
            let push = self.push(parity, 0);
            let bytes = bytemuck::bytes_of(&push);
            let elems = STATE_ARGS_ELEMS * 4;
            self.p
                .nn
                .dispatch_indirect_at(cmd, None, bytes, state, elems);
            self.barrier(cmd);
            self.p
                .merge
                .dispatch_indirect_at(cmd, None, bytes, state, elems);
            self.barrier(cmd);
            self.record_scan(
                cmd,
                self.scratch.arrays[9].address(),
                state_addr + 4 * STATE_CLUSTERS as u64,
                state_addr + 4 * STATE_CLUSTERS_NEXT as u64,
                None,
            );
            self.p
                .compact
                .dispatch_indirect_at(cmd, None, bytes, state, elems);
            self.barrier(cmd);
            self.p.ploc_prepare.dispatch(cmd, None, bytes, [1, 1, 1]);
            self.barrier(cmd);
        }
    }

    fn build_blas(&mut self, gt: &GeometryTris, tri_base: u32) -> Result<BuiltBlas, BvhError> {
        let ctx = self.ctx;
        let n = gt.tris.len();
        self.scratch.arrays[0].upload(ctx, bytemuck::cast_slice(&gt.tris))?;
        let mut cmin = glam::Vec3A::splat(f32::INFINITY);
        let mut cmax = glam::Vec3A::splat(f32::NEG_INFINITY);
        for b in &gt.aabbs {
            let c = b.center();
            cmin = cmin.min(c);
            cmax = cmax.max(c);
        }
        let extent = cmax - cmin;
        let inv = |e: f32| if e > 0.0 { 1.0 / e } else { 0.0 };
        self.refs.n = n as u32;
        self.refs.tri_base = tri_base;
        self.refs.pad_scale = max_abs(&gt.bounds);
        self.refs.centroid_min = cmin.to_array();
        self.refs.centroid_inv_extent = [inv(extent.x), inv(extent.y), inv(extent.z)];
        self.scratch.refs.write(bytemuck::bytes_of(&self.refs))?;
        let mut state = [0u32; STATE_WORDS];
        state[STATE_CLUSTERS_NEXT] = n as u32;
        state[STATE_HIST_COUNT] = 16 * sort_blocks(n as u64) as u32;
        self.scratch.state.write(bytemuck::cast_slice(&state))?;

        let groups = (n as u32).div_ceil(256);
        let blocks = sort_blocks(n as u64) as u32;
        self.run("bvh build: morton, sort, clustering", |b, cmd| {
            let push = b.push(0, 0);
            b.begin(cmd, "morton");
            b.p.morton
                .dispatch(cmd, None, bytemuck::bytes_of(&push), [groups, 1, 1]);
            b.barrier(cmd);
            if n > 1 {
                b.begin(cmd, "sort");
                let hist = b.scratch.arrays[9].address();
                let count = b.scratch.state.address() + 4 * STATE_HIST_COUNT as u64;
                for pass in 0..8u32 {
                    let push = b.push(4 * pass, pass % 2);
                    let bytes = bytemuck::bytes_of(&push);
                    b.p.hist.dispatch(cmd, None, bytes, [blocks, 1, 1]);
                    b.barrier(cmd);
                    let scan_blocks = (16 * blocks).div_ceil(1024);
                    b.record_scan(cmd, hist, count, 0, Some(scan_blocks));
                    b.p.scatter.dispatch(cmd, None, bytes, [blocks, 1, 1]);
                    b.barrier(cmd);
                }
                b.begin(cmd, "clustering");
                b.p.ploc_prepare
                    .dispatch(cmd, None, bytemuck::bytes_of(&push), [1, 1, 1]);
                b.barrier(cmd);
                b.record_ploc_iterations(cmd, 0, PLOC_CHUNK);
            }
        })?;
        let mut recorded = PLOC_CHUNK;
        let mut clusters = self.scratch.read_state(ctx)?[STATE_CLUSTERS];
        while n > 1 && clusters > 1 {
            // Every iteration merges at least the globally closest pair, so a chunk that
            // merges nothing means a bug, not slow convergence.
            let before = clusters;
            self.run("bvh build: clustering", |b, cmd| {
                b.begin(cmd, "clustering");
                b.record_ploc_iterations(cmd, recorded, PLOC_CHUNK);
            })?;
            recorded += PLOC_CHUNK;
            clusters = self.scratch.read_state(ctx)?[STATE_CLUSTERS];
            if clusters >= before {
                return Err(BvhError::InvalidScene(format!(
                    "internal: GPU PLOC stalled at {clusters} clusters"
                )));
            }
        }

        let mut level = 0u32;
        loop {
            self.run("bvh build: collapse", |b, cmd| {
                b.begin(cmd, "collapse");
                if level == 0 {
                    let push = b.push(0, 0);
                    b.p.collapse_init
                        .dispatch(cmd, None, bytemuck::bytes_of(&push), [1, 1, 1]);
                    b.barrier(cmd);
                }
                for l in level..level + COLLAPSE_CHUNK {
                    let push = b.push(l % 2, 0);
                    let bytes = bytemuck::bytes_of(&push);
                    b.p.collapse.dispatch_indirect_at(
                        cmd,
                        None,
                        bytes,
                        &b.scratch.state,
                        STATE_ARGS_COLLAPSE * 4,
                    );
                    b.barrier(cmd);
                    b.p.collapse_prepare.dispatch(cmd, None, bytes, [1, 1, 1]);
                    b.barrier(cmd);
                }
            })?;
            level += COLLAPSE_CHUNK;
            let state = self.scratch.read_state(ctx)?;
            if state[STATE_QUEUE0 + (level % 2) as usize] == 0 {
                break;
            }
            if level >= MAX_COLLAPSE_LEVELS {
                return Err(BvhError::TooDeep {
                    entries: state[STATE_MAX_STACK],
                    limit: super::layout::BVH_STACK_SIZE,
                });
            }
        }
        let state = self.scratch.read_state(ctx)?;
        if state[STATE_ERROR] != 0 {
            return Err(BvhError::InvalidScene(
                "bounds too large to quantize (beyond ~1e38)".into(),
            ));
        }
        let node_count = state[STATE_WIDE_COUNT];
        let bytes = u64::from(node_count) * std::mem::size_of::<BvhNode>() as u64;
        let nodes = Buffer::new(
            ctx,
            "bvh blas nodes",
            bytes,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::GpuOnly,
        )?;
        let src = self.scratch.arrays[11].raw();
        ctx.run("bvh build: copy nodes", |cmd| {
            memory_barrier(ctx.device(), cmd);
            let region = vk::BufferCopy::default().size(bytes);
            // SAFETY: both buffers are alive and hold at least `bytes`.
            unsafe {
                ctx.device()
                    .cmd_copy_buffer(cmd, src, nodes.raw(), &[region])
            };
            Ok(())
        })?;
        Ok(BuiltBlas {
            nodes,
            node_count,
            depth: state[STATE_MAX_DEPTH],
            stack: state[STATE_MAX_STACK],
            iterations: state[STATE_ITERATIONS],
        })
    }
}

/// Builds the two-level BVH of `scene` with the bottom levels built on the GPU (see the
/// module docs). Checks limits and the scratch + result memory before allocating anything.
pub(super) fn build(
    ctx: &Context,
    scene: &Scene,
    opts: &BvhBuildOptions,
) -> Result<GpuBvh, BvhError> {
    let t_start = Instant::now();
    let max_leaf = opts.max_leaf_size.clamp(1, MAX_LEAF_PRIMITIVES);
    let input = builder::scene_input(scene)?;
    // Limits first, from the raw counts: nothing is gathered or allocated for a scene the
    // GPU build cannot take.
    let mut max_n = 0usize;
    let mut total = 0usize;
    for (g, geom) in scene.geometries.iter().enumerate() {
        if !input.used[g] {
            continue;
        }
        let n = geom.indices.len() / 3;
        if n > GPU_BUILD_MAX_TRIANGLES {
            return Err(BvhError::GpuBuildLimit {
                geometry: g,
                triangles: n,
                limit: GPU_BUILD_MAX_TRIANGLES,
            });
        }
        max_n = max_n.max(n);
        total += n;
    }
    if total > LINK_FIRST_MASK as usize + 1 {
        return Err(BvhError::too_many("triangles"));
    }
    let result_estimate = BvhData::estimate_bytes(scene);
    super::check_fits(&ctx.info().memory_heaps, result_estimate, "estimate")?;
    let peak_scratch = scratch_bytes(max_n);
    ctx.check_memory(
        "the GPU BVH build (scratch and result)",
        peak_scratch + result_estimate,
    )?;

    let mut stats = BvhStats {
        skipped_instances: input.skipped_instances,
        builder: "gpu".into(),
        peak_scratch_bytes: peak_scratch,
        ..Default::default()
    };
    let t_blas = Instant::now();
    // Gather every used geometry's usable triangles (host, O(n)) to size the output.
    let mut gathered: Vec<Option<GeometryTris>> = Vec::with_capacity(scene.geometries.len());
    let mut tri_count = 0usize;
    for (g, geom) in scene.geometries.iter().enumerate() {
        if !input.used[g] {
            gathered.push(None);
            continue;
        }
        let gt = gather_geometry(scene, g)?;
        stats.skipped_triangles += geom.triangle_count() - gt.tris.len();
        tri_count += gt.tris.len();
        gathered.push((!gt.tris.is_empty()).then_some(gt));
    }
    let triangles = Buffer::new(
        ctx,
        "bvh triangles",
        (tri_count * std::mem::size_of::<BvhTriangle>()) as u64,
        vk::BufferUsageFlags::empty(),
        MemoryLocation::GpuOnly,
    )?;
    let mut builder = Builder::new(ctx, max_n, triangles.address(), opts, max_leaf)?;
    let mut blas: Vec<Option<BuiltBlas>> = Vec::with_capacity(scene.geometries.len());
    let mut blas_bounds: Vec<Option<ObAabb>> = vec![None; scene.geometries.len()];
    let mut tri_base = 0u32;
    let mut max_blas_stack = 0;
    for (g, gt) in gathered.iter().enumerate() {
        let Some(gt) = gt else {
            blas.push(None);
            continue;
        };
        let built = builder.build_blas(gt, tri_base)?;
        tri_base += gt.tris.len() as u32;
        stats.blas_count += 1;
        stats.max_blas_depth = stats.max_blas_depth.max(built.depth);
        max_blas_stack = max_blas_stack.max(built.stack);
        builder.phases.ploc_iterations = builder.phases.ploc_iterations.max(built.iterations);
        blas_bounds[g] = Some(gt.bounds);
        blas.push(Some(built));
    }
    drop(gathered);
    stats.blas_ms = t_blas.elapsed().as_secs_f64() * 1e3;

    // The top level goes to the front, into room for a top level over every instance, so
    // that `GpuBvh::rebuild_tlas` can rebuild it in place.
    let region = tlas::tlas_region(scene.instances.len());
    let mut offset = region as u64;
    let mut roots = vec![None; scene.geometries.len()];
    for (g, b) in blas.iter().enumerate() {
        if let Some(b) = b {
            roots[g] = Some(offset as u32);
            offset += u64::from(b.node_count);
        }
    }
    if offset > 1 << 31 {
        return Err(BvhError::too_many("nodes"));
    }
    let node_count = offset as usize;
    let nodes = Buffer::new(
        ctx,
        "bvh nodes",
        (node_count * std::mem::size_of::<BvhNode>()) as u64,
        vk::BufferUsageFlags::empty(),
        MemoryLocation::GpuOnly,
    )?;
    nodes.upload(ctx, bytemuck::cast_slice(&vec![BvhNode::EMPTY; region]))?;
    builder.run("bvh build: relocate", |b, cmd| {
        b.begin(cmd, "relocate");
        for (g, built) in blas.iter().enumerate() {
            let (Some(built), Some(root)) = (built, roots[g]) else {
                continue;
            };
            let push = RelocatePush {
                src: built.nodes.address(),
                dst: nodes.address(),
                count: built.node_count,
                offset: root,
            };
            b.p.relocate.dispatch(
                cmd,
                None,
                bytemuck::bytes_of(&push),
                [built.node_count.div_ceil(256), 1, 1],
            );
        }
    })?;
    let mut phases = builder.phases.clone();
    drop(builder);
    let t_tlas = Instant::now();
    let (boxes, ids, world) = builder::instance_boxes(scene, &input, &blas_bounds, &mut stats);
    let tlas = tlas::build_tlas_gpu(ctx, &nodes, region, &boxes, &ids, world, opts)?;
    phases.tlas_ms = tlas.phases.total_ms();
    stats.tlas_nodes = region;
    stats.tlas_depth = tlas.depth;
    stats.tlas_ms = t_tlas.elapsed().as_secs_f64() * 1e3;
    let instances = builder::instance_records(scene, &input, &roots);
    builder::finish_stats(&mut stats, tlas.stack, max_blas_stack)?;
    stats.node_count = node_count;
    stats.triangle_count = tri_count;
    stats.instance_count = scene.instances.len();
    stats.max_leaf_size = max_leaf;
    stats.gpu_phases = Some(phases);
    stats.bytes = nodes.size() + triangles.size() + (instances.len() * 64) as u64;
    stats.build_ms = t_start.elapsed().as_secs_f64() * 1e3;
    GpuBvh::from_buffers(
        ctx, nodes, node_count, triangles, tri_count, &instances, stats,
    )
}
