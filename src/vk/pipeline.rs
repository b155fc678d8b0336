//! Compute pipelines with one descriptor set layout each ([`Binding`] per binding number),
//! their descriptor sets, and the per-context pipeline cache (graphics pipelines, in
//! `graphics_pipeline`, share all three).

use std::ffi::CStr;
use std::hash::{Hash, Hasher};
use std::sync::Arc;

use ash::vk;

use super::context::Shared;
use super::{Buffer, CallExt, Context, VkError, VkResult};

/// One descriptor binding of a compute pipeline, in binding-number order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Binding {
    /// `buffer` block (std430/scalar).
    StorageBuffer,
    /// `uniform` block.
    UniformBuffer,
    /// `image2D` storage image.
    StorageImage,
    /// `sampler2D textures[]`: a partially bound array of up to this many combined samplers.
    SampledImages(u32),
    /// `accelerationStructureEXT`.
    AccelerationStructure,
    /// No descriptor at this binding number (keeps numbering shared between passes).
    Unused,
}

impl Binding {
    fn descriptor_type(self) -> vk::DescriptorType {
        match self {
            Self::StorageBuffer => vk::DescriptorType::STORAGE_BUFFER,
            Self::UniformBuffer => vk::DescriptorType::UNIFORM_BUFFER,
            Self::StorageImage => vk::DescriptorType::STORAGE_IMAGE,
            Self::SampledImages(_) => vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
            Self::AccelerationStructure => vk::DescriptorType::ACCELERATION_STRUCTURE_KHR,
            Self::Unused => vk::DescriptorType::SAMPLER,
        }
    }

    fn count(self) -> u32 {
        match self {
            Self::SampledImages(n) => n.max(1),
            _ => 1,
        }
    }
}

/// Converts SPIR-V bytes (as embedded with `include_bytes!`) to aligned words.
pub fn spirv_words(bytes: &[u8]) -> VkResult<Vec<u32>> {
    ash::util::read_spv(&mut std::io::Cursor::new(bytes))
        .map_err(|e| VkError::Invalid(format!("invalid SPIR-V: {e}")))
}

/// Creates a descriptor set layout for `bindings` visible to `stages`.
pub(super) fn create_set_layout(
    device: &ash::Device,
    bindings: &[Binding],
    stages: vk::ShaderStageFlags,
) -> VkResult<vk::DescriptorSetLayout> {
    let raw: Vec<_> = bindings
        .iter()
        .enumerate()
        .filter(|(_, b)| **b != Binding::Unused)
        .map(|(i, b)| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(i as u32)
                .descriptor_type(b.descriptor_type())
                .descriptor_count(b.count())
                .stage_flags(stages)
        })
        .collect();
    let flags: Vec<_> = bindings
        .iter()
        .filter(|b| **b != Binding::Unused)
        .map(|b| match b {
            Binding::SampledImages(_) => vk::DescriptorBindingFlags::PARTIALLY_BOUND,
            _ => vk::DescriptorBindingFlags::empty(),
        })
        .collect();
    let mut flag_info =
        vk::DescriptorSetLayoutBindingFlagsCreateInfo::default().binding_flags(&flags);
    let info = vk::DescriptorSetLayoutCreateInfo::default()
        .bindings(&raw)
        .push_next(&mut flag_info);
    // SAFETY: valid create info.
    unsafe { device.create_descriptor_set_layout(&info, None) }.call("vkCreateDescriptorSetLayout")
}

/// Key of a pipeline in its [`Context`]'s cache: a hash of everything that defines it.
/// Creating a pipeline costs lavapipe 50-200 ms of CPU even when its JIT cache hits (SPIR-V to
/// NIR and NIR optimisation), and passes are built per frame, so every pass reuses one pipeline
/// per shader for the context's lifetime.
pub(super) fn cache_key(parts: impl Hash) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    parts.hash(&mut h);
    h.finish()
}

/// Map entries of 32-bit specialization constants: `constants[i]` is `constant_id = i`.
pub(super) fn specialization_entries(constants: &[u32]) -> Vec<vk::SpecializationMapEntry> {
    (0..constants.len() as u32)
        .map(|i| vk::SpecializationMapEntry {
            constant_id: i,
            offset: i * 4,
            size: 4,
        })
        .collect()
}

/// A compute pipeline with one descriptor set layout and an optional push-constant block.
pub struct ComputePipeline {
    shared: Arc<Shared>,
    name: String,
    bindings: Vec<Binding>,
    set_layout: vk::DescriptorSetLayout,
    layout: vk::PipelineLayout,
    pipeline: vk::Pipeline,
    push_size: u32,
}

impl ComputePipeline {
    /// Builds a pipeline from SPIR-V (entry point `main`).
    pub fn new(
        ctx: &Context,
        name: &str,
        spirv: &[u8],
        bindings: &[Binding],
        push_size: u32,
    ) -> VkResult<Self> {
        Self::new_specialized(ctx, name, spirv, bindings, push_size, &[])
    }

    /// [`Self::new`] with specialization constants: `constants[i]` is `constant_id = i`. A
    /// shader that holds several passes picks one this way, so the driver compiles only that
    /// pass's code (on a CPU device, a big shader's unused stages still cost every
    /// invocation).
    pub fn new_specialized(
        ctx: &Context,
        name: &str,
        spirv: &[u8],
        bindings: &[Binding],
        push_size: u32,
        constants: &[u32],
    ) -> VkResult<Self> {
        let device = ctx.device();
        let limit = ctx.info().max_push_constants_size;
        if push_size > limit {
            return Err(VkError::Limit {
                what: format!(
                    "pipeline '{name}' needs {push_size} bytes of push constants, the device allows {limit}"
                ),
                needed: push_size.into(),
                available: limit.into(),
            });
        }
        let words = spirv_words(spirv)?;
        let set_layout = create_set_layout(device, bindings, vk::ShaderStageFlags::COMPUTE)?;
        let ranges = [vk::PushConstantRange::default()
            .stage_flags(vk::ShaderStageFlags::COMPUTE)
            .size(push_size)];
        let set_layouts = [set_layout];
        let layout_info = vk::PipelineLayoutCreateInfo::default()
            .set_layouts(&set_layouts)
            .push_constant_ranges(if push_size > 0 { &ranges } else { &[] });
        // SAFETY: valid create info.
        let layout = unsafe { device.create_pipeline_layout(&layout_info, None) }
            .call("vkCreatePipelineLayout");
        let layout = match layout {
            Ok(l) => l,
            Err(e) => {
                // SAFETY: unused layout.
                unsafe { device.destroy_descriptor_set_layout(set_layout, None) };
                return Err(e);
            }
        };
        let module_info = vk::ShaderModuleCreateInfo::default().code(&words);
        // SAFETY: `words` is valid SPIR-V produced by build.rs.
        let module =
            unsafe { device.create_shader_module(&module_info, None) }.call("vkCreateShaderModule");
        let entries = specialization_entries(constants);
        let spec = vk::SpecializationInfo::default()
            .map_entries(&entries)
            .data(bytemuck::cast_slice(constants));
        let pipeline = module.and_then(|module| {
            const MAIN: &CStr = c"main";
            let stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(module)
                .name(MAIN)
                .specialization_info(&spec);
            let info = vk::ComputePipelineCreateInfo::default()
                .stage(stage)
                .layout(layout);
            // SAFETY: valid create info; the module may be destroyed once the pipeline exists.
            let result =
                unsafe { device.create_compute_pipelines(ctx.pipeline_cache(), &[info], None) };
            // SAFETY: the module is no longer needed.
            unsafe { device.destroy_shader_module(module, None) };
            result
                .map(|p| p[0])
                .map_err(|(_, r)| VkError::from_call("vkCreateComputePipelines", r))
        });
        let pipeline = match pipeline {
            Ok(p) => p,
            Err(e) => {
                // SAFETY: unused objects.
                unsafe {
                    device.destroy_pipeline_layout(layout, None);
                    device.destroy_descriptor_set_layout(set_layout, None);
                }
                return Err(e);
            }
        };
        Ok(Self {
            shared: ctx.shared.clone(),
            name: name.to_string(),
            bindings: bindings.to_vec(),
            set_layout,
            layout,
            pipeline,
            push_size,
        })
    }

    /// [`Self::new`], built once per context: later calls with the same name, SPIR-V,
    /// bindings and push-constant size return the same pipeline.
    pub fn cached(
        ctx: &Context,
        name: &str,
        spirv: &[u8],
        bindings: &[Binding],
        push_size: u32,
    ) -> VkResult<Arc<Self>> {
        Self::cached_specialized(ctx, name, spirv, bindings, push_size, &[])
    }

    /// [`Self::new_specialized`], built once per context (as [`Self::cached`]).
    pub fn cached_specialized(
        ctx: &Context,
        name: &str,
        spirv: &[u8],
        bindings: &[Binding],
        push_size: u32,
        constants: &[u32],
    ) -> VkResult<Arc<Self>> {
        let key = cache_key((
            "compute",
            name,
            spirv,
            format!("{bindings:?}"),
            push_size,
            constants,
        ));
        let mut cache = ctx.pipelines.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(p) = cache
            .get(&key)
            .and_then(|p| p.clone().downcast::<Self>().ok())
        {
            return Ok(p);
        }
        let p = Arc::new(Self::new_specialized(
            ctx, name, spirv, bindings, push_size, constants,
        )?);
        cache.insert(key, p.clone());
        Ok(p)
    }

    /// The pipeline's name (used for timeouts and profiler scopes).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Allocates a descriptor set for this pipeline's layout (from its own small pool).
    pub fn allocate_set(&self) -> VkResult<DescriptorSet> {
        DescriptorSet::new(&self.shared, self.set_layout, &self.bindings)
    }

    /// Records a dispatch of `groups` workgroups with `push` as push constants. (A long
    /// one-dimensional dispatch goes through [`rows_of_groups`].)
    pub fn dispatch(
        &self,
        cmd: vk::CommandBuffer,
        set: Option<&DescriptorSet>,
        push: &[u8],
        groups: [u32; 3],
    ) {
        self.bind(cmd, set, push);
        // SAFETY: recording command buffer with this pipeline bound.
        unsafe {
            self.shared
                .device
                .cmd_dispatch(cmd, groups[0], groups[1], groups[2])
        };
    }

    /// Records a dispatch whose workgroup counts the GPU reads from the first three words of
    /// `args` (an `INDIRECT_BUFFER` buffer), so a pass can be sized by work an earlier pass
    /// found (a job list's length).
    pub fn dispatch_indirect(
        &self,
        cmd: vk::CommandBuffer,
        set: Option<&DescriptorSet>,
        push: &[u8],
        args: &super::Buffer,
    ) {
        self.bind(cmd, set, push);
        // SAFETY: recording command buffer with this pipeline bound; `args` has
        // INDIRECT_BUFFER usage (the caller's) and holds three u32 at offset 0.
        unsafe { self.shared.device.cmd_dispatch_indirect(cmd, args.raw(), 0) };
    }

    /// Binds the pipeline, `set` and `push` for a dispatch.
    fn bind(&self, cmd: vk::CommandBuffer, set: Option<&DescriptorSet>, push: &[u8]) {
        let device = &self.shared.device;
        debug_assert_eq!(
            push.len() as u32,
            self.push_size,
            "push-constant size of {}",
            self.name
        );
        // SAFETY: the pipeline, layout and set are alive; push fits the declared range.
        unsafe {
            device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.pipeline);
            if let Some(set) = set {
                device.cmd_bind_descriptor_sets(
                    cmd,
                    vk::PipelineBindPoint::COMPUTE,
                    self.layout,
                    0,
                    &[set.raw],
                    &[],
                );
            }
            if !push.is_empty() {
                device.cmd_push_constants(cmd, self.layout, vk::ShaderStageFlags::COMPUTE, 0, push);
            }
        }
    }

    /// Records a dispatch whose workgroup counts the GPU reads from `args` at byte `offset`
    /// (three `u32`s; the buffer needs `INDIRECT_BUFFER` usage): passes whose size an earlier
    /// pass computed run without a host round trip.
    pub fn dispatch_indirect_at(
        &self,
        cmd: vk::CommandBuffer,
        set: Option<&DescriptorSet>,
        push: &[u8],
        args: &Buffer,
        offset: u64,
    ) {
        self.bind(cmd, set, push);
        // SAFETY: recording command buffer with this pipeline bound; `args` is alive and
        // `offset + 12` lies within it (callers pass fixed slots).
        unsafe {
            self.shared
                .device
                .cmd_dispatch_indirect(cmd, args.raw(), offset)
        };
    }
}

/// Destroys a pipeline with its layouts once no submission can use them.
pub(super) fn retire_pipeline(
    shared: &Shared,
    pipeline: vk::Pipeline,
    layout: vk::PipelineLayout,
    set_layout: vk::DescriptorSetLayout,
) {
    shared.retire(move |shared| {
        // SAFETY: no submission using the pipeline is pending (submissions wait; `retire`
        // defers past submissions that timed out).
        unsafe {
            shared.device.destroy_pipeline(pipeline, None);
            shared.device.destroy_pipeline_layout(layout, None);
            shared
                .device
                .destroy_descriptor_set_layout(set_layout, None);
        }
    });
}

impl Drop for ComputePipeline {
    fn drop(&mut self) {
        retire_pipeline(&self.shared, self.pipeline, self.layout, self.set_layout);
    }
}

/// A descriptor set with its own pool.
pub struct DescriptorSet {
    shared: Arc<Shared>,
    pool: vk::DescriptorPool,
    raw: vk::DescriptorSet,
}

impl DescriptorSet {
    pub(crate) fn new(
        shared: &Arc<Shared>,
        layout: vk::DescriptorSetLayout,
        bindings: &[Binding],
    ) -> VkResult<Self> {
        let device = &shared.device;
        let sizes: Vec<_> = bindings
            .iter()
            .filter(|b| **b != Binding::Unused)
            .map(|b| vk::DescriptorPoolSize {
                ty: b.descriptor_type(),
                descriptor_count: b.count(),
            })
            .collect();
        let info = vk::DescriptorPoolCreateInfo::default()
            .max_sets(1)
            .pool_sizes(&sizes);
        // SAFETY: valid create info.
        let pool =
            unsafe { device.create_descriptor_pool(&info, None) }.call("vkCreateDescriptorPool")?;
        let layouts = [layout];
        let alloc = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(pool)
            .set_layouts(&layouts);
        // SAFETY: the pool was sized for exactly this layout.
        match unsafe { device.allocate_descriptor_sets(&alloc) }.call("vkAllocateDescriptorSets") {
            Ok(sets) => Ok(Self {
                shared: shared.clone(),
                pool,
                raw: sets[0],
            }),
            Err(e) => {
                // SAFETY: unused pool.
                unsafe { device.destroy_descriptor_pool(pool, None) };
                Err(e)
            }
        }
    }

    /// The Vulkan handle.
    pub fn raw(&self) -> vk::DescriptorSet {
        self.raw
    }

    fn write(&self, write: vk::WriteDescriptorSet<'_>) {
        // SAFETY: the set is not in use by a pending submission while it is updated.
        unsafe { self.shared.device.update_descriptor_sets(&[write], &[]) };
    }

    /// Binds a whole buffer as a storage (or uniform, per `ty`) buffer.
    pub fn buffer(&self, binding: u32, buffer: &Buffer, ty: Binding) -> &Self {
        let info = [vk::DescriptorBufferInfo::default()
            .buffer(buffer.raw())
            .offset(0)
            .range(vk::WHOLE_SIZE)];
        self.write(
            vk::WriteDescriptorSet::default()
                .dst_set(self.raw)
                .dst_binding(binding)
                .descriptor_type(ty.descriptor_type())
                .buffer_info(&info),
        );
        self
    }

    /// Binds a storage image view in `GENERAL` layout.
    pub fn storage_image(&self, binding: u32, view: vk::ImageView) -> &Self {
        let info = [vk::DescriptorImageInfo::default()
            .image_view(view)
            .image_layout(vk::ImageLayout::GENERAL)];
        self.write(
            vk::WriteDescriptorSet::default()
                .dst_set(self.raw)
                .dst_binding(binding)
                .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
                .image_info(&info),
        );
        self
    }

    /// Binds combined image samplers (shader-read-only layout) to array elements 0..n.
    pub fn sampled_images(&self, binding: u32, images: &[(vk::ImageView, vk::Sampler)]) -> &Self {
        if images.is_empty() {
            return self;
        }
        let info: Vec<_> = images
            .iter()
            .map(|&(view, sampler)| {
                vk::DescriptorImageInfo::default()
                    .image_view(view)
                    .sampler(sampler)
                    .image_layout(vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL)
            })
            .collect();
        self.write(
            vk::WriteDescriptorSet::default()
                .dst_set(self.raw)
                .dst_binding(binding)
                .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
                .image_info(&info),
        );
        self
    }

    /// Binds a top-level acceleration structure.
    pub fn acceleration_structure(
        &self,
        binding: u32,
        tlas: vk::AccelerationStructureKHR,
    ) -> &Self {
        let handles = [tlas];
        let mut as_info = vk::WriteDescriptorSetAccelerationStructureKHR::default()
            .acceleration_structures(&handles);
        // descriptor_count must be set by hand: the AS array lives in the pNext struct.
        let write = vk::WriteDescriptorSet::default()
            .dst_set(self.raw)
            .dst_binding(binding)
            .descriptor_type(vk::DescriptorType::ACCELERATION_STRUCTURE_KHR)
            .descriptor_count(1)
            .push_next(&mut as_info);
        self.write(write);
        self
    }
}

impl Drop for DescriptorSet {
    fn drop(&mut self) {
        let pool = self.pool;
        // SAFETY: no pending submission uses the set (`retire` defers past timed-out ones).
        self.shared
            .retire(move |shared| unsafe { shared.device.destroy_descriptor_pool(pool, None) });
    }
}

/// Records a full memory barrier between compute/transfer writes and later reads.
pub fn memory_barrier(device: &ash::Device, cmd: vk::CommandBuffer) {
    let barrier = [vk::MemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
        .src_access_mask(vk::AccessFlags2::MEMORY_WRITE)
        .dst_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
        .dst_access_mask(vk::AccessFlags2::MEMORY_READ | vk::AccessFlags2::MEMORY_WRITE)];
    let dep = vk::DependencyInfo::default().memory_barriers(&barrier);
    // SAFETY: recording command buffer; synchronization2 is enabled.
    unsafe { device.cmd_pipeline_barrier2(cmd, &dep) };
}

/// A one-dimensional dispatch of `groups` workgroups as rows of at most `per_row` (a power of
/// two up to 65 535, the shaders' row width, `interface::GROUPS_PER_ROW`): a device may launch
/// no more than 65 535 in one dimension (`maxComputeWorkGroupCount`, lavapipe's limit), which
/// 64-pixel workgroups reach at 2048×2048. Shaders number their invocations with
/// `linear_invocation()` (`shaders/common/counters.glsl`) and skip those past their count.
pub fn rows_of_groups(groups: u32, per_row: u32) -> [u32; 3] {
    let row = groups.min(per_row);
    [row, groups.div_ceil(row.max(1)).max(1), 1]
}

#[cfg(test)]
mod tests {
    use super::rows_of_groups;

    #[test]
    fn rows_of_groups_cover_the_dispatch_within_the_limit() {
        // The shaders' row width (`interface::GROUPS_PER_ROW`) and a narrow one.
        for (groups, per_row) in [0, 1, 63, 32_768, 65_535, 65_536, 68_907, 129_600, 1 << 24]
            .into_iter()
            .flat_map(|g| [(g, 32_768), (g, 1024)])
        {
            let [x, y, z] = rows_of_groups(groups, per_row);
            assert!(x <= 65_535 && y <= 65_535 && z == 1, "{groups}: {x} x {y}");
            let launched = u64::from(x) * u64::from(y);
            assert!(launched >= u64::from(groups), "{groups}: {x} x {y}");
            // At most one row's worth more than asked (the shaders skip past their count).
            assert!(
                launched < u64::from(groups) + u64::from(x.max(1)),
                "{groups}: {x} x {y}"
            );
        }
        assert_eq!(rows_of_groups(100, 32_768), [100, 1, 1]);
        assert_eq!(rows_of_groups(2000, 1024), [1024, 2, 1]);
    }
}
