//! Uploads a scene's images as sampled Vulkan images with full mip chains, and creates one
//! sampler per distinct glTF sampler state, for a bindless `sampler2D textures[]` array.
//! Images that keep their KTX2 file upload as BC7 (or ASTC 4x4) blocks with the file's levels
//! where the device samples that format, else as RGBA8 (`--texture-format`, whose `auto`
//! drops the files first where RGBA8 measured faster: [`Scene::drop_ktx2_files`]).

use std::collections::HashMap;

use ash::vk;

use super::error::SceneError;
use super::ktx2::{self, BlockTarget};
use super::types::{ImageData, Sampler as SamplerState, Scene, Wrap};
use crate::vk::{Buffer, Context, Image, MemoryLocation, Sampler, VkError, VkResult};

/// How KTX2 (KHR_texture_basisu) textures reach the GPU (`--texture-format`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum TextureFormat {
    /// The faster of [`Self::Block`] and [`Self::Rgba8`] on the device, as measured once per
    /// device and driver (`rqr::device_select::autotune`). The loader keeps the KTX2 files, so that the
    /// choice can be made once the device is open ([`Scene::drop_ktx2_files`] applies
    /// RGBA8); uploaded as is, such a scene's KTX2 textures go up as [`Self::Block`].
    #[default]
    Auto,
    /// RGBA8, as transcoded at load (four times the memory of BC7; faster to sample on CPU
    /// devices, which decode block formats in software).
    Rgba8,
    /// Transcoded to the block format the device samples (BC7, else ASTC 4x4) with the
    /// file's mip levels; RGBA8 where the device samples neither.
    Block,
}

impl TextureFormat {
    /// The `--texture-format` name.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Auto => "auto",
            Self::Rgba8 => "rgba8",
            Self::Block => "block",
        }
    }
}

/// The block format KTX2 textures transcode to on a device with `features`, if it samples
/// one: BC7 first (desktop GPUs, lavapipe), else ASTC 4x4 (mobile GPUs).
pub(crate) fn block_target_of(features: &crate::vk::DeviceInfo) -> Option<BlockTarget> {
    if features.bc7_textures {
        Some(BlockTarget::Bc7)
    } else if features.astc_4x4_textures {
        Some(BlockTarget::Astc4x4)
    } else {
        None
    }
}

/// [`block_target_of`] the device of `ctx`.
pub(crate) fn block_target(ctx: &Context) -> Option<BlockTarget> {
    block_target_of(ctx.info())
}

/// The name of the block format KTX2 textures upload as on `device` (`BC7`, `ASTC 4x4`),
/// `None` where it samples neither.
pub fn block_format_name(device: &crate::vk::DeviceInfo) -> Option<&'static str> {
    block_target_of(device).map(BlockTarget::name)
}

/// The Vulkan format of `target` blocks, sRGB for colour images.
pub(crate) fn block_format(target: BlockTarget, srgb: bool) -> vk::Format {
    match (target, srgb) {
        (BlockTarget::Bc7, true) => vk::Format::BC7_SRGB_BLOCK,
        (BlockTarget::Bc7, false) => vk::Format::BC7_UNORM_BLOCK,
        (BlockTarget::Astc4x4, true) => vk::Format::ASTC_4X4_SRGB_BLOCK,
        (BlockTarget::Astc4x4, false) => vk::Format::ASTC_4X4_UNORM_BLOCK,
    }
}

/// What one image uploads.
enum Texels<'a> {
    /// The scene's RGBA8 levels (level 0 alone: the upload generates the chain).
    Rgba8(Vec<&'a [u8]>),
    /// Levels transcoded from the image's KTX2 file to a block format.
    Blocks(vk::Format, BlockLevels),
}

impl Texels<'_> {
    fn levels(&self) -> Vec<&[u8]> {
        match self {
            Self::Rgba8(levels) => levels.clone(),
            Self::Blocks(_, levels) => levels.iter().map(Vec::as_slice).collect(),
        }
    }

    /// Device memory the image takes: the stored levels, plus a third of level 0 for a
    /// chain the upload generates.
    fn device_bytes(&self) -> u64 {
        match self {
            Self::Rgba8(levels) if levels.len() == 1 => levels[0].len() as u64 / 3 * 4,
            _ => self.levels().iter().map(|l| l.len() as u64).sum(),
        }
    }
}

/// Levels 0.. of one image in 4x4 blocks.
type BlockLevels = Vec<Vec<u8>>;

/// Whether image `img` uploads as `target` blocks: it comes from a KTX2 file that stores its
/// mip chain (block formats cannot be blitted, so a single-level file of a larger image keeps
/// RGBA8 and a generated chain).
fn uses_blocks(img: &ImageData, target: Option<BlockTarget>) -> bool {
    target.is_some()
        && img.ktx2.is_some()
        && (!img.mips.is_empty() || mip_levels(img.width, img.height) == 1)
}

/// Transcodes the images that [`uses_blocks`] to `target` (in parallel: the transcoder is
/// single-threaded), naming the file and image on failure; `None` for the others.
fn transcode_images(
    scene: &Scene,
    target: Option<BlockTarget>,
) -> Result<Vec<Option<(vk::Format, BlockLevels)>>, SceneError> {
    let Some(block) = target else {
        return Ok(scene.images.iter().map(|_| None).collect());
    };
    let jobs: Vec<usize> = (0..scene.images.len())
        .filter(|&i| uses_blocks(&scene.images[i], target))
        .collect();
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(jobs.len())
        .max(1);
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results: Vec<(usize, Result<BlockLevels, String>)> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|_| {
                s.spawn(|| {
                    let mut out = Vec::new();
                    while let Some(&i) =
                        jobs.get(next.fetch_add(1, std::sync::atomic::Ordering::Relaxed))
                    {
                        let img = &scene.images[i];
                        let levels = 1 + img.mips.len() as u32;
                        let file = img.ktx2.as_deref().unwrap_or_default();
                        let blocks =
                            ktx2::transcode_blocks(file, block, (img.width, img.height), levels);
                        out.push((i, blocks));
                    }
                    out
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| {
                h.join()
                    .unwrap_or_else(|_| vec![(usize::MAX, Err("transcoder panicked".into()))])
            })
            .collect()
    });
    let mut out: Vec<Option<(vk::Format, BlockLevels)>> =
        scene.images.iter().map(|_| None).collect();
    let mut first_error: Option<(usize, String)> = None;
    for (i, result) in results {
        match result {
            Ok(levels) => out[i] = Some((block_format(block, scene.images[i].srgb), levels)),
            Err(e) if first_error.as_ref().is_none_or(|(j, _)| i < *j) => {
                first_error = Some((i, e))
            }
            Err(_) => {}
        }
    }
    match first_error {
        Some((i, e)) => Err(SceneError::element(
            &scene.source,
            if i == usize::MAX {
                "image ?".to_string()
            } else {
                format!("image {i}")
            },
            format!("{e} (`--texture-format rgba8` uploads the RGBA8 decoded at load)"),
        )),
        None => Ok(out),
    }
}

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

/// An image memory barrier over mip `levels` of `image` from one (stage, access, layout) to another.
pub(crate) fn barrier(
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
pub(crate) fn pipeline_barrier(
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
    /// `maxImageDimension2D`, and with a [`SceneError`] for one whose pixel data does not match
    /// its size, whose KTX2 levels do not transcode, or a texture naming a missing image.
    pub fn upload(ctx: &Context, scene: &Scene) -> crate::Result<Self> {
        let limit = ctx.info().max_image_dimension_2d;
        for (i, img) in scene.images.iter().enumerate() {
            if img.width > limit || img.height > limit {
                return Err(VkError::Limit {
                    what: format!(
                        "{}: image {i} is {}x{}, larger than this device's maxImageDimension2D ({limit})",
                        scene.source, img.width, img.height
                    ),
                    needed: img.width.max(img.height).into(),
                    available: limit.into(),
                }
                .into());
            }
            if img.width == 0
                || img.height == 0
                || img.rgba8.len() as u64 != u64::from(img.width) * u64::from(img.height) * 4
            {
                return Err(SceneError::element(
                    &scene.source,
                    format!("image {i}"),
                    format!(
                        "{} bytes of RGBA8 data for {}x{}",
                        img.rgba8.len(),
                        img.width,
                        img.height
                    ),
                )
                .into());
            }
            for (l, mip) in img.mips.iter().enumerate() {
                let level = l as u32 + 1;
                let (w, h) = ((img.width >> level).max(1), (img.height >> level).max(1));
                if level >= mip_levels(img.width, img.height)
                    || mip.len() as u64 != u64::from(w) * u64::from(h) * 4
                {
                    return Err(SceneError::element(
                        &scene.source,
                        format!("image {i} mip level {level}"),
                        format!("{} bytes of RGBA8 data for {w}x{h}", mip.len()),
                    )
                    .into());
                }
            }
        }
        let target = block_target(ctx);
        let texels: Vec<Texels> = transcode_images(scene, target)?
            .into_iter()
            .zip(&scene.images)
            .map(|(blocks, img)| match blocks {
                Some((format, levels)) => Texels::Blocks(format, levels),
                None => Texels::Rgba8(
                    std::iter::once(img.rgba8.as_slice())
                        .chain(img.mips.iter().map(Vec::as_slice))
                        .collect(),
                ),
            })
            .collect();
        let bytes: u64 = texels.iter().map(Texels::device_bytes).sum();
        ctx.check_memory(&format!("{}: the scene's textures", scene.source), bytes)?;
        let compressed = texels
            .iter()
            .filter(|t| matches!(t, Texels::Blocks(..)))
            .count();
        if let (Some(target), true) = (target, compressed > 0) {
            log::info!(
                "{}: {compressed} of {} images uploaded as {} blocks ({bytes} bytes of textures)",
                scene.source,
                scene.images.len(),
                target.name()
            );
        }
        let mut images = Vec::with_capacity(scene.images.len());
        for (i, (img, texels)) in scene.images.iter().zip(&texels).enumerate() {
            let label = format!("texture {i}");
            images.push(upload_image(ctx, &label, img, texels)?);
        }
        let mut samplers = Vec::new();
        let mut sampler_of: HashMap<SamplerState, usize> = HashMap::new();
        let mut textures = Vec::with_capacity(scene.textures.len());
        for (t, tex) in scene.textures.iter().enumerate() {
            let image = tex.image as usize;
            if image >= images.len() {
                return Err(SceneError::element(
                    &scene.source,
                    format!("texture {t}"),
                    format!("refers to image {image} of {}", images.len()),
                )
                .into());
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

/// Uploads one image (`label` names it in errors and debug names): its stored levels, or
/// level 0 and a chain generated with linear blits; left in `SHADER_READ_ONLY_OPTIMAL`.
fn upload_image(ctx: &Context, label: &str, img: &ImageData, texels: &Texels) -> VkResult<Image> {
    let format = match texels {
        Texels::Blocks(format, _) => *format,
        Texels::Rgba8(_) if img.srgb => vk::Format::R8G8B8A8_SRGB,
        Texels::Rgba8(_) => vk::Format::R8G8B8A8_UNORM,
    };
    let stored = texels.levels();
    // The file's own levels when it stores them (KTX2), else a full generated chain.
    let levels = if stored.len() == 1 {
        mip_levels(img.width, img.height)
    } else {
        stored.len() as u32
    };
    let extent = vk::Extent2D {
        width: img.width,
        height: img.height,
    };
    let image = Image::new(
        ctx,
        &format!("{label} image"),
        extent,
        format,
        // TRANSFER_SRC: the chain's blits, and readback (block formats are checked for
        // it by the probe).
        vk::ImageUsageFlags::SAMPLED
            | vk::ImageUsageFlags::TRANSFER_SRC
            | vk::ImageUsageFlags::TRANSFER_DST,
        levels,
    )?;
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
    ctx.run(&format!("upload {label}"), |cmd| {
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
        // SAFETY: the staging buffer holds every stored level back to back: RGBA8 levels
        // of width*height*4 bytes (checked in `upload`), or whole 16-byte blocks per
        // level (checked by the transcode), so every offset is a multiple of the block
        // size; extents are the levels' texel sizes, which Vulkan allows for a partial
        // last block; all levels are TRANSFER_DST.
        unsafe {
            device.cmd_copy_buffer_to_image(
                cmd,
                staging.raw(),
                raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &copies,
            )
        };
        // Stored levels (KTX2, RGBA8 or blocks) are complete; a block-compressed image has
        // more than one (`uses_blocks`) or is a single 1x1..4x4 level.
        if stored.len() > 1 || matches!(texels, Texels::Blocks(..)) {
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

/// Uploads a `width` x `height` image of `format` whose every mip level is given (RGBA8 or
/// 4x4 blocks, level `l` of `max(1, size >> l)` texels), for measurements that sample a
/// synthetic texture; left in `SHADER_READ_ONLY_OPTIMAL`.
pub(crate) fn upload_levels(
    ctx: &Context,
    label: &str,
    (width, height): (u32, u32),
    format: vk::Format,
    levels: &[Vec<u8>],
) -> VkResult<Image> {
    let img = ImageData {
        width,
        height,
        rgba8: Vec::new(),
        mips: Vec::new(),
        srgb: false,
        ktx2: None,
    };
    let levels: Vec<&[u8]> = levels.iter().map(Vec::as_slice).collect();
    let texels = match format {
        vk::Format::R8G8B8A8_UNORM | vk::Format::R8G8B8A8_SRGB => Texels::Rgba8(levels),
        _ => Texels::Blocks(format, levels.iter().map(|l| l.to_vec()).collect()),
    };
    upload_image(ctx, label, &img, &texels)
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
