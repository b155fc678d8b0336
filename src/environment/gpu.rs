//! An environment map on the GPU: the map with its mip chain, the textures the Whitted
//! model's split-sum lighting reads, and the importance-sampling table, all computed at load by
//! the compute passes of `shaders/environment/` in one submission. The lighting textures can
//! come from an on-disk cache keyed by the map's content and the preparation's settings; the
//! sampling table is built on the GPU every time (`env_sampling_rows.comp`,
//! `env_sampling_marginal.comp`; `super::sampling` is its host reference).

use std::path::{Path, PathBuf};
use std::time::Instant;

use ash::vk;

use super::EnvironmentMap;
use crate::interface::bindings;
use crate::interface::environment::{
    EnvPreparePush, BINDING_ENV_SOURCE, ENV_BRDF_SIZE, ENV_IRRADIANCE_WIDTH, ENV_SHEEN_WIDTH,
    ENV_SPECULAR_LEVELS, ENV_SPECULAR_WIDTH, ENV_TEXTURES,
};
use crate::interface::push_bytes;
use crate::scene::textures::{barrier, pipeline_barrier};
use crate::vk::{
    memory_barrier, Binding, Buffer, ComputePipeline, Context, DescriptorSet, Image,
    MemoryLocation, Sampler, VkError, VkResult,
};

/// GGX samples per texel of the prefiltered levels (filtered importance sampling).
const SPECULAR_SAMPLES: u32 = 256;
/// Samples per texel of the Charlie-prefiltered sheen levels (uniform over the hemisphere,
/// filtered importance sampling; the Sample Viewer takes 64 Charlie samples).
const SHEEN_SAMPLES: u32 = 128;
/// Samples per texel of the BRDF table (GGX and sheen albedo each).
const BRDF_SAMPLES: u32 = 1024;
/// The irradiance pass integrates over the first source level at most this many rows high.
const IRRADIANCE_SOURCE_ROWS: u32 = 32;
/// Version of the cache files' contents: bump when a preparation pass changes its output.
const CACHE_VERSION: u32 = 3;

/// The textures of an environment (`ENV_TEX_*` order) and how long preparing took.
pub struct GpuEnvironment {
    radiance: Image,
    specular: Image,
    irradiance: Image,
    brdf: Image,
    sampling: Image,
    sheen: Image,
    map_sampler: Sampler,
    table_sampler: Sampler,
    /// Width of the map.
    pub width: u32,
    /// Where the preparation's time went.
    pub timing: PrepareTiming,
}

/// Wall-clock milliseconds of [`GpuEnvironment::prepare_cached`]'s stages.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct PrepareTiming {
    /// The whole preparation.
    pub total_ms: f64,
    /// The map's mip chain on the host.
    pub mips_ms: f64,
    /// The upload and the GPU passes (from the cache: the upload of their results).
    pub gpu_ms: f64,
    /// Whether the prepared textures came from the on-disk cache.
    pub cached: bool,
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
    /// The split-sum BRDF table (and the sheen albedo in `.b`).
    Brdf,
    /// The importance-sampling table (R32F: each texel's value in the first channel, the
    /// others 0).
    Sampling,
    /// The Charlie-prefiltered sheen levels.
    Sheen,
}

fn level_extent(width: u32, height: u32, level: u32) -> (u32, u32) {
    ((width >> level).max(1), (height >> level).max(1))
}

/// Where each prepared texture starts in the passes' output, in texels, and their total.
struct Layout {
    irradiance: u64,
    brdf: u64,
    sheen: u64,
    total: u64,
}

/// Texels of a `width` × `width / 2` texture with ENV_SPECULAR_LEVELS levels.
fn levels_texels(width: u32) -> u64 {
    (0..ENV_SPECULAR_LEVELS)
        .map(|l| {
            let (w, h) = level_extent(width, width / 2, l);
            u64::from(w * h)
        })
        .sum()
}

fn layout() -> Layout {
    let specular = levels_texels(ENV_SPECULAR_WIDTH);
    let irradiance = u64::from(ENV_IRRADIANCE_WIDTH * ENV_IRRADIANCE_WIDTH / 2);
    let brdf = u64::from(ENV_BRDF_SIZE * ENV_BRDF_SIZE);
    let sheen = specular + irradiance + brdf;
    Layout {
        irradiance: specular,
        brdf: specular + irradiance,
        sheen,
        total: sheen + levels_texels(ENV_SHEEN_WIDTH),
    }
}

/// The on-disk cache of prepared textures: `environment/` in [`crate::cache::cache_dir`]
/// (`RQR_CACHE_DIR`, else the user's cache folder).
pub fn default_cache_dir() -> Option<PathBuf> {
    crate::cache::cache_dir().map(|d| d.join("environment"))
}

/// FNV-1a over the map and every setting that shapes the prepared textures.
fn cache_key(map: &EnvironmentMap) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes {
            h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
    };
    for v in [
        CACHE_VERSION,
        map.width,
        map.height,
        SPECULAR_SAMPLES,
        SHEEN_SAMPLES,
        BRDF_SAMPLES,
        IRRADIANCE_SOURCE_ROWS,
        ENV_SPECULAR_WIDTH,
        ENV_SPECULAR_LEVELS,
        ENV_IRRADIANCE_WIDTH,
        ENV_BRDF_SIZE,
        ENV_SHEEN_WIDTH,
    ] {
        eat(&v.to_le_bytes());
    }
    eat(bytemuck::cast_slice(&map.texels));
    h
}

/// Reads a cache file (the key, then `texels` RGBA32F texels); `None` when absent, and
/// with a warning when short or for another key: the environment is prepared again and the
/// file overwritten.
fn read_cache(path: &Path, key: u64, texels: u64) -> Option<Vec<[f32; 4]>> {
    let bytes = std::fs::read(path).ok()?;
    let valid = bytes.len() as u64 == 8 + texels * 16
        && bytes[..8] == key.to_le_bytes()
        && bytes[8..]
            .chunks_exact(4)
            .all(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]).is_finite());
    if !valid {
        log::warn!(
            "{}: corrupt environment cache file, preparing again",
            path.display()
        );
        return None;
    }
    Some(bytemuck::pod_collect_to_vec(&bytes[8..]))
}

/// Writes a cache file atomically (a temporary name in the same folder, then a rename).
fn write_cache(path: &Path, key: u64, texels: &[[f32; 4]]) -> std::io::Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)?;
    }
    let tmp = path.with_extension(format!("tmp{}", std::process::id()));
    let mut bytes = key.to_le_bytes().to_vec();
    bytes.extend_from_slice(bytemuck::cast_slice(texels));
    std::fs::write(&tmp, &bytes)?;
    std::fs::rename(&tmp, path)
}

const NONE: (vk::PipelineStageFlags2, vk::AccessFlags2, vk::ImageLayout) = (
    vk::PipelineStageFlags2::NONE,
    vk::AccessFlags2::NONE,
    vk::ImageLayout::UNDEFINED,
);
const TRANSFER_DST: (vk::PipelineStageFlags2, vk::AccessFlags2, vk::ImageLayout) = (
    vk::PipelineStageFlags2::ALL_TRANSFER,
    vk::AccessFlags2::TRANSFER_WRITE,
    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
);
const TRANSFER_SRC: (vk::PipelineStageFlags2, vk::AccessFlags2, vk::ImageLayout) = (
    vk::PipelineStageFlags2::ALL_TRANSFER,
    vk::AccessFlags2::TRANSFER_READ,
    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
);
const SHADER_READ: (vk::PipelineStageFlags2, vk::AccessFlags2, vk::ImageLayout) = (
    vk::PipelineStageFlags2::ALL_COMMANDS,
    vk::AccessFlags2::SHADER_SAMPLED_READ,
    vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
);

/// A copy between a buffer at byte `offset` and mip `level` (`width` × `height`) of a colour image.
fn level_region(offset: u64, level: u32, width: u32, height: u32) -> vk::BufferImageCopy {
    vk::BufferImageCopy::default()
        .buffer_offset(offset)
        .image_subresource(vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: level,
            base_array_layer: 0,
            layer_count: 1,
        })
        .image_extent(vk::Extent3D {
            width,
            height,
            depth: 1,
        })
}

/// Copies of every level of `image`, stored back to back from texel `first` of a buffer.
fn level_copies(image: &Image, levels: u32, first: u64) -> Vec<vk::BufferImageCopy> {
    let mut offset = first * 16;
    (0..levels)
        .map(|level| {
            let (w, h) = level_extent(image.extent.width, image.extent.height, level);
            let copy = level_region(offset, level, w, h);
            offset += u64::from(w * h) * 16;
            copy
        })
        .collect()
}

/// The preparation passes and their descriptor sets.
struct Passes {
    specular: std::sync::Arc<ComputePipeline>,
    irradiance: std::sync::Arc<ComputePipeline>,
    brdf: std::sync::Arc<ComputePipeline>,
    sheen: std::sync::Arc<ComputePipeline>,
    specular_set: DescriptorSet,
    irradiance_set: DescriptorSet,
    sheen_set: DescriptorSet,
}

impl Passes {
    fn new(ctx: &Context, source: (vk::ImageView, vk::Sampler)) -> VkResult<Self> {
        let source_binding = bindings(&[(BINDING_ENV_SOURCE, Binding::SampledImages(1))]);
        let push_size = std::mem::size_of::<EnvPreparePush>() as u32;
        let pipeline = |name: &str, spirv: &[u8], b: &[Binding]| {
            ComputePipeline::cached(ctx, name, spirv, b, push_size)
        };
        let specular = pipeline(
            "environment specular",
            crate::shaders::ENV_SPECULAR_COMP,
            &source_binding,
        )?;
        let irradiance = pipeline(
            "environment irradiance",
            crate::shaders::ENV_IRRADIANCE_COMP,
            &source_binding,
        )?;
        let brdf = pipeline(
            "environment BRDF table",
            crate::shaders::ENV_BRDF_COMP,
            &bindings(&[]),
        )?;
        let sheen = pipeline(
            "environment sheen",
            crate::shaders::ENV_SHEEN_COMP,
            &source_binding,
        )?;
        let specular_set = specular.allocate_set()?;
        specular_set.sampled_images(BINDING_ENV_SOURCE, &[source]);
        let irradiance_set = irradiance.allocate_set()?;
        irradiance_set.sampled_images(BINDING_ENV_SOURCE, &[source]);
        let sheen_set = sheen.allocate_set()?;
        sheen_set.sampled_images(BINDING_ENV_SOURCE, &[source]);
        Ok(Self {
            specular,
            irradiance,
            brdf,
            sheen,
            specular_set,
            irradiance_set,
            sheen_set,
        })
    }

    /// Records every pass, writing `out` in [`layout`]'s order.
    fn record(&self, cmd: vk::CommandBuffer, out: &Buffer, map: &EnvironmentMap, levels: u32) {
        let at = |texel: u64| out.address() + texel * 16;
        let groups = |w: u32, h: u32| [w.div_ceil(8), h.div_ceil(8), 1];
        let mut push = EnvPreparePush {
            source_width: map.width,
            source_levels: levels,
            samples: SPECULAR_SAMPLES,
            ..Default::default()
        };
        let mut first = 0u64;
        for level in 0..ENV_SPECULAR_LEVELS {
            let (w, h) = level_extent(ENV_SPECULAR_WIDTH, ENV_SPECULAR_WIDTH / 2, level);
            push.texels_out = at(first);
            push.width = w;
            push.height = h;
            push.roughness = level as f32 / (ENV_SPECULAR_LEVELS - 1) as f32;
            let bytes = push_bytes(&push);
            self.specular
                .dispatch(cmd, Some(&self.specular_set), bytes, groups(w, h));
            first += u64::from(w * h);
        }
        let l = layout();
        let (w, h) = (ENV_IRRADIANCE_WIDTH, ENV_IRRADIANCE_WIDTH / 2);
        push.texels_out = at(l.irradiance);
        push.width = w;
        push.height = h;
        push.source_level = (0..levels)
            .find(|&l| (map.height >> l).max(1) <= IRRADIANCE_SOURCE_ROWS)
            .unwrap_or(levels - 1);
        self.irradiance.dispatch(
            cmd,
            Some(&self.irradiance_set),
            push_bytes(&push),
            groups(w, h),
        );
        push.texels_out = at(l.brdf);
        push.width = ENV_BRDF_SIZE;
        push.height = ENV_BRDF_SIZE;
        push.samples = BRDF_SAMPLES;
        self.brdf.dispatch(
            cmd,
            None,
            push_bytes(&push),
            groups(ENV_BRDF_SIZE, ENV_BRDF_SIZE),
        );
        push.samples = SHEEN_SAMPLES;
        let mut first = l.sheen;
        for level in 0..ENV_SPECULAR_LEVELS {
            let (w, h) = level_extent(ENV_SHEEN_WIDTH, ENV_SHEEN_WIDTH / 2, level);
            push.texels_out = at(first);
            push.width = w;
            push.height = h;
            push.roughness = level as f32 / (ENV_SPECULAR_LEVELS - 1) as f32;
            let bytes = push_bytes(&push);
            self.sheen
                .dispatch(cmd, Some(&self.sheen_set), bytes, groups(w, h));
            first += u64::from(w * h);
        }
    }
}

/// Bytes of the importance-sampling table of `map`: `(width + 1) × (height + 1)` f32.
fn table_bytes(map: &EnvironmentMap) -> u64 {
    u64::from(map.width + 1) * u64::from(map.height + 1) * 4
}

/// The passes that build the importance-sampling table on the GPU (`env_sampling_rows.comp`,
/// then `env_sampling_marginal.comp`; `super::sampling::SamplingTables` is their host
/// reference). They run at every preparation, from the cache too, which keeps the cache files
/// as they were: on lavapipe the passes take about 4 ms for a 1024×512 map and creating their
/// pipelines about 3 ms a process (from the pipeline cache), within the cached preparation's
/// 100 ms.
struct TablePasses {
    rows: std::sync::Arc<ComputePipeline>,
    marginal: std::sync::Arc<ComputePipeline>,
    rows_set: DescriptorSet,
}

impl TablePasses {
    fn new(ctx: &Context, source: (vk::ImageView, vk::Sampler)) -> VkResult<Self> {
        let push_size = std::mem::size_of::<EnvPreparePush>() as u32;
        let rows = ComputePipeline::cached(
            ctx,
            "environment sampling rows",
            crate::shaders::ENV_SAMPLING_ROWS_COMP,
            &bindings(&[(BINDING_ENV_SOURCE, Binding::SampledImages(1))]),
            push_size,
        )?;
        let marginal = ComputePipeline::cached(
            ctx,
            "environment sampling marginal",
            crate::shaders::ENV_SAMPLING_MARGINAL_COMP,
            &bindings(&[]),
            push_size,
        )?;
        let rows_set = rows.allocate_set()?;
        rows_set.sampled_images(BINDING_ENV_SOURCE, &[source]);
        Ok(Self {
            rows,
            marginal,
            rows_set,
        })
    }

    /// Records both passes, writing the table of `map` to `table` (after the map's upload).
    fn record(
        &self,
        device: &ash::Device,
        cmd: vk::CommandBuffer,
        table: &Buffer,
        map: &EnvironmentMap,
    ) {
        let push = EnvPreparePush {
            texels_out: table.address(),
            width: map.width,
            height: map.height,
            ..Default::default()
        };
        // One workgroup per row (heights stay under the 65 535 groups a dimension allows:
        // `map::MAX_WIDTH` / 2).
        self.rows.dispatch(
            cmd,
            Some(&self.rows_set),
            push_bytes(&push),
            [map.height, 1, 1],
        );
        // The marginal pass scans the row weights the rows pass wrote.
        memory_barrier(device, cmd);
        self.marginal
            .dispatch(cmd, None, push_bytes(&push), [1, 1, 1]);
    }
}

fn sampler(ctx: &Context, mode_u: vk::SamplerAddressMode, mips: bool) -> VkResult<Sampler> {
    Sampler::new(
        ctx,
        &vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::LINEAR)
            .min_filter(vk::Filter::LINEAR)
            .mipmap_mode(vk::SamplerMipmapMode::LINEAR)
            .address_mode_u(mode_u)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .min_lod(0.0)
            .max_lod(if mips { vk::LOD_CLAMP_NONE } else { 0.25 }),
    )
}

impl GpuEnvironment {
    /// Uploads `map` and prepares its lighting textures, without a cache.
    pub fn prepare(ctx: &Context, map: &EnvironmentMap) -> VkResult<Self> {
        Self::prepare_cached(ctx, map, None)
    }

    /// [`Self::prepare_cached`] through the user's cache ([`default_cache_dir`]).
    pub fn prepare_with_user_cache(ctx: &Context, map: &EnvironmentMap) -> VkResult<Self> {
        Self::prepare_cached(ctx, map, default_cache_dir().as_deref())
    }

    /// Uploads `map` and prepares its lighting textures. With `cache_dir`, the prepared
    /// textures are read from (or written to) a file there named by the content hash of the
    /// map and the preparation's settings. The device memory it needs is checked first.
    pub fn prepare_cached(
        ctx: &Context,
        map: &EnvironmentMap,
        cache_dir: Option<&Path>,
    ) -> VkResult<Self> {
        let start = Instant::now();
        let l = layout();
        // The map with its mips twice (image and staging), the prepared texels twice.
        ctx.check_memory(
            "the environment map",
            2 * map.device_bytes() + 2 * l.total * 16 + 2 * table_bytes(map),
        )?;
        let key = cache_dir.map(|_| cache_key(map));
        let cache_file = cache_dir
            .zip(key)
            .map(|(d, k)| d.join(format!("{k:016x}.bin")));
        let cached = cache_file
            .as_deref()
            .zip(key)
            .and_then(|(f, k)| read_cache(f, k, l.total));

        let mips_start = Instant::now();
        let chain = map.mip_chain();
        let mips_ms = mips_start.elapsed().as_secs_f64() * 1e3;
        let gpu_start = Instant::now();
        let levels = chain.len() as u32;
        let usage = vk::ImageUsageFlags::SAMPLED
            | vk::ImageUsageFlags::TRANSFER_DST
            | vk::ImageUsageFlags::TRANSFER_SRC;
        let image = |name: &str, width: u32, height: u32, levels: u32| {
            let extent = vk::Extent2D { width, height };
            Image::new(
                ctx,
                name,
                extent,
                vk::Format::R32G32B32A32_SFLOAT,
                usage,
                levels,
            )
        };
        let spec_w = ENV_SPECULAR_WIDTH;
        let irr_w = ENV_IRRADIANCE_WIDTH;
        let radiance = image("environment map", map.width, map.height, levels)?;
        let specular = image(
            "environment specular",
            spec_w,
            spec_w / 2,
            ENV_SPECULAR_LEVELS,
        )?;
        let irradiance = image("environment irradiance", irr_w, irr_w / 2, 1)?;
        let brdf = image("environment BRDF table", ENV_BRDF_SIZE, ENV_BRDF_SIZE, 1)?;
        let sheen = image(
            "environment sheen",
            ENV_SHEEN_WIDTH,
            ENV_SHEEN_WIDTH / 2,
            ENV_SPECULAR_LEVELS,
        )?;
        let sampling = Image::new(
            ctx,
            "environment sampling tables",
            vk::Extent2D {
                width: map.width + 1,
                height: map.height + 1,
            },
            vk::Format::R32_SFLOAT,
            usage,
            1,
        )?;
        let table = Buffer::new(
            ctx,
            "environment sampling table",
            table_bytes(map),
            vk::BufferUsageFlags::empty(),
            MemoryLocation::GpuOnly,
        )?;
        let map_sampler = sampler(ctx, vk::SamplerAddressMode::REPEAT, true)?;
        let table_sampler = sampler(ctx, vk::SamplerAddressMode::CLAMP_TO_EDGE, false)?;

        let texels: Vec<[f32; 4]> = chain.concat();
        let mut staging = Buffer::new(
            ctx,
            "environment staging",
            texels.len() as u64 * 16,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::CpuToGpu,
        )?;
        staging.write(bytemuck::cast_slice(&texels))?;
        let location = if cached.is_some() {
            MemoryLocation::CpuToGpu
        } else {
            MemoryLocation::GpuOnly
        };
        let mut out = Buffer::new(
            ctx,
            "environment prepared texels",
            l.total * 16,
            vk::BufferUsageFlags::empty(),
            location,
        )?;
        let passes = match &cached {
            Some(texels) => {
                out.write(bytemuck::cast_slice(texels))?;
                None
            }
            None => Some(Passes::new(ctx, (radiance.view(), map_sampler.raw()))?),
        };
        let table_passes = TablePasses::new(ctx, (radiance.view(), map_sampler.raw()))?;

        let device = ctx.device();
        ctx.run("environment preparation", |cmd| {
            pipeline_barrier(
                device,
                cmd,
                &[
                    barrier(radiance.raw(), 0..levels, NONE, TRANSFER_DST),
                    barrier(specular.raw(), 0..ENV_SPECULAR_LEVELS, NONE, TRANSFER_DST),
                    barrier(irradiance.raw(), 0..1, NONE, TRANSFER_DST),
                    barrier(brdf.raw(), 0..1, NONE, TRANSFER_DST),
                    barrier(sampling.raw(), 0..1, NONE, TRANSFER_DST),
                    barrier(sheen.raw(), 0..ENV_SPECULAR_LEVELS, NONE, TRANSFER_DST),
                ],
            );
            let copies = level_copies(&radiance, levels, 0);
            // SAFETY: the staging buffer holds every level back to back, 16 bytes a texel, at
            // the offsets `level_copies` computes from the same extents; TRANSFER_DST layout.
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
                    TRANSFER_DST,
                    SHADER_READ,
                )],
            );
            if let Some(passes) = &passes {
                passes.record(cmd, &out, map, levels);
            }
            table_passes.record(device, cmd, &table, map);
            memory_barrier(device, cmd);
            let table_copy = level_region(0, 0, map.width + 1, map.height + 1);
            // SAFETY: `table` holds the whole (width + 1) × (height + 1) R32F table, written by
            // the table passes and made visible by the barrier; the image is TRANSFER_DST.
            unsafe {
                device.cmd_copy_buffer_to_image(
                    cmd,
                    table.raw(),
                    sampling.raw(),
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &[table_copy],
                )
            };
            for (image, levels, first) in [
                (&specular, ENV_SPECULAR_LEVELS, 0),
                (&irradiance, 1, l.irradiance),
                (&brdf, 1, l.brdf),
                (&sheen, ENV_SPECULAR_LEVELS, l.sheen),
            ] {
                let copies = level_copies(image, levels, first);
                // SAFETY: `out` holds each texture's levels back to back from `first`,
                // written by the passes (or from the cache) with the same extents; the
                // barrier made them visible; TRANSFER_DST layout.
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
                        TRANSFER_DST,
                        SHADER_READ,
                    ),
                    barrier(irradiance.raw(), 0..1, TRANSFER_DST, SHADER_READ),
                    barrier(brdf.raw(), 0..1, TRANSFER_DST, SHADER_READ),
                    barrier(sampling.raw(), 0..1, TRANSFER_DST, SHADER_READ),
                    barrier(
                        sheen.raw(),
                        0..ENV_SPECULAR_LEVELS,
                        TRANSFER_DST,
                        SHADER_READ,
                    ),
                ],
            );
            Ok(())
        })?;
        let gpu_ms = gpu_start.elapsed().as_secs_f64() * 1e3;
        if let (Some(file), Some(k), true) = (&cache_file, key, passes.is_some()) {
            let written = read_buffer(ctx, &out, l.total)
                .map_err(|e| std::io::Error::other(e.to_string()))
                .and_then(|texels| write_cache(file, k, &texels));
            match written {
                Ok(()) => log::debug!("environment cached in {}", file.display()),
                Err(e) => log::warn!("cannot cache the environment in {}: {e}", file.display()),
            }
        }
        Ok(Self {
            radiance,
            specular,
            irradiance,
            brdf,
            sampling,
            sheen,
            map_sampler,
            table_sampler,
            width: map.width,
            timing: PrepareTiming {
                total_ms: start.elapsed().as_secs_f64() * 1e3,
                mips_ms,
                gpu_ms,
                cached: passes.is_none(),
            },
        })
    }

    /// The bindless texture entries, in `ENV_TEX_*` order.
    pub fn descriptors(&self) -> [(vk::ImageView, vk::Sampler); ENV_TEXTURES as usize] {
        let map = self.map_sampler.raw();
        [
            (self.radiance.view(), map),
            (self.specular.view(), map),
            (self.irradiance.view(), map),
            (self.brdf.view(), self.table_sampler.raw()),
            (self.sampling.view(), self.table_sampler.raw()),
            (self.sheen.view(), map),
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
            EnvTexture::Sampling => &self.sampling,
            EnvTexture::Sheen => &self.sheen,
        };
        let texel_bytes = if which == EnvTexture::Sampling { 4 } else { 16 };
        let (w, h) = level_extent(image.extent.width, image.extent.height, level);
        let count = (w * h) as usize;
        let staging = Buffer::new(
            ctx,
            "environment readback",
            count as u64 * texel_bytes,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::GpuToCpu,
        )?;
        let device = ctx.device();
        ctx.run("environment readback", |cmd| {
            let levels = level..level + 1;
            pipeline_barrier(
                device,
                cmd,
                &[barrier(
                    image.raw(),
                    levels.clone(),
                    SHADER_READ,
                    TRANSFER_SRC,
                )],
            );
            let region = level_region(0, level, w, h);
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
                &[barrier(image.raw(), levels, TRANSFER_SRC, SHADER_READ)],
            );
            crate::vk::host_read_barrier(device, cmd);
            Ok(())
        })?;
        let invalid = || crate::vk::VkError::Invalid("readback buffer is not host-visible".into());
        let texels = if which == EnvTexture::Sampling {
            let values: Vec<f32> = staging.mapped_read(0, count).ok_or_else(invalid)?;
            values.into_iter().map(|v| [v, 0.0, 0.0, 0.0]).collect()
        } else {
            staging.mapped_read(0, count).ok_or_else(invalid)?
        };
        Ok((w, h, texels))
    }
}

/// Copies `texels` RGBA32F texels of a GPU buffer back to the host.
fn read_buffer(ctx: &Context, buffer: &Buffer, texels: u64) -> VkResult<Vec<[f32; 4]>> {
    let staging = Buffer::new(
        ctx,
        "environment cache readback",
        texels * 16,
        vk::BufferUsageFlags::empty(),
        MemoryLocation::GpuToCpu,
    )?;
    ctx.run("environment cache readback", |cmd| {
        let region = vk::BufferCopy::default().size(texels * 16);
        // SAFETY: both buffers hold at least `texels * 16` bytes and have transfer usage.
        unsafe {
            ctx.device()
                .cmd_copy_buffer(cmd, buffer.raw(), staging.raw(), &[region])
        };
        crate::vk::host_read_barrier(ctx.device(), cmd);
        Ok(())
    })?;
    staging
        .mapped_read(0, texels as usize)
        .ok_or_else(|| VkError::Invalid("readback buffer is not host-visible".into()))
}
