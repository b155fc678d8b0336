//! Tonemap pass: linear HDR colour buffer → sRGB RGBA8 (`shaders/tonemap.comp`).

use std::sync::Arc;

use ash::vk;

use super::frame::Tonemap;
use crate::vk::{
    Binding, Buffer, ComputePipeline, Context, DescriptorSet, GpuProfiler, MemoryLocation, VkResult,
};

/// Pipeline and output buffer of the tonemap pass.
pub struct TonemapPass {
    pipeline: Arc<ComputePipeline>,
    set: DescriptorSet,
    /// RGBA8 pixels, one `u32` each.
    pub output: Buffer,
    count: u32,
}

impl TonemapPass {
    /// Reads `color` (`vec4` per pixel) of `count` pixels.
    pub fn new(ctx: &Context, color: &Buffer, count: u32) -> VkResult<Self> {
        let pipeline = ComputePipeline::cached(
            ctx,
            "tonemap",
            crate::shaders::TONEMAP_COMP,
            &[Binding::StorageBuffer, Binding::StorageBuffer],
            12,
        )?;
        let output = Buffer::new(
            ctx,
            "tonemapped",
            u64::from(count) * 4,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::GpuOnly,
        )?;
        let set = pipeline.allocate_set()?;
        set.buffer(0, color, Binding::StorageBuffer)
            .buffer(1, &output, Binding::StorageBuffer);
        Ok(Self {
            pipeline,
            set,
            output,
            count,
        })
    }

    /// Records the pass.
    pub fn record(
        &self,
        cmd: vk::CommandBuffer,
        profiler: Option<&mut GpuProfiler>,
        op: Tonemap,
        exposure: f32,
    ) {
        let mut push = Vec::with_capacity(12);
        push.extend_from_slice(&self.count.to_le_bytes());
        let code: u32 = match op {
            Tonemap::None => 0,
            Tonemap::Aces => 1,
            Tonemap::KhronosNeutral => 2,
        };
        push.extend_from_slice(&code.to_le_bytes());
        push.extend_from_slice(&exposure.exp2().to_le_bytes());
        let mut profiler = profiler;
        if let Some(p) = profiler.as_deref_mut() {
            p.begin(cmd, "tonemap");
        }
        self.pipeline
            .dispatch(cmd, Some(&self.set), &push, [self.count.div_ceil(64), 1, 1]);
        if let Some(p) = profiler {
            p.end(cmd);
        }
    }
}
