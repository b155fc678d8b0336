//! An environment map on the GPU: the map with its mip chain, and the textures the Whitted
//! model's split-sum lighting reads, computed at load by the compute passes of
//! `shaders/environment/` (one submission).

use std::time::Instant;

use ash::vk;

use super::EnvironmentMap;
use crate::interface::bindings;
use crate::interface::environment::{
    EnvPreparePush, BINDING_ENV_SOURCE, ENV_BRDF_SIZE, ENV_IRRADIANCE_WIDTH, ENV_SPECULAR_LEVELS,
    ENV_SPECULAR_WIDTH,
};
use crate::interface::push_bytes;
use crate::scene::textures::{barrier, pipeline_barrier};
use crate::vk::{
    memory_barrier, Binding, Buffer, ComputePipeline, Context, Image, MemoryLocation, Sampler,
    VkResult,
};

/// GGX samples per texel of the prefiltered levels (filtered importance sampling).
const SPECULAR_SAMPLES: u32 = 256;
/// Samples per texel of the BRDF table.
const BRDF_SAMPLES: u32 = 1024;
/// The irradiance pass integrates over the first source level at most this many rows high.
const IRRADIANCE_SOURCE_ROWS: u32 = 32;

/// The four textures of an environment (`ENV_TEX_*` order) and how long preparing took.
pub struct GpuEnvironment {
    radiance: Image,
    specular: Image,
    irradiance: Image,
    brdf: Image,
    map_sampler: Sampler,
    table_sampler: Sampler,
    /// Width of the map.
    pub width: u32,
    /// Milliseconds of preparation (host mips, upload and the GPU passes), wall time.
    pub prepare_ms: f64,
}

/// Which prepared texture to read back ([`GpuEnvironment::read`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EnvTexture {
    /// The map and its area-weighted mips.
    Radiance,
    /// The GGX-prefiltered levels.
    Specular,
    /// Irradiance / π.
    Irradiance,
    /// The split-sum BRDF table.
    Brdf,
}

fn level_extent(width: u32, height: u32, level: u32) -> (u32, u32) {
    ((width >> level).max(1), (height >> level).max(1))
}

impl GpuEnvironment {
    /// Uploads `map` and prepares its lighting textures. The device memory it needs is
    /// checked first.
    pub fn prepare(ctx: &Context, map: &EnvironmentMap) -> VkResult<Self> {
        let start = Instant::now();
        let spec_w = ENV_SPECULAR_WIDTH;
        let irr_w = ENV_IRRADIANCE_WIDTH;
        let out_texels: u64 = (0..ENV_SPECULAR_LEVELS)
            .map(|l| {
                let (w, h) = level_extent(spec_w, spec_w / 2, l);
                u64::from(w * h)
            })
            .sum::<u64>()
            + u64::from(irr_w * irr_w / 2)
            + u64::from(ENV_BRDF_SIZE * ENV_BRDF_SIZE);
        // The map with its mips twice (image and staging), the prepared texels twice.
        ctx.check_memory(
            "the environment map",
            2 * map.device_bytes() + 2 * out_texels * 16,
        )?;
        let chain = map.mip_chain();
        let levels = chain.len() as u32;
        let usage = vk::ImageUsageFlags::SAMPLED
            | vk::ImageUsageFlags::TRANSFER_DST
            | vk::ImageUsageFlags::TRANSFER_SRC;
        let format = vk::Format::R32G32B32A32_SFLOAT;
        let image = |name: &str, w: u32, h: u32, levels: u32| {
            Image::new(
                ctx,
                name,
                vk::Extent2D {
                    width: w,
                    height: h,
                },
                format,
                usage,
                levels,
            )
        };
        let radiance = image("environment map", map.width, map.height, levels)?;
        let specular = image(
            "environment specular",
            spec_w,
            spec_w / 2,
            ENV_SPECULAR_LEVELS,
        )?;
        let irradiance = image("environment irradiance", irr_w, irr_w / 2, 1)?;
        let brdf = image("environment BRDF table", ENV_BRDF_SIZE, ENV_BRDF_SIZE, 1)?;
        let map_sampler = Sampler::new(
            ctx,
            &vk::SamplerCreateInfo::default()
                .mag_filter(vk::Filter::LINEAR)
                .min_filter(vk::Filter::LINEAR)
                .mipmap_mode(vk::SamplerMipmapMode::LINEAR)
                .address_mode_u(vk::SamplerAddressMode::REPEAT)
                .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                .min_lod(0.0)
                .max_lod(vk::LOD_CLAMP_NONE),
        )?;
        let table_sampler = Sampler::new(
            ctx,
            &vk::SamplerCreateInfo::default()
                .mag_filter(vk::Filter::LINEAR)
                .min_filter(vk::Filter::LINEAR)
                .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
                .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                .min_lod(0.0)
                .max_lod(0.25),
        )?;

        let texels: Vec<[f32; 4]> = chain.concat();
        let mut staging = Buffer::new(
            ctx,
            "environment staging",
            texels.len() as u64 * 16,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::CpuToGpu,
        )?;
        staging.write(bytemuck::cast_slice(&texels))?;
        let out = Buffer::new(
            ctx,
            "environment prepared texels",
            out_texels * 16,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::GpuOnly,
        )?;

        let source_binding = bindings(&[(BINDING_ENV_SOURCE, Binding::SampledImages(1))]);
        let push_size = std::mem::size_of::<EnvPreparePush>() as u32;
        let specular_pass = ComputePipeline::cached(
            ctx,
            "environment specular",
            crate::shaders::ENV_SPECULAR_COMP,
            &source_binding,
            push_size,
        )?;
        let irradiance_pass = ComputePipeline::cached(
            ctx,
            "environment irradiance",
            crate::shaders::ENV_IRRADIANCE_COMP,
            &source_binding,
            push_size,
        )?;
        let brdf_pass = ComputePipeline::cached(
            ctx,
            "environment BRDF table",
            crate::shaders::ENV_BRDF_COMP,
            &bindings(&[]),
            push_size,
        )?;
        let set = specular_pass.allocate_set()?;
        set.sampled_images(BINDING_ENV_SOURCE, &[(radiance.view(), map_sampler.raw())]);
        let irradiance_set = irradiance_pass.allocate_set()?;
        irradiance_set.sampled_images(BINDING_ENV_SOURCE, &[(radiance.view(), map_sampler.raw())]);

        let irradiance_level = (0..levels)
            .find(|&l| (map.height >> l).max(1) <= IRRADIANCE_SOURCE_ROWS)
            .unwrap_or(levels - 1);
        let device = ctx.device();
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
        let shader_read = (
            vk::PipelineStageFlags2::ALL_COMMANDS,
            vk::AccessFlags2::SHADER_SAMPLED_READ,
            vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        );
        let copies_of = |image: &Image, levels: u32, first_offset: u64| {
            let mut offset = first_offset;
            (0..levels)
                .map(|level| {
                    let (w, h) = level_extent(image.extent.width, image.extent.height, level);
                    let copy = vk::BufferImageCopy::default()
                        .buffer_offset(offset)
                        .image_subresource(vk::ImageSubresourceLayers {
                            aspect_mask: vk::ImageAspectFlags::COLOR,
                            mip_level: level,
                            base_array_layer: 0,
                            layer_count: 1,
                        })
                        .image_extent(vk::Extent3D {
                            width: w,
                            height: h,
                            depth: 1,
                        });
                    offset += u64::from(w * h) * 16;
                    copy
                })
                .collect::<Vec<_>>()
        };
        ctx.run("environment preparation", |cmd| {
            pipeline_barrier(
                device,
                cmd,
                &[
                    barrier(radiance.raw(), 0..levels, none, transfer_dst),
                    barrier(specular.raw(), 0..ENV_SPECULAR_LEVELS, none, transfer_dst),
                    barrier(irradiance.raw(), 0..1, none, transfer_dst),
                    barrier(brdf.raw(), 0..1, none, transfer_dst),
                ],
            );
            let copies = copies_of(&radiance, levels, 0);
            // SAFETY: the staging buffer holds every level back to back, 16 bytes a texel, at
            // the offsets `copies_of` computes from the same extents; the image is TRANSFER_DST.
            unsafe {
                device.cmd_copy_buffer_to_image(
                    cmd,
                    staging.raw(),
                    radiance.raw(),
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &copies,
                )
            };
            pipeline_barrier(
                device,
                cmd,
                &[barrier(
                    radiance.raw(),
                    0..levels,
                    transfer_dst,
                    shader_read,
                )],
            );
            let mut offset = 0u64;
            let mut push = EnvPreparePush {
                source_width: map.width,
                source_levels: levels,
                samples: SPECULAR_SAMPLES,
                ..Default::default()
            };
            for level in 0..ENV_SPECULAR_LEVELS {
                let (w, h) = level_extent(spec_w, spec_w / 2, level);
                push.texels_out = out.address() + offset;
                push.width = w;
                push.height = h;
                push.roughness = level as f32 / (ENV_SPECULAR_LEVELS - 1) as f32;
                specular_pass.dispatch(
                    cmd,
                    Some(&set),
                    push_bytes(&push),
                    [w.div_ceil(8), h.div_ceil(8), 1],
                );
                offset += u64::from(w * h) * 16;
            }
            let irradiance_offset = offset;
            push.texels_out = out.address() + offset;
            push.width = irr_w;
            push.height = irr_w / 2;
            push.source_level = irradiance_level;
            irradiance_pass.dispatch(
                cmd,
                Some(&irradiance_set),
                push_bytes(&push),
                [irr_w.div_ceil(8), (irr_w / 2).div_ceil(8), 1],
            );
            offset += u64::from(irr_w * irr_w / 2) * 16;
            let brdf_offset = offset;
            push.texels_out = out.address() + offset;
            push.width = ENV_BRDF_SIZE;
            push.height = ENV_BRDF_SIZE;
            push.samples = BRDF_SAMPLES;
            brdf_pass.dispatch(
                cmd,
                None,
                push_bytes(&push),
                [ENV_BRDF_SIZE.div_ceil(8), ENV_BRDF_SIZE.div_ceil(8), 1],
            );
            memory_barrier(device, cmd);
            for (image, levels, at) in [
                (&specular, ENV_SPECULAR_LEVELS, 0),
                (&irradiance, 1, irradiance_offset),
                (&brdf, 1, brdf_offset),
            ] {
                let copies = copies_of(image, levels, at);
                // SAFETY: `out` holds each texture's levels back to back from `at`, written
                // by the passes above with the same extents; the barrier made them visible.
                unsafe {
                    device.cmd_copy_buffer_to_image(
                        cmd,
                        out.raw(),
                        image.raw(),
                        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                        &copies,
                    )
                };
            }
            pipeline_barrier(
                device,
                cmd,
                &[
                    barrier(
                        specular.raw(),
                        0..ENV_SPECULAR_LEVELS,
                        transfer_dst,
                        shader_read,
                    ),
                    barrier(irradiance.raw(), 0..1, transfer_dst, shader_read),
                    barrier(brdf.raw(), 0..1, transfer_dst, shader_read),
                ],
            );
            Ok(())
        })?;
        Ok(Self {
            radiance,
            specular,
            irradiance,
            brdf,
            map_sampler,
            table_sampler,
            width: map.width,
            prepare_ms: start.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// The bindless texture entries, in `ENV_TEX_*` order.
    pub fn descriptors(&self) -> [(vk::ImageView, vk::Sampler); 4] {
        let map = self.map_sampler.raw();
        [
            (self.radiance.view(), map),
            (self.specular.view(), map),
            (self.irradiance.view(), map),
            (self.brdf.view(), self.table_sampler.raw()),
        ]
    }

    /// Reads one level of a prepared texture back (tests and tools): its size and RGBA texels.
    pub fn read(
        &self,
        ctx: &Context,
        which: EnvTexture,
        level: u32,
    ) -> VkResult<(u32, u32, Vec<[f32; 4]>)> {
        let image = match which {
            EnvTexture::Radiance => &self.radiance,
            EnvTexture::Specular => &self.specular,
            EnvTexture::Irradiance => &self.irradiance,
            EnvTexture::Brdf => &self.brdf,
        };
        let (w, h) = level_extent(image.extent.width, image.extent.height, level);
        let count = (w * h) as usize;
        let staging = Buffer::new(
            ctx,
            "environment readback",
            count as u64 * 16,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::GpuToCpu,
        )?;
        let shader_read = (
            vk::PipelineStageFlags2::ALL_COMMANDS,
            vk::AccessFlags2::SHADER_SAMPLED_READ,
            vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        );
        let transfer_src = (
            vk::PipelineStageFlags2::ALL_TRANSFER,
            vk::AccessFlags2::TRANSFER_READ,
            vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
        );
        let device = ctx.device();
        ctx.run("environment readback", |cmd| {
            let levels = level..level + 1;
            pipeline_barrier(
                device,
                cmd,
                &[barrier(
                    image.raw(),
                    levels.clone(),
                    shader_read,
                    transfer_src,
                )],
            );
            let region = vk::BufferImageCopy::default()
                .image_subresource(vk::ImageSubresourceLayers {
                    aspect_mask: vk::ImageAspectFlags::COLOR,
                    mip_level: level,
                    base_array_layer: 0,
                    layer_count: 1,
                })
                .image_extent(vk::Extent3D {
                    width: w,
                    height: h,
                    depth: 1,
                });
            // SAFETY: the level is TRANSFER_SRC (barrier above), the image was made with
            // TRANSFER_SRC usage, and the staging buffer holds the whole level.
            unsafe {
                device.cmd_copy_image_to_buffer(
                    cmd,
                    image.raw(),
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    staging.raw(),
                    &[region],
                )
            };
            pipeline_barrier(
                device,
                cmd,
                &[barrier(image.raw(), levels, transfer_src, shader_read)],
            );
            crate::vk::host_read_barrier(device, cmd);
            Ok(())
        })?;
        let texels = staging.mapped_read(0, count).ok_or_else(|| {
            crate::vk::VkError::Limit("readback buffer is not host-visible".into())
        })?;
        Ok((w, h, texels))
    }
}
