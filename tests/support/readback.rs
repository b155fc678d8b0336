//! Reading uploaded texture levels back to the host (texture upload tests).

use rqr::scene::textures::GpuTextures;
use rqr::vk::{vk, Buffer, Context, MemoryLocation};

/// Copies mip `level` of uploaded image `index` back to the host: `bytes` of RGBA8 texels or
/// 16-byte blocks, tightly packed.
pub fn read_level(
    ctx: &Context,
    tex: &GpuTextures,
    index: usize,
    level: u32,
    bytes: usize,
) -> Vec<u8> {
    let image = &tex.images()[index];
    let buffer = Buffer::new(
        ctx,
        "level readback",
        bytes as u64,
        vk::BufferUsageFlags::empty(),
        MemoryLocation::GpuToCpu,
    )
    .unwrap();
    let range = vk::ImageSubresourceRange {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        base_mip_level: level,
        level_count: 1,
        base_array_layer: 0,
        layer_count: 1,
    };
    let transition = |old, new, src: (vk::PipelineStageFlags2, vk::AccessFlags2), dst: (_, _)| {
        vk::ImageMemoryBarrier2::default()
            .src_stage_mask(src.0)
            .src_access_mask(src.1)
            .dst_stage_mask(dst.0)
            .dst_access_mask(dst.1)
            .old_layout(old)
            .new_layout(new)
            .image(image.raw())
            .subresource_range(range)
    };
    let sampled = (
        vk::PipelineStageFlags2::ALL_COMMANDS,
        vk::AccessFlags2::SHADER_SAMPLED_READ,
    );
    let transfer = (
        vk::PipelineStageFlags2::ALL_TRANSFER,
        vk::AccessFlags2::TRANSFER_READ,
    );
    ctx.run("level readback", |cmd| {
        let copy = vk::BufferImageCopy::default()
            .image_subresource(vk::ImageSubresourceLayers {
                aspect_mask: vk::ImageAspectFlags::COLOR,
                mip_level: level,
                base_array_layer: 0,
                layer_count: 1,
            })
            .image_extent(vk::Extent3D {
                width: (image.extent.width >> level).max(1),
                height: (image.extent.height >> level).max(1),
                depth: 1,
            });
        let to_src = [transition(
            vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            sampled,
            transfer,
        )];
        let back = [transition(
            vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            transfer,
            sampled,
        )];
        let device = ctx.device();
        // SAFETY: recording command buffer; the image was uploaded with TRANSFER_SRC usage and
        // the buffer holds the whole level.
        unsafe {
            device.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&to_src),
            );
            device.cmd_copy_image_to_buffer(
                cmd,
                image.raw(),
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                buffer.raw(),
                &[copy],
            );
            device.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&back),
            );
        }
        Ok(())
    })
    .unwrap();
    buffer.read::<u8>(ctx).unwrap()
}
