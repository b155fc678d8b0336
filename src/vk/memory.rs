//! Device memory: [`Buffer`] and [`Image`] allocated through `gpu-allocator`, uploads and
//! read-backs, and barriers around host reads.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

use super::context::Shared;
use super::{CallExt, Context, VkError, VkResult};

fn allocate(
    shared: &Shared,
    name: &str,
    requirements: vk::MemoryRequirements,
    location: MemoryLocation,
    linear: bool,
) -> VkResult<Allocation> {
    shared
        .allocations
        .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let mut guard = shared.allocator.lock().expect("allocator lock poisoned");
    let allocator = guard.as_mut().expect("allocator alive while the device is");
    allocator
        .allocate(&AllocationCreateDesc {
            name,
            requirements,
            location,
            linear,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        })
        .map_err(|e| VkError::OutOfMemory {
            what: name.to_string(),
            bytes: requirements.size,
            reason: e.to_string(),
        })
}

fn free(shared: &Shared, allocation: Allocation) {
    if let Ok(mut guard) = shared.allocator.lock() {
        if let Some(allocator) = guard.as_mut() {
            if let Err(e) = allocator.free(allocation) {
                log::error!("freeing GPU memory failed: {e}");
            }
        }
    }
}

/// A buffer with its memory; always usable as a storage buffer, a transfer source/target
/// and through its device address.
pub struct Buffer {
    shared: Arc<Shared>,
    raw: vk::Buffer,
    allocation: Option<Allocation>,
    size: u64,
    address: vk::DeviceAddress,
}

impl Buffer {
    /// Creates an uninitialised buffer of `size` bytes (a zero size is rounded up to 4:
    /// Vulkan forbids empty buffers). `usage` is added to the defaults.
    pub fn new(
        ctx: &Context,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> VkResult<Self> {
        let shared = ctx.shared.clone();
        let size = size.max(4);
        let usage = usage
            | vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_SRC
            | vk::BufferUsageFlags::TRANSFER_DST
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        let device = &shared.device;
        // SAFETY: valid create info.
        let raw = unsafe { device.create_buffer(&info, None) }.call("vkCreateBuffer")?;
        // SAFETY: `raw` was just created.
        let requirements = unsafe { device.get_buffer_memory_requirements(raw) };
        let allocation = match allocate(&shared, name, requirements, location, true) {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: unused buffer.
                unsafe { device.destroy_buffer(raw, None) };
                return Err(e);
            }
        };
        // SAFETY: the allocation satisfies the buffer's requirements and outlives it.
        if let Err(e) =
            unsafe { device.bind_buffer_memory(raw, allocation.memory(), allocation.offset()) }
                .call("vkBindBufferMemory")
        {
            // SAFETY: unused buffer.
            unsafe { device.destroy_buffer(raw, None) };
            free(&shared, allocation);
            return Err(e);
        }
        // SAFETY: the buffer has SHADER_DEVICE_ADDRESS usage and bound memory.
        let address = unsafe {
            device.get_buffer_device_address(&vk::BufferDeviceAddressInfo::default().buffer(raw))
        };
        Ok(Self {
            shared,
            raw,
            allocation: Some(allocation),
            size,
            address,
        })
    }

    /// Creates a GPU-only buffer holding `data` (uploaded through a staging buffer).
    pub fn from_slice<T: bytemuck::Pod>(
        ctx: &Context,
        name: &str,
        data: &[T],
        usage: vk::BufferUsageFlags,
    ) -> VkResult<Self> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let buffer = Self::new(
            ctx,
            name,
            bytes.len() as u64,
            usage,
            MemoryLocation::GpuOnly,
        )?;
        buffer.upload(ctx, bytes)?;
        Ok(buffer)
    }

    /// Copies `bytes` to the start of the buffer through a staging buffer (waits).
    pub fn upload(&self, ctx: &Context, bytes: &[u8]) -> VkResult<()> {
        if bytes.is_empty() {
            return Ok(());
        }
        if bytes.len() as u64 > self.size {
            return Err(VkError::Invalid(format!(
                "upload of {} bytes into a {}-byte buffer",
                bytes.len(),
                self.size
            )));
        }
        let mut staging = Self::new(
            ctx,
            "staging upload",
            bytes.len() as u64,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::CpuToGpu,
        )?;
        staging.write(bytes)?;
        ctx.run("upload", |cmd| {
            let region = vk::BufferCopy::default().size(bytes.len() as u64);
            // SAFETY: both buffers are alive and large enough.
            unsafe {
                ctx.device()
                    .cmd_copy_buffer(cmd, staging.raw, self.raw, &[region])
            };
            Ok(())
        })
    }

    /// Writes `bytes` into a host-visible buffer.
    pub fn write(&mut self, bytes: &[u8]) -> VkResult<()> {
        let size = self.size;
        let slice = self
            .allocation
            .as_mut()
            .and_then(|a| a.mapped_slice_mut())
            .ok_or_else(|| VkError::Invalid("write to a buffer that is not host-visible".into()))?;
        if bytes.len() as u64 > size {
            return Err(VkError::Invalid(format!(
                "write of {} bytes into a {size}-byte buffer",
                bytes.len()
            )));
        }
        slice[..bytes.len()].copy_from_slice(bytes);
        Ok(())
    }

    /// Reads the whole buffer back (through a staging buffer unless host-visible).
    pub fn read<T: bytemuck::Pod>(&self, ctx: &Context) -> VkResult<Vec<T>> {
        let count = self.size as usize / std::mem::size_of::<T>();
        let bytes = count * std::mem::size_of::<T>();
        if let Some(mapped) = self.allocation.as_ref().and_then(|a| a.mapped_slice()) {
            return Ok(bytemuck::pod_collect_to_vec(&mapped[..bytes]));
        }
        let staging = Self::new(
            ctx,
            "staging readback",
            self.size,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::GpuToCpu,
        )?;
        ctx.run("readback", |cmd| {
            let region = vk::BufferCopy::default().size(self.size);
            // SAFETY: both buffers are alive and of equal size.
            unsafe {
                ctx.device()
                    .cmd_copy_buffer(cmd, self.raw, staging.raw, &[region])
            };
            Ok(())
        })?;
        let mapped = staging
            .allocation
            .as_ref()
            .and_then(|a| a.mapped_slice())
            .ok_or_else(|| VkError::Invalid("readback buffer is not host-visible".into()))?;
        Ok(bytemuck::pod_collect_to_vec(&mapped[..bytes]))
    }

    /// Records a copy of `size` bytes from `src_offset` of this buffer to `dst_offset` of
    /// `dst` (both alive until the command buffer completes).
    pub fn record_copy_to(
        &self,
        device: &ash::Device,
        cmd: vk::CommandBuffer,
        dst: &Buffer,
        src_offset: u64,
        dst_offset: u64,
        size: u64,
    ) {
        let region = vk::BufferCopy::default()
            .src_offset(src_offset)
            .dst_offset(dst_offset)
            .size(size);
        // SAFETY: recording command buffer; both buffers are alive and the caller keeps the
        // ranges within them.
        unsafe { device.cmd_copy_buffer(cmd, self.raw, dst.raw, &[region]) };
    }

    /// Records an update of the start of the buffer with `bytes` (at most 65536, a multiple
    /// of 4): the way a frame recorded into a burst gets its own uniforms, without the host
    /// writing memory the previous frame still reads.
    pub fn record_update(&self, device: &ash::Device, cmd: vk::CommandBuffer, bytes: &[u8]) {
        debug_assert!(bytes.len() <= 65536 && bytes.len() % 4 == 0);
        debug_assert!(bytes.len() as u64 <= self.size);
        // SAFETY: recording command buffer; the buffer has TRANSFER_DST usage and is large
        // enough (checked above in debug builds; callers pass their own uniform structs).
        unsafe { device.cmd_update_buffer(cmd, self.raw, 0, bytes) };
    }

    /// `count` elements at byte `offset` of a host-visible buffer, after the submission that
    /// wrote them completed (see [`host_read_barrier`]). `None` if the buffer is not
    /// host-visible or the range is outside it.
    pub fn mapped_read<T: bytemuck::Pod>(&self, offset: u64, count: usize) -> Option<Vec<T>> {
        let mapped = self.allocation.as_ref()?.mapped_slice()?;
        let start = usize::try_from(offset).ok()?;
        let end = start.checked_add(count.checked_mul(std::mem::size_of::<T>())?)?;
        Some(bytemuck::pod_collect_to_vec(mapped.get(start..end)?))
    }

    /// The Vulkan handle.
    pub fn raw(&self) -> vk::Buffer {
        self.raw
    }

    /// Size in bytes.
    pub fn size(&self) -> u64 {
        self.size
    }

    /// Device address (for `buffer_reference` in shaders and acceleration-structure builds).
    pub fn address(&self) -> vk::DeviceAddress {
        self.address
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        let (raw, allocation) = (self.raw, self.allocation.take());
        self.shared.retire(move |shared| {
            // SAFETY: no pending submission uses the buffer: every `Context::run` waits for
            // its fence, and `retire` defers past submissions that timed out.
            unsafe { shared.device.destroy_buffer(raw, None) };
            if let Some(a) = allocation {
                free(shared, a);
            }
        });
    }
}

/// Makes transfer writes recorded before it visible to the host once the submission's fence
/// has signalled (for reading back host-visible buffers filled inside a frame).
pub fn host_read_barrier(device: &ash::Device, cmd: vk::CommandBuffer) {
    let barrier = [vk::MemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
        .src_access_mask(vk::AccessFlags2::MEMORY_WRITE)
        .dst_stage_mask(vk::PipelineStageFlags2::HOST)
        .dst_access_mask(vk::AccessFlags2::HOST_READ)];
    let dep = vk::DependencyInfo::default().memory_barriers(&barrier);
    // SAFETY: recording command buffer; synchronization2 is enabled.
    unsafe { device.cmd_pipeline_barrier2(cmd, &dep) };
}

/// A 2D image with one view over all its mip levels.
pub struct Image {
    shared: Arc<Shared>,
    raw: vk::Image,
    view: vk::ImageView,
    allocation: Option<Allocation>,
    /// Texel format.
    pub format: vk::Format,
    /// Size of mip 0.
    pub extent: vk::Extent2D,
    /// Number of mip levels.
    pub mip_levels: u32,
}

impl Image {
    /// Creates a device-local 2D image and its view. The image starts in `UNDEFINED` layout.
    pub fn new(
        ctx: &Context,
        name: &str,
        extent: vk::Extent2D,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
        mip_levels: u32,
    ) -> VkResult<Self> {
        let limit = ctx.info().max_image_dimension_2d;
        if extent.width == 0 || extent.height == 0 || extent.width > limit || extent.height > limit
        {
            let what = format!(
                "image '{name}' of {}x{} is outside the device's 1..={limit} range",
                extent.width, extent.height
            );
            let side = extent.width.max(extent.height);
            return Err(if side > limit {
                VkError::Limit {
                    what,
                    needed: side.into(),
                    available: limit.into(),
                }
            } else {
                VkError::Invalid(what)
            });
        }
        let shared = ctx.shared.clone();
        let device = &shared.device;
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D {
                width: extent.width,
                height: extent.height,
                depth: 1,
            })
            .mip_levels(mip_levels.max(1))
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid create info.
        let raw = unsafe { device.create_image(&info, None) }.call("vkCreateImage")?;
        // SAFETY: `raw` was just created.
        let requirements = unsafe { device.get_image_memory_requirements(raw) };
        let allocation = match allocate(&shared, name, requirements, MemoryLocation::GpuOnly, false)
        {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: unused image.
                unsafe { device.destroy_image(raw, None) };
                return Err(e);
            }
        };
        // SAFETY: the allocation satisfies the image's requirements and outlives it.
        let bound =
            unsafe { device.bind_image_memory(raw, allocation.memory(), allocation.offset()) }
                .call("vkBindImageMemory");
        let aspect = if matches!(
            format,
            vk::Format::D32_SFLOAT | vk::Format::D16_UNORM | vk::Format::X8_D24_UNORM_PACK32
        ) {
            vk::ImageAspectFlags::DEPTH
        } else {
            vk::ImageAspectFlags::COLOR
        };
        let view = bound.and_then(|()| {
            let view_info = vk::ImageViewCreateInfo::default()
                .image(raw)
                .view_type(vk::ImageViewType::TYPE_2D)
                .format(format)
                .subresource_range(vk::ImageSubresourceRange {
                    aspect_mask: aspect,
                    base_mip_level: 0,
                    level_count: mip_levels.max(1),
                    base_array_layer: 0,
                    layer_count: 1,
                });
            // SAFETY: the image has bound memory.
            unsafe { device.create_image_view(&view_info, None) }.call("vkCreateImageView")
        });
        let view = match view {
            Ok(v) => v,
            Err(e) => {
                // SAFETY: unused image.
                unsafe { device.destroy_image(raw, None) };
                free(&shared, allocation);
                return Err(e);
            }
        };
        Ok(Self {
            shared,
            raw,
            view,
            allocation: Some(allocation),
            format,
            extent,
            mip_levels: mip_levels.max(1),
        })
    }

    /// The Vulkan handle.
    pub fn raw(&self) -> vk::Image {
        self.raw
    }

    /// The view over every mip level.
    pub fn view(&self) -> vk::ImageView {
        self.view
    }

    /// Reads mip 0 of a 16-byte-texel image (`R32G32B32A32_SFLOAT`) back, the image being in
    /// `layout` (which it stays in) and made with `TRANSFER_SRC`. Waits.
    pub fn read_rgba32f(&self, ctx: &Context, layout: vk::ImageLayout) -> VkResult<Vec<[f32; 4]>> {
        if self.format != vk::Format::R32G32B32A32_SFLOAT {
            return Err(VkError::Invalid(format!(
                "read_rgba32f of a {:?} image",
                self.format
            )));
        }
        let texels = self.extent.width as usize * self.extent.height as usize;
        let staging = Buffer::new(
            ctx,
            "image readback",
            (texels * 16) as u64,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::GpuToCpu,
        )?;
        ctx.run("image readback", |cmd| {
            crate::vk::memory_barrier(ctx.device(), cmd);
            let region = vk::BufferImageCopy::default()
                .image_subresource(vk::ImageSubresourceLayers {
                    aspect_mask: vk::ImageAspectFlags::COLOR,
                    mip_level: 0,
                    base_array_layer: 0,
                    layer_count: 1,
                })
                .image_extent(vk::Extent3D {
                    width: self.extent.width,
                    height: self.extent.height,
                    depth: 1,
                });
            // SAFETY: the image is alive in `layout` with TRANSFER_SRC usage (the caller's
            // contract) and the staging buffer holds all of mip 0.
            unsafe {
                ctx.device().cmd_copy_image_to_buffer(
                    cmd,
                    self.raw,
                    layout,
                    staging.raw(),
                    &[region],
                )
            };
            Ok(())
        })?;
        staging
            .mapped_read(0, texels)
            .ok_or_else(|| VkError::Invalid("image readback buffer is not host-visible".into()))
    }

    /// Records a full layout transition of every mip level, ordering all prior memory
    /// accesses before all later ones (simple and always correct; passes are few and large).
    pub fn transition(&self, cmd: vk::CommandBuffer, old: vk::ImageLayout, new: vk::ImageLayout) {
        let aspect = if matches!(
            self.format,
            vk::Format::D32_SFLOAT | vk::Format::D16_UNORM | vk::Format::X8_D24_UNORM_PACK32
        ) {
            vk::ImageAspectFlags::DEPTH
        } else {
            vk::ImageAspectFlags::COLOR
        };
        let barrier = [vk::ImageMemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
            .src_access_mask(vk::AccessFlags2::MEMORY_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
            .dst_access_mask(vk::AccessFlags2::MEMORY_READ | vk::AccessFlags2::MEMORY_WRITE)
            .old_layout(old)
            .new_layout(new)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(self.raw)
            .subresource_range(vk::ImageSubresourceRange {
                aspect_mask: aspect,
                base_mip_level: 0,
                level_count: self.mip_levels,
                base_array_layer: 0,
                layer_count: 1,
            })];
        let dep = vk::DependencyInfo::default().image_memory_barriers(&barrier);
        // SAFETY: recording command buffer; the image is alive; synchronization2 is enabled.
        unsafe { self.shared.device.cmd_pipeline_barrier2(cmd, &dep) };
    }
}

impl Drop for Image {
    fn drop(&mut self) {
        let (raw, view, allocation) = (self.raw, self.view, self.allocation.take());
        self.shared.retire(move |shared| {
            // SAFETY: GPU work using the image has completed (every submission waits;
            // `retire` defers past submissions that timed out).
            unsafe {
                shared.device.destroy_image_view(view, None);
                shared.device.destroy_image(raw, None);
            }
            if let Some(a) = allocation {
                free(shared, a);
            }
        });
    }
}
