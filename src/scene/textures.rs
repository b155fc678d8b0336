//! Uploads a scene's images as sampled Vulkan images with full mip chains, and creates one
//! sampler per distinct glTF sampler state, for a bindless `sampler2D textures[]` array.

use std::collections::HashMap;

use ash::vk;

use super::types::{Sampler as SamplerState, Scene, Wrap};
use crate::vk::{Buffer, Context, Image, MemoryLocation, Sampler, VkError, VkResult};

/// A scene's textures on the GPU.
pub struct GpuTextures {
    /// One image per [`Scene::images`] entry, in `SHADER_READ_ONLY_OPTIMAL`.
    images: Vec<Image>,
    /// Distinct samplers.
    samplers: Vec<Sampler>,
    /// Per [`Scene::textures`] entry: (image index, sampler index).
    textures: Vec<(usize, usize)>,
}

/// Number of mip levels of a full chain down to 1x1.
pub fn mip_levels(width: u32, height: u32) -> u32 {
    32 - width.max(height).max(1).leading_zeros()
}

fn address_mode(w: Wrap) -> vk::SamplerAddressMode {
    match w {
        Wrap::Repeat => vk::SamplerAddressMode::REPEAT,
        Wrap::MirroredRepeat => vk::SamplerAddressMode::MIRRORED_REPEAT,
        Wrap::ClampToEdge => vk::SamplerAddressMode::CLAMP_TO_EDGE,
    }
}

fn filter(linear: bool) -> vk::Filter {
    if linear {
        vk::Filter::LINEAR
    } else {
        vk::Filter::NEAREST
    }
}

/// The Vulkan sampler for a glTF sampler state. Anisotropy is off. Without mipmapping
/// (glTF `minFilter` NEAREST / LINEAR) the LOD is clamped to 0.25, Vulkan's recipe for
/// "no mipmaps" that still tells magnification from minification.
pub fn sampler_create_info(s: &SamplerState) -> vk::SamplerCreateInfo<'static> {
    vk::SamplerCreateInfo::default()
        .mag_filter(filter(s.mag_linear))
        .min_filter(filter(s.min_linear))
        .mipmap_mode(if s.mipmaps && s.mip_linear {
            vk::SamplerMipmapMode::LINEAR
        } else {
            vk::SamplerMipmapMode::NEAREST
        })
        .address_mode_u(address_mode(s.wrap_s))
        .address_mode_v(address_mode(s.wrap_t))
        .address_mode_w(vk::SamplerAddressMode::REPEAT)
        .anisotropy_enable(false)
        .min_lod(0.0)
        .max_lod(if s.mipmaps { vk::LOD_CLAMP_NONE } else { 0.25 })
}

fn barrier(
    image: vk::Image,
    levels: std::ops::Range<u32>,
    (src_stage, src_access, old): (vk::PipelineStageFlags2, vk::AccessFlags2, vk::ImageLayout),
    (dst_stage, dst_access, new): (vk::PipelineStageFlags2, vk::AccessFlags2, vk::ImageLayout),
) -> vk::ImageMemoryBarrier2<'static> {
    vk::ImageMemoryBarrier2::default()
        .src_stage_mask(src_stage)
        .src_access_mask(src_access)
        .dst_stage_mask(dst_stage)
        .dst_access_mask(dst_access)
        .old_layout(old)
        .new_layout(new)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(vk::ImageSubresourceRange {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            base_mip_level: levels.start,
            level_count: levels.end - levels.start,
            base_array_layer: 0,
            layer_count: 1,
        })
}

/// Records `barriers` (synchronization2).
fn pipeline_barrier(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    barriers: &[vk::ImageMemoryBarrier2],
) {
    let dep = vk::DependencyInfo::default().image_memory_barriers(barriers);
    // SAFETY: recording command buffer; synchronization2 is enabled on every rqr device.
    unsafe { device.cmd_pipeline_barrier2(cmd, &dep) };
}

impl GpuTextures {
    /// Uploads every image of `scene` once (R8G8B8A8_SRGB or _UNORM per
    /// [`ImageData::srgb`](super::ImageData::srgb)), uploads the mip levels an image stores
    /// ([`ImageData::mips`](super::ImageData::mips), from KTX2 files) or else generates the
    /// full chain with linear blits (which filter sRGB images in linear space), leaves each in
    /// `SHADER_READ_ONLY_OPTIMAL`, and creates one sampler per distinct sampler state.
    /// Fails with [`VkError::Limit`] for an image larger than the device's
    /// `maxImageDimension2D` or whose pixel data does not match its size.
    pub fn upload(ctx: &Context, scene: &Scene) -> VkResult<Self> {
        let limit = ctx.info().max_image_dimension_2d;
        for (i, img) in scene.images.iter().enumerate() {
            if img.width > limit || img.height > limit {
                return Err(VkError::Limit(format!(
                    "{}: image {i} is {}x{}, larger than this device's maxImageDimension2D ({limit})",
                    scene.source, img.width, img.height
                )));
            }
            if img.width == 0
                || img.height == 0
                || img.rgba8.len() as u64 != u64::from(img.width) * u64::from(img.height) * 4
            {
                return Err(VkError::Limit(format!(
                    "{}: image {i} has {} bytes of RGBA8 data for {}x{}",
                    scene.source,
                    img.rgba8.len(),
                    img.width,
                    img.height
                )));
            }
            for (l, mip) in img.mips.iter().enumerate() {
                let level = l as u32 + 1;
                let (w, h) = ((img.width >> level).max(1), (img.height >> level).max(1));
                if level >= mip_levels(img.width, img.height)
                    || mip.len() as u64 != u64::from(w) * u64::from(h) * 4
                {
                    return Err(VkError::Limit(format!(
                        "{}: image {i} mip level {level} has {} bytes of RGBA8 data for {w}x{h}",
                        scene.source,
                        mip.len()
                    )));
                }
            }
        }
        // A full mip chain adds a third to the largest level.
        let bytes: u64 = scene
            .images
            .iter()
            .map(|i| i.rgba8.len() as u64 / 3 * 4)
            .sum();
        ctx.check_memory(&format!("{}: the scene's textures", scene.source), bytes)?;
        let mut images = Vec::with_capacity(scene.images.len());
        for (i, img) in scene.images.iter().enumerate() {
            images.push(Self::upload_image(ctx, i, img)?);
        }
        let mut samplers = Vec::new();
        let mut sampler_of: HashMap<SamplerState, usize> = HashMap::new();
        let mut textures = Vec::with_capacity(scene.textures.len());
        for (t, tex) in scene.textures.iter().enumerate() {
            let image = tex.image as usize;
            if image >= images.len() {
                return Err(VkError::Limit(format!(
                    "{}: texture {t} refers to image {image} of {}",
                    scene.source,
                    images.len()
                )));
            }
            let sampler = match sampler_of.get(&tex.sampler) {
                Some(&s) => s,
                None => {
                    samplers.push(Sampler::new(ctx, &sampler_create_info(&tex.sampler))?);
                    sampler_of.insert(tex.sampler, samplers.len() - 1);
                    samplers.len() - 1
                }
            };
            textures.push((image, sampler));
        }
        Ok(Self {
            images,
            samplers,
            textures,
        })
    }

    fn upload_image(ctx: &Context, index: usize, img: &super::ImageData) -> VkResult<Image> {
        let format = if img.srgb {
            vk::Format::R8G8B8A8_SRGB
        } else {
            vk::Format::R8G8B8A8_UNORM
        };
        // The file's own levels when it stores them (KTX2), else a full generated chain.
        let levels = if img.mips.is_empty() {
            mip_levels(img.width, img.height)
        } else {
            1 + img.mips.len() as u32
        };
        let extent = vk::Extent2D {
            width: img.width,
            height: img.height,
        };
        let image = Image::new(
            ctx,
            &format!("texture image {index}"),
            extent,
            format,
            vk::ImageUsageFlags::SAMPLED
                | vk::ImageUsageFlags::TRANSFER_SRC
                | vk::ImageUsageFlags::TRANSFER_DST,
            levels,
        )?;
        let stored: Vec<&[u8]> = std::iter::once(img.rgba8.as_slice())
            .chain(img.mips.iter().map(Vec::as_slice))
            .collect();
        let mut staging = Buffer::new(
            ctx,
            "texture staging",
            stored.iter().map(|l| l.len() as u64).sum(),
            vk::BufferUsageFlags::empty(),
            MemoryLocation::CpuToGpu,
        )?;
        staging.write(&stored.concat())?;
        let device = ctx.device();
        let raw = image.raw();
        let none = (
            vk::PipelineStageFlags2::NONE,
            vk::AccessFlags2::NONE,
            vk::ImageLayout::UNDEFINED,
        );
        let transfer_dst = (
            vk::PipelineStageFlags2::ALL_TRANSFER,
            vk::AccessFlags2::TRANSFER_WRITE,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
        );
        let transfer_src = (
            vk::PipelineStageFlags2::ALL_TRANSFER,
            vk::AccessFlags2::TRANSFER_READ,
            vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
        );
        let shader_read = (
            vk::PipelineStageFlags2::ALL_COMMANDS,
            vk::AccessFlags2::SHADER_SAMPLED_READ,
            vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        );
        ctx.run(&format!("upload texture {index}"), |cmd| {
            pipeline_barrier(device, cmd, &[barrier(raw, 0..levels, none, transfer_dst)]);
            let mut offset = 0u64;
            let copies: Vec<vk::BufferImageCopy> = stored
                .iter()
                .enumerate()
                .map(|(level, data)| {
                    let copy = vk::BufferImageCopy::default()
                        .buffer_offset(offset)
                        .image_subresource(vk::ImageSubresourceLayers {
                            aspect_mask: vk::ImageAspectFlags::COLOR,
                            mip_level: level as u32,
                            base_array_layer: 0,
                            layer_count: 1,
                        })
                        .image_extent(vk::Extent3D {
                            width: (img.width >> level).max(1),
                            height: (img.height >> level).max(1),
                            depth: 1,
                        });
                    offset += data.len() as u64;
                    copy
                })
                .collect();
            // SAFETY: the staging buffer holds every stored level back to back, each
            // width*height*4 bytes (checked in `upload`); all levels are TRANSFER_DST.
            unsafe {
                device.cmd_copy_buffer_to_image(
                    cmd,
                    staging.raw(),
                    raw,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &copies,
                )
            };
            if stored.len() > 1 {
                pipeline_barrier(
                    device,
                    cmd,
                    &[barrier(raw, 0..levels, transfer_dst, shader_read)],
                );
                return Ok(());
            }
            let size = |l: u32| vk::Offset3D {
                x: (img.width >> l).max(1) as i32,
                y: (img.height >> l).max(1) as i32,
                z: 1,
            };
            for level in 1..levels {
                pipeline_barrier(
                    device,
                    cmd,
                    &[barrier(raw, level - 1..level, transfer_dst, transfer_src)],
                );
                let layers = |mip_level| vk::ImageSubresourceLayers {
                    aspect_mask: vk::ImageAspectFlags::COLOR,
                    mip_level,
                    base_array_layer: 0,
                    layer_count: 1,
                };
                let blit = vk::ImageBlit::default()
                    .src_subresource(layers(level - 1))
                    .src_offsets([vk::Offset3D::default(), size(level - 1)])
                    .dst_subresource(layers(level))
                    .dst_offsets([vk::Offset3D::default(), size(level)]);
                // SAFETY: level-1 is TRANSFER_SRC, level is TRANSFER_DST; R8G8B8A8 UNORM and
                // SRGB must support linear blits on every Vulkan device.
                unsafe {
                    device.cmd_blit_image(
                        cmd,
                        raw,
                        vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                        raw,
                        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                        &[blit],
                        vk::Filter::LINEAR,
                    )
                };
                pipeline_barrier(
                    device,
                    cmd,
                    &[barrier(raw, level - 1..level, transfer_src, shader_read)],
                );
            }
            pipeline_barrier(
                device,
                cmd,
                &[barrier(raw, levels - 1..levels, transfer_dst, shader_read)],
            );
            Ok(())
        })?;
        Ok(image)
    }

    /// `(view, sampler)` per [`Scene::textures`] entry, in texture-index order: the contents
    /// of a bindless `sampler2D textures[]` array (combined image samplers).
    pub fn descriptors(&self) -> Vec<(vk::ImageView, vk::Sampler)> {
        self.textures
            .iter()
            .map(|&(i, s)| (self.images[i].view(), self.samplers[s].raw()))
            .collect()
    }

    /// The uploaded images, parallel to [`Scene::images`].
    pub fn images(&self) -> &[Image] {
        &self.images
    }

    /// Number of distinct samplers created.
    pub fn sampler_count(&self) -> usize {
        self.samplers.len()
    }

    /// Number of textures (descriptor entries).
    pub fn len(&self) -> usize {
        self.textures.len()
    }

    /// Whether the scene has no textures.
    pub fn is_empty(&self) -> bool {
        self.textures.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mip_chain_lengths() {
        assert_eq!(mip_levels(1, 1), 1);
        assert_eq!(mip_levels(2, 1), 2);
        assert_eq!(mip_levels(256, 256), 9);
        assert_eq!(mip_levels(300, 17), 9);
        assert_eq!(mip_levels(16384, 1), 15);
    }

    #[test]
    fn sampler_without_mipmaps_clamps_lod() {
        let s = SamplerState {
            mipmaps: false,
            ..Default::default()
        };
        let info = sampler_create_info(&s);
        assert_eq!(info.max_lod, 0.25);
        assert_eq!(info.mipmap_mode, vk::SamplerMipmapMode::NEAREST);
        let t = sampler_create_info(&SamplerState::default());
        assert_eq!(t.max_lod, vk::LOD_CLAMP_NONE);
        assert_eq!(t.mipmap_mode, vk::SamplerMipmapMode::LINEAR);
        assert_eq!(t.anisotropy_enable, vk::FALSE);
    }
}
