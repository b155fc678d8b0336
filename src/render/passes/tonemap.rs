//! Tonemap pass: linear HDR colour buffer → sRGB RGBA8 (`shaders/tonemap.comp`).

use std::sync::Arc;

use ash::vk;

use crate::interface::{self as io, bindings, push_bytes, TonemapPush};
use crate::render::Tonemap;
use crate::vk::{
    rows_of_groups, Buffer, ComputePipeline, Context, GpuProfiler, MemoryLocation, VkResult,
};

/// The shaders' `TONEMAP_*` code of `op` (`shaders/common/tonemap.glsl`).
pub fn operator_code(op: Tonemap) -> u32 {
    match op {
        Tonemap::None => io::TONEMAP_NONE,
        Tonemap::Aces => io::TONEMAP_ACES,
        Tonemap::KhronosNeutral => io::TONEMAP_KHRONOS_NEUTRAL,
    }
}

/// Pipeline and output buffer of the tonemap pass.
pub struct TonemapPass {
    pipeline: Arc<ComputePipeline>,
    /// Device address of the linear colour it reads.
    input: vk::DeviceAddress,
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
            &bindings(&[]),
            std::mem::size_of::<TonemapPush>() as u32,
        )?;
        let output = Buffer::new(
            ctx,
            "tonemapped",
            u64::from(count) * 4,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::GpuOnly,
        )?;
        Ok(Self {
            pipeline,
            input: color.address(),
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
        let push = TonemapPush {
            count: self.count,
            op: operator_code(op),
            scale: exposure.exp2(),
            pad0: 0,
            color_in: self.input,
            pixels_out: self.output.address(),
        };
        let mut profiler = profiler;
        if let Some(p) = profiler.as_deref_mut() {
            p.begin(cmd, crate::render::PassScope::Tonemap.name());
        }
        self.pipeline.dispatch(
            cmd,
            None,
            push_bytes(&push),
            rows_of_groups(self.count.div_ceil(64), io::GROUPS_PER_ROW),
        );
        if let Some(p) = profiler {
            p.end(cmd);
        }
    }
}
