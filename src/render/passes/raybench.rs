//! Ray-throughput measurement (`rqr bench`): primary rays through pixel centres and one
//! cosine-weighted bounce per primary hit, through `trace_closest()` only, GPU-timed.

use std::sync::Arc;

use ash::vk;

use crate::accel::Backend;
use crate::interface::{self as io, bindings, push_bytes, scene_bindings, RaybenchPush};
use crate::render::GpuFrame;
use crate::render::PassContext;
use crate::vk::{
    memory_barrier, Binding, Buffer, ComputePipeline, Context, DescriptorSet, GpuProfiler,
    MemoryLocation, VkResult,
};

/// One timed batch of rays.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct RayBatch {
    /// Rays traced (counted on the GPU).
    pub rays: u64,
    /// Rays that hit geometry.
    pub hits: u64,
    /// GPU milliseconds of the dispatch.
    pub ms: f64,
}

impl RayBatch {
    /// Million rays per second.
    pub fn mrays_per_s(&self) -> f64 {
        if self.ms > 0.0 {
            self.rays as f64 / self.ms / 1e3
        } else {
            0.0
        }
    }
}

/// Pipeline and buffers of the throughput benchmark.
pub struct RayBench {
    pipeline: Arc<ComputePipeline>,
    set: DescriptorSet,
    counters: Buffer,
    _hits: Buffer,
    _frame: Buffer,
    width: u32,
    height: u32,
}

impl RayBench {
    /// Creates the benchmark for `frame`'s camera and resolution.
    pub fn new(ctx: &Context, pass: &PassContext<'_>, frame: &GpuFrame) -> VkResult<Self> {
        let spirv = match pass.backend.kind() {
            Backend::Hw => crate::shaders::RAYBENCH_COMP_HW,
            Backend::Bvh => crate::shaders::RAYBENCH_COMP_BVH,
        };
        let mut entries = scene_bindings(pass.texture_capacity(), pass.backend.binding()).to_vec();
        entries.extend([
            (io::BINDING_RAYBENCH_HITS, Binding::StorageBuffer),
            (io::BINDING_RAYBENCH_COUNTERS, Binding::StorageBuffer),
        ]);
        let pipeline = ComputePipeline::cached(
            ctx,
            "ray bench",
            spirv,
            &bindings(&entries),
            std::mem::size_of::<RaybenchPush>() as u32,
        )?;
        let pixels = u64::from(frame.width) * u64::from(frame.height);
        let none = vk::BufferUsageFlags::empty();
        let hits = Buffer::new(
            ctx,
            "bench hits",
            pixels * 32,
            none,
            MemoryLocation::GpuOnly,
        )?;
        let counters = Buffer::new(ctx, "bench counters", 8, none, MemoryLocation::GpuOnly)?;
        let frame_buf = Buffer::from_slice(
            ctx,
            "bench frame",
            std::slice::from_ref(frame),
            vk::BufferUsageFlags::UNIFORM_BUFFER,
        )?;
        let set = pipeline.allocate_set()?;
        pass.bind_scene(&set);
        set.buffer(io::BINDING_FRAME, &frame_buf, Binding::UniformBuffer)
            .buffer(io::BINDING_RAYBENCH_HITS, &hits, Binding::StorageBuffer)
            .buffer(
                io::BINDING_RAYBENCH_COUNTERS,
                &counters,
                Binding::StorageBuffer,
            );
        Ok(Self {
            pipeline,
            set,
            counters,
            _hits: hits,
            _frame: frame_buf,
            width: frame.width,
            height: frame.height,
        })
    }

    /// Traces one batch: primary rays (`incoherent = false`) or bounces from the last primary hits.
    pub fn run(&self, ctx: &Context, incoherent: bool) -> VkResult<RayBatch> {
        let mut profiler = GpuProfiler::new(ctx, 1)?;
        let name = if incoherent {
            "incoherent rays"
        } else {
            "primary rays"
        };
        ctx.run(name, |cmd| {
            profiler.reset(cmd);
            // SAFETY: recording command buffer; the counters buffer is ours.
            unsafe {
                ctx.device()
                    .cmd_fill_buffer(cmd, self.counters.raw(), 0, vk::WHOLE_SIZE, 0)
            };
            memory_barrier(ctx.device(), cmd);
            profiler.begin(cmd, name);
            self.pipeline.dispatch(
                cmd,
                Some(&self.set),
                push_bytes(&RaybenchPush {
                    mode: if incoherent {
                        io::RAYBENCH_BOUNCE
                    } else {
                        io::RAYBENCH_PRIMARY
                    },
                }),
                [self.width.div_ceil(8), self.height.div_ceil(8), 1],
            );
            profiler.end(cmd);
            Ok(())
        })?;
        let counts: Vec<u32> = self.counters.read(ctx)?;
        Ok(RayBatch {
            rays: u64::from(counts[0]),
            hits: u64::from(counts[1]),
            ms: profiler.results()?.first().map_or(0.0, |r| r.1),
        })
    }
}
