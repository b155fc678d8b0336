//! Hybrid path, shading pass: reads the raster pass's images (visibility buffer or full
//! G-buffer) and runs the shared Whitted loop, or the distributed paths, for shadows,
//! reflections and refractions (`shaders/hybrid_vis.comp`, `shaders/hybrid.comp` and their
//! `shaders/distributed/` variants, all `shaders/common/hybrid_main.glsl`).

use std::sync::Arc;

use ash::vk;

use super::gbuffer::{GbufferLayout, GbufferPass};
use crate::accel::Backend;
use crate::interface::distributed::PIXELS_PER_INVOCATION;
use crate::interface::{self as io, bindings, push_bytes, scene_bindings, HybridPush};
use crate::render::{PassContext, Shading};
use crate::vk::{Binding, Buffer, ComputePipeline, Context, DescriptorSet, GpuProfiler, VkResult};

pub use crate::interface::{HYBRID_FIRST_SAMPLE, HYBRID_WRITE_AOV};

/// Pipeline and descriptor set of the hybrid shading pass.
pub struct HybridPass {
    pipeline: Arc<ComputePipeline>,
    set: DescriptorSet,
    /// The shading model (the distributed pass lays its invocations out differently).
    shading: Shading,
}

fn spirv(backend: Backend, layout: GbufferLayout, shading: Shading) -> &'static [u8] {
    use crate::shaders as s;
    match (shading, backend, layout) {
        (Shading::Whitted, Backend::Hw, GbufferLayout::Full) => s::HYBRID_COMP_HW,
        (Shading::Whitted, Backend::Bvh, GbufferLayout::Full) => s::HYBRID_COMP_BVH,
        (Shading::Whitted, Backend::Hw, GbufferLayout::Visibility) => s::HYBRID_VIS_COMP_HW,
        (Shading::Whitted, Backend::Bvh, GbufferLayout::Visibility) => s::HYBRID_VIS_COMP_BVH,
        (Shading::Distributed, Backend::Hw, GbufferLayout::Full) => s::HYBRID_DISTRIBUTED_COMP_HW,
        (Shading::Distributed, Backend::Bvh, GbufferLayout::Full) => s::HYBRID_DISTRIBUTED_COMP_BVH,
        (Shading::Distributed, Backend::Hw, GbufferLayout::Visibility) => {
            s::HYBRID_VIS_DISTRIBUTED_COMP_HW
        }
        (Shading::Distributed, Backend::Bvh, GbufferLayout::Visibility) => {
            s::HYBRID_VIS_DISTRIBUTED_COMP_BVH
        }
    }
}

impl HybridPass {
    /// Binds the scene, the frame uniform, the outputs and the G-buffer images; shades in
    /// the `shading` model.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        ctx: &Context,
        pass: &PassContext<'_>,
        shading: Shading,
        frame: &Buffer,
        accum: &Buffer,
        aov: &Buffer,
        counters: &Buffer,
        gbuffer: &GbufferPass,
    ) -> VkResult<Self> {
        let mut entries = scene_bindings(pass.texture_capacity(), pass.backend.binding()).to_vec();
        entries.extend([
            (io::BINDING_HYBRID_ACCUM, Binding::StorageBuffer),
            (io::BINDING_HYBRID_AOV, Binding::StorageBuffer),
            (io::BINDING_HYBRID_COUNTERS, Binding::StorageBuffer),
        ]);
        entries.extend(
            (0..gbuffer.images.len() as u32)
                .map(|i| (io::BINDING_HYBRID_GBUFFER + i, Binding::StorageImage)),
        );
        let pipeline = ComputePipeline::cached(
            ctx,
            crate::render::PassScope::HybridShading.name(),
            spirv(pass.backend.kind(), gbuffer.layout(), shading),
            &bindings(&entries),
            std::mem::size_of::<HybridPush>() as u32,
        )?;
        let set = pipeline.allocate_set()?;
        pass.bind_scene(&set);
        set.buffer(io::BINDING_FRAME, frame, Binding::UniformBuffer)
            .buffer(io::BINDING_HYBRID_ACCUM, accum, Binding::StorageBuffer)
            .buffer(io::BINDING_HYBRID_AOV, aov, Binding::StorageBuffer)
            .buffer(
                io::BINDING_HYBRID_COUNTERS,
                counters,
                Binding::StorageBuffer,
            );
        // The images in `GBUFFER_*` order (one, the visibility image, without a G-buffer).
        for (i, image) in (0u32..).zip(&gbuffer.images) {
            set.storage_image(io::BINDING_HYBRID_GBUFFER + i, image.view());
        }
        Ok(Self {
            pipeline,
            set,
            shading,
        })
    }

    /// Records the shading of one sample with filter weight `weight`; with a `guide` address
    /// (not 0) it also accumulates the denoiser's colour split there (distributed shading).
    pub fn record(
        &self,
        cmd: vk::CommandBuffer,
        extent: vk::Extent2D,
        flags: u32,
        weight: f32,
        guide: vk::DeviceAddress,
        profiler: Option<&mut GpuProfiler>,
    ) {
        let push = HybridPush {
            flags,
            weight,
            guide,
        };
        let mut profiler = profiler;
        if let Some(p) = profiler.as_deref_mut() {
            p.begin(cmd, crate::render::PassScope::HybridShading.name());
        }
        // The distributed pass's invocations take PIXELS_PER_INVOCATION pixels each, in turn.
        let rows = if self.shading == Shading::Distributed {
            extent.height.div_ceil(PIXELS_PER_INVOCATION)
        } else {
            extent.height
        };
        self.pipeline.dispatch(
            cmd,
            Some(&self.set),
            push_bytes(&push),
            [extent.width.div_ceil(8), rows.div_ceil(8), 1],
        );
        if let Some(p) = profiler {
            p.end(cmd);
        }
    }
}
