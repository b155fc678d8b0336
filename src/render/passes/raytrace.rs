//! The pure ray-traced (Whitted) pass: `shaders/raytrace.comp`, one thread per pixel.

use std::sync::Arc;

use ash::vk;

use crate::accel::Backend;
use crate::interface::distributed::PIXELS_PER_INVOCATION;
use crate::interface::{
    self as io, bindings, push_bytes, scene_bindings, RaytracePush, FLAG_ADAPTIVE_CORNERS,
    FLAG_WRITE_AOV,
};
use crate::render::{Aov, PassContext};
use crate::render::{GpuFrame, RenderSettings, SamplerKind, Shading};
use crate::vk::{
    memory_barrier, Binding, Buffer, ComputePipeline, Context, DescriptorSet, GpuProfiler,
    MemoryLocation, VkResult,
};

/// Words of the ray-traced and hybrid passes' counter buffers: per stripe
/// (`RAY_COUNTER_STRIPES`, `RAY_COUNTER_STRIDE` words apart) primary, shadow, reflection,
/// refraction, samples.
pub const COUNTER_WORDS: usize = (io::RAY_COUNTER_STRIPES * io::RAY_COUNTER_STRIDE) as usize;

/// Counter `k` of striped counters `c`: the sum of word `k` of each of the
/// `RAY_COUNTER_STRIPES` copies, `RAY_COUNTER_STRIDE` words apart (words past the end count 0).
pub fn striped_sum(c: &[u32], k: u32) -> u64 {
    (0..io::RAY_COUNTER_STRIPES)
        .map(|s| (s * io::RAY_COUNTER_STRIDE + k) as usize)
        .map(|i| u64::from(c.get(i).copied().unwrap_or(0)))
        .sum()
}

/// Ray counts and samples from a ray-traced or hybrid frame's counters (the sums over stripes).
pub fn ray_counts(c: &[u32]) -> (crate::render::RayCounts, u64) {
    let count = |k: u32| striped_sum(c, k);
    (
        crate::render::RayCounts {
            primary: count(io::RAY_PRIMARY),
            shadow: count(io::RAY_SHADOW),
            reflection: count(io::RAY_REFLECTION),
            refraction: count(io::RAY_REFRACTION),
            diffuse: count(io::RAY_DIFFUSE),
        },
        count(io::COUNTER_SAMPLES),
    )
}

/// Pipeline and per-resolution buffers of the ray-traced pass.
pub struct RaytracedPass {
    pipeline: Arc<ComputePipeline>,
    set: DescriptorSet,
    /// Linear HDR colour, `vec4` per pixel.
    pub color: Buffer,
    /// AOVs per pixel when created with `write_aov`, else a one-element placeholder (the
    /// shader writes AOVs only under `FLAG_WRITE_AOV`).
    pub aov: Buffer,
    /// Ray counters.
    pub counters: Buffer,
    _corners: Buffer,
    frame: Buffer,
    write_aov: bool,
    /// The shading model (the distributed pass lays its invocations out differently).
    shading: Shading,
    /// Device address of the denoiser's guide out (0: none).
    guide: vk::DeviceAddress,
}

fn spirv(backend: Backend, shading: Shading) -> &'static [u8] {
    match (shading, backend) {
        (Shading::Whitted, Backend::Hw) => crate::shaders::RAYTRACE_COMP_HW,
        (Shading::Whitted, Backend::Bvh) => crate::shaders::RAYTRACE_COMP_BVH,
        (Shading::Distributed, Backend::Hw) => crate::shaders::RAYTRACE_DISTRIBUTED_COMP_HW,
        (Shading::Distributed, Backend::Bvh) => crate::shaders::RAYTRACE_DISTRIBUTED_COMP_BVH,
    }
}

impl RaytracedPass {
    /// Creates the pipeline and buffers for `settings`' resolution; the per-pixel AOV buffer
    /// only when `write_aov` (80 bytes per pixel: at full size it alone limits the resolution
    /// on devices with a small `maxStorageBufferRange`). `frame_buf` is the Frame uniform
    /// buffer, written by [`Self::record`].
    pub fn new(
        ctx: &Context,
        pass: &PassContext<'_>,
        settings: &RenderSettings,
        frame_buf: Buffer,
        write_aov: bool,
    ) -> VkResult<Self> {
        let layout = bindings(
            &[
                &scene_bindings(pass.texture_capacity(), pass.backend.binding())[..],
                &[
                    (io::BINDING_RT_AOV, Binding::StorageBuffer),
                    (io::BINDING_RT_COUNTERS, Binding::StorageBuffer),
                    (io::BINDING_RT_CORNERS, Binding::StorageBuffer),
                ],
            ]
            .concat(),
        );
        let pipeline = ComputePipeline::cached(
            ctx,
            "raytrace",
            spirv(pass.backend.kind(), settings.shading),
            &layout,
            std::mem::size_of::<RaytracePush>() as u32,
        )?;
        let pixels = settings.pixels();
        let none = vk::BufferUsageFlags::empty();
        let color = Buffer::new(ctx, "rt colour", pixels * 16, none, MemoryLocation::GpuOnly)?;
        let aov_len = if write_aov { pixels } else { 1 };
        let aov = Buffer::new(
            ctx,
            if write_aov {
                "rt aov"
            } else {
                "rt aov placeholder"
            },
            aov_len * std::mem::size_of::<Aov>() as u64,
            none,
            MemoryLocation::GpuOnly,
        )?;
        let counters = Buffer::new(
            ctx,
            "rt counters",
            COUNTER_WORDS as u64 * 4,
            none,
            MemoryLocation::GpuOnly,
        )?;
        let corner_count = (u64::from(settings.width) + 1) * (u64::from(settings.height) + 1);
        let corners = Buffer::new(
            ctx,
            "rt adaptive corners",
            corner_count * 16,
            none,
            MemoryLocation::GpuOnly,
        )?;
        let set = pipeline.allocate_set()?;
        pass.bind_scene(&set);
        set.buffer(io::BINDING_FRAME, &frame_buf, Binding::UniformBuffer)
            .buffer(io::BINDING_RT_AOV, &aov, Binding::StorageBuffer)
            .buffer(io::BINDING_RT_COUNTERS, &counters, Binding::StorageBuffer)
            .buffer(io::BINDING_RT_CORNERS, &corners, Binding::StorageBuffer);
        Ok(Self {
            pipeline,
            set,
            color,
            aov,
            counters,
            _corners: corners,
            frame: frame_buf,
            write_aov,
            shading: settings.shading,
            guide: 0,
        })
    }

    /// Makes the pass write the denoiser's colour split to `guide` (a
    /// [`crate::interface::denoise::DenoiseGuide`] per pixel; distributed shading).
    pub fn write_guide(&mut self, guide: &Buffer) {
        self.guide = guide.address();
    }

    /// Whether [`Self::record`] writes the AOVs (the pass was created with `write_aov`).
    pub fn writes_aov(&self) -> bool {
        self.write_aov
    }

    /// Records the pass for `frame` (camera, settings; written into the uniform by the
    /// commands themselves): counter reset, the adaptive corner pass when that sampler is on,
    /// then one thread per pixel (writing AOVs when the pass was created to). The caller
    /// orders it after earlier readers of the uniform and counters.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        frame: &GpuFrame,
        profiler: Option<&mut GpuProfiler>,
    ) {
        let device = ctx.device();
        let f = *frame;
        self.frame
            .record_update(device, cmd, bytemuck::bytes_of(&f));
        // SAFETY: recording command buffer; the counters buffer is ours.
        unsafe { device.cmd_fill_buffer(cmd, self.counters.raw(), 0, vk::WHOLE_SIZE, 0) };
        memory_barrier(device, cmd);
        let mut profiler = profiler;
        if let Some(p) = profiler.as_deref_mut() {
            p.begin(cmd, crate::render::PassScope::RayTraced.name());
        }
        if f.sampler_kind == SamplerKind::Adaptive.code() {
            let push = RaytracePush {
                flags: FLAG_ADAPTIVE_CORNERS,
                pad0: 0,
                color: self.color.address(),
                guide: 0,
            };
            let groups = [(f.width + 1).div_ceil(8), (f.height + 1).div_ceil(8), 1];
            self.pipeline
                .dispatch(cmd, Some(&self.set), push_bytes(&push), groups);
            memory_barrier(device, cmd);
        }
        let push = RaytracePush {
            flags: if self.write_aov { FLAG_WRITE_AOV } else { 0 },
            pad0: 0,
            color: self.color.address(),
            guide: self.guide,
        };
        // The distributed pass's invocations take PIXELS_PER_INVOCATION pixels each, in turn.
        let rows = if self.shading == Shading::Distributed {
            f.height.div_ceil(PIXELS_PER_INVOCATION)
        } else {
            f.height
        };
        self.pipeline.dispatch(
            cmd,
            Some(&self.set),
            push_bytes(&push),
            [f.width.div_ceil(8), rows.div_ceil(8), 1],
        );
        if let Some(p) = profiler {
            p.end(cmd);
        }
    }
}
