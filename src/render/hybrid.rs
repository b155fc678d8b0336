//! Hybrid path, shading pass: reads the raster pass's images (visibility buffer or full
//! G-buffer) and runs the shared Whitted loop for shadows, reflections and refractions
//! (`shaders/hybrid_vis.comp`, `shaders/hybrid.comp`, both `shaders/common/hybrid_main.glsl`).

use std::sync::Arc;

use ash::vk;

use super::gbuffer::{GbufferLayout, GbufferPass};
use super::PassContext;
use crate::accel::Backend;
use crate::vk::{Binding, Buffer, ComputePipeline, Context, DescriptorSet, GpuProfiler, VkResult};

/// `hybrid.comp` push flag: overwrite the accumulation (first sample).
pub const HYBRID_FIRST_SAMPLE: u32 = 1;
/// `hybrid.comp` push flag: write AOVs.
pub const HYBRID_WRITE_AOV: u32 = 4;

/// Pipeline and descriptor set of the hybrid shading pass.
pub struct HybridPass {
    pipeline: Arc<ComputePipeline>,
    set: DescriptorSet,
}

fn spirv(backend: Backend, layout: GbufferLayout) -> &'static [u8] {
    match (backend, layout) {
        (Backend::Hw, GbufferLayout::Full) => crate::shaders::HYBRID_COMP_HW,
        (Backend::Bvh, GbufferLayout::Full) => crate::shaders::HYBRID_COMP_BVH,
        (Backend::Hw, GbufferLayout::Visibility) => crate::shaders::HYBRID_VIS_COMP_HW,
        (Backend::Bvh, GbufferLayout::Visibility) => crate::shaders::HYBRID_VIS_COMP_BVH,
    }
}

impl HybridPass {
    /// Binds the scene, the frame uniform, the outputs and the G-buffer images.
    pub fn new(
        ctx: &Context,
        pass: &PassContext<'_>,
        frame: &Buffer,
        accum: &Buffer,
        aov: &Buffer,
        counters: &Buffer,
        gbuffer: &GbufferPass,
    ) -> VkResult<Self> {
        let mut bindings = vec![
            Binding::UniformBuffer,
            Binding::SampledImages(pass.texture_capacity()),
            pass.backend.binding(),
            Binding::UniformBuffer,
            Binding::StorageBuffer,
            Binding::StorageBuffer,
            Binding::StorageBuffer,
        ];
        bindings.extend(std::iter::repeat_n(
            Binding::StorageImage,
            gbuffer.images.len(),
        ));
        let pipeline = ComputePipeline::cached(
            ctx,
            "hybrid shading",
            spirv(pass.backend.kind(), gbuffer.layout()),
            &bindings,
            8,
        )?;
        let set = pipeline.allocate_set()?;
        pass.bind_scene(&set);
        set.buffer(3, frame, Binding::UniformBuffer)
            .buffer(4, accum, Binding::StorageBuffer)
            .buffer(5, aov, Binding::StorageBuffer)
            .buffer(6, counters, Binding::StorageBuffer);
        for (i, image) in gbuffer.images.iter().enumerate() {
            set.storage_image(7 + i as u32, image.view());
        }
        Ok(Self { pipeline, set })
    }

    /// Records the shading of one sample with filter weight `weight`.
    pub fn record(
        &self,
        cmd: vk::CommandBuffer,
        extent: vk::Extent2D,
        flags: u32,
        weight: f32,
        profiler: Option<&mut GpuProfiler>,
    ) {
        let mut push = [0u8; 8];
        push[..4].copy_from_slice(&flags.to_le_bytes());
        push[4..].copy_from_slice(&weight.to_le_bytes());
        let mut profiler = profiler;
        if let Some(p) = profiler.as_deref_mut() {
            p.begin(cmd, "hybrid shading");
        }
        self.pipeline.dispatch(
            cmd,
            Some(&self.set),
            &push,
            [extent.width.div_ceil(8), extent.height.div_ceil(8), 1],
        );
        if let Some(p) = profiler {
            p.end(cmd);
        }
    }
}
