//! Graphics pipelines for dynamic rendering (the G-buffer raster pass), built on the same
//! descriptor set layouts, sets and per-context cache as the compute pipelines.

use std::ffi::CStr;
use std::sync::Arc;

use ash::vk;

use super::context::Shared;
use super::pipeline::{
    cache_key, create_set_layout, retire_pipeline, specialization_entries, spirv_words, Binding,
    DescriptorSet,
};
use super::{CallExt, Context, VkError, VkResult};

/// A graphics pipeline for dynamic rendering with vertex pulling (no vertex input state),
/// one descriptor set, push constants, dynamic viewport/scissor/cull mode/front face.
pub struct GraphicsPipeline {
    shared: Arc<Shared>,
    bindings: Vec<Binding>,
    set_layout: vk::DescriptorSetLayout,
    layout: vk::PipelineLayout,
    pipeline: vk::Pipeline,
}

/// What a [`GraphicsPipeline`] renders into.
pub struct GraphicsTargets<'a> {
    /// Colour attachment formats, in location order.
    pub color_formats: &'a [vk::Format],
    /// Depth attachment format (depth test LESS, write on).
    pub depth_format: vk::Format,
}

impl GraphicsPipeline {
    /// [`Self::new`], built once per context (see
    /// [`ComputePipeline::cached`](super::ComputePipeline::cached)).
    pub fn cached(
        ctx: &Context,
        vertex: &[u8],
        fragment: &[u8],
        bindings: &[Binding],
        push_size: u32,
        targets: &GraphicsTargets<'_>,
        fragment_constants: &[u32],
    ) -> VkResult<Arc<Self>> {
        let key = cache_key((
            "graphics",
            vertex,
            fragment,
            format!("{bindings:?}"),
            push_size,
            format!("{:?} {:?}", targets.color_formats, targets.depth_format),
            fragment_constants,
        ));
        let mut cache = ctx.pipelines.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(p) = cache
            .get(&key)
            .and_then(|p| p.clone().downcast::<Self>().ok())
        {
            return Ok(p);
        }
        let p = Arc::new(Self::new(
            ctx,
            vertex,
            fragment,
            bindings,
            push_size,
            targets,
            fragment_constants,
        )?);
        cache.insert(key, p.clone());
        Ok(p)
    }

    /// Builds the pipeline from vertex and fragment SPIR-V (entry points `main`);
    /// `fragment_constants[i]` specialises the fragment stage's `constant_id = i`.
    pub fn new(
        ctx: &Context,
        vertex: &[u8],
        fragment: &[u8],
        bindings: &[Binding],
        push_size: u32,
        targets: &GraphicsTargets<'_>,
        fragment_constants: &[u32],
    ) -> VkResult<Self> {
        let device = ctx.device();
        let stages = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        let set_layout = create_set_layout(device, bindings, stages)?;
        let ranges = [vk::PushConstantRange::default()
            .stage_flags(stages)
            .size(push_size)];
        let set_layouts = [set_layout];
        let layout_info = vk::PipelineLayoutCreateInfo::default()
            .set_layouts(&set_layouts)
            .push_constant_ranges(if push_size > 0 { &ranges } else { &[] });
        // SAFETY: valid create info.
        let layout = match unsafe { device.create_pipeline_layout(&layout_info, None) }
            .call("vkCreatePipelineLayout")
        {
            Ok(l) => l,
            Err(e) => {
                // SAFETY: unused layout.
                unsafe { device.destroy_descriptor_set_layout(set_layout, None) };
                return Err(e);
            }
        };
        let destroy_layouts = || {
            // SAFETY: unused objects.
            unsafe {
                device.destroy_pipeline_layout(layout, None);
                device.destroy_descriptor_set_layout(set_layout, None);
            }
        };
        let mut modules = Vec::new();
        for code in [vertex, fragment] {
            let words = match spirv_words(code) {
                Ok(w) => w,
                Err(e) => {
                    destroy_layouts();
                    return Err(e);
                }
            };
            // SAFETY: valid SPIR-V from build.rs.
            match unsafe {
                device
                    .create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&words), None)
            } {
                Ok(m) => modules.push(m),
                Err(result) => {
                    // SAFETY: unused modules.
                    unsafe {
                        modules
                            .iter()
                            .for_each(|&m| device.destroy_shader_module(m, None))
                    };
                    destroy_layouts();
                    return Err(VkError::from_call("vkCreateShaderModule", result));
                }
            }
        }
        const MAIN: &CStr = c"main";
        let entries = specialization_entries(fragment_constants);
        let spec = vk::SpecializationInfo::default()
            .map_entries(&entries)
            .data(bytemuck::cast_slice(fragment_constants));
        let stage_info = [
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::VERTEX)
                .module(modules[0])
                .name(MAIN),
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::FRAGMENT)
                .module(modules[1])
                .name(MAIN)
                .specialization_info(&spec),
        ];
        let vertex_input = vk::PipelineVertexInputStateCreateInfo::default();
        let assembly = vk::PipelineInputAssemblyStateCreateInfo::default()
            .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
        let viewport = vk::PipelineViewportStateCreateInfo::default()
            .viewport_count(1)
            .scissor_count(1);
        let raster = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .line_width(1.0);
        let multisample = vk::PipelineMultisampleStateCreateInfo::default()
            .rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let depth = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(true)
            .depth_write_enable(true)
            .depth_compare_op(vk::CompareOp::LESS);
        let blend_attachments: Vec<_> = targets
            .color_formats
            .iter()
            .map(|_| {
                vk::PipelineColorBlendAttachmentState::default()
                    .color_write_mask(vk::ColorComponentFlags::RGBA)
            })
            .collect();
        let blend =
            vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachments);
        let dynamic_states = [
            vk::DynamicState::VIEWPORT,
            vk::DynamicState::SCISSOR,
            vk::DynamicState::CULL_MODE,
            vk::DynamicState::FRONT_FACE,
        ];
        let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
        let mut rendering = vk::PipelineRenderingCreateInfo::default()
            .color_attachment_formats(targets.color_formats)
            .depth_attachment_format(targets.depth_format);
        let info = vk::GraphicsPipelineCreateInfo::default()
            .stages(&stage_info)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&assembly)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .depth_stencil_state(&depth)
            .color_blend_state(&blend)
            .dynamic_state(&dynamic)
            .layout(layout)
            .push_next(&mut rendering);
        // SAFETY: every referenced struct lives until the call returns.
        let result =
            unsafe { device.create_graphics_pipelines(ctx.pipeline_cache(), &[info], None) };
        // SAFETY: modules are no longer needed once the pipeline exists (or failed).
        unsafe {
            modules
                .iter()
                .for_each(|&m| device.destroy_shader_module(m, None))
        };
        let pipeline = match result {
            Ok(p) => p[0],
            Err((_, result)) => {
                destroy_layouts();
                return Err(VkError::from_call("vkCreateGraphicsPipelines", result));
            }
        };
        Ok(Self {
            shared: ctx.shared.clone(),
            bindings: bindings.to_vec(),
            set_layout,
            layout,
            pipeline,
        })
    }

    /// Allocates a descriptor set for this pipeline.
    pub fn allocate_set(&self) -> VkResult<DescriptorSet> {
        DescriptorSet::new(&self.shared, self.set_layout, &self.bindings)
    }

    /// Binds the pipeline and its set (call inside a dynamic rendering scope).
    pub fn bind(&self, cmd: vk::CommandBuffer, set: &DescriptorSet) {
        // SAFETY: recording command buffer, live objects.
        unsafe {
            self.shared.device.cmd_bind_pipeline(
                cmd,
                vk::PipelineBindPoint::GRAPHICS,
                self.pipeline,
            );
            self.shared.device.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::GRAPHICS,
                self.layout,
                0,
                &[set.raw()],
                &[],
            );
        }
    }

    /// Sets the push constants of both stages.
    pub fn push(&self, cmd: vk::CommandBuffer, bytes: &[u8]) {
        // SAFETY: the range was declared for both stages at creation.
        unsafe {
            self.shared.device.cmd_push_constants(
                cmd,
                self.layout,
                vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
                0,
                bytes,
            )
        };
    }
}

impl Drop for GraphicsPipeline {
    fn drop(&mut self) {
        retire_pipeline(&self.shared, self.pipeline, self.layout, self.set_layout);
    }
}
