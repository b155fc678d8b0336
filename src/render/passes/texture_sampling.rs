//! The texture-format measurement behind `--texture-format auto` (`rqr::device_select::autotune`): the same
//! small synthetic texture as the device's block format (BC7, else ASTC 4x4) and as RGBA8,
//! each sampled by one short dispatch (`shaders/texture_sampling.comp`), timed with GPU
//! timestamps, the two alternating.
//!
//! The texture is noise: its RGBA8 texels and its blocks are random bytes. Random BC7 blocks
//! cover every BC7 mode, as real textures use them (lavapipe decodes each fetched block in
//! software, whatever its colours). Many random ASTC blocks are void-extent or error blocks;
//! ASTC is only chosen on devices without BC7 (mobile GPUs), which decode it in hardware at
//! the same cost per block.

use std::sync::Arc;

use ash::vk;

use crate::interface::{self as io, bindings, push_bytes, TextureSamplingPush};
use crate::scene::ktx2::{block_level_bytes, BlockTarget};
use crate::scene::textures::{self, mip_levels};
use crate::vk::{
    Binding, Buffer, ComputePipeline, Context, DescriptorSet, GpuProfiler, Image, MemoryLocation,
    Sampler, VkResult,
};

/// Side of the sampled texture (a full mip chain: 256 KiB of RGBA8 at level 0, 64 KiB of
/// BC7).
pub const TEXTURE_SIDE: u32 = 256;
/// Invocations per side of the dispatch (lavapipe on 2 cores: about 90 ms with BC7, 1 ms
/// with RGBA8).
pub const DISPATCH_SIDE: u32 = 128;
/// Trilinear samples per invocation (131 072 per dispatch).
pub const SAMPLES_PER_INVOCATION: u32 = 8;

/// What one measurement found: GPU milliseconds of the sampling dispatch per format.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SamplingTimes {
    /// The device's block format (`None` where it samples none, and nothing was timed).
    pub block: Option<(&'static str, f64)>,
    /// RGBA8.
    pub rgba8_ms: f64,
}

/// A xorshift64* stream: reproducible noise without a dependency.
struct Noise(u64);

impl Noise {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    fn bytes(&mut self, len: u64) -> Vec<u8> {
        (0..len.div_ceil(8))
            .flat_map(|_| self.next().to_le_bytes())
            .take(len as usize)
            .collect()
    }
}

/// Every level of the synthetic texture: RGBA8 (4 bytes per texel) or `block` blocks.
fn levels(block: Option<BlockTarget>) -> Vec<Vec<u8>> {
    let mut noise = Noise(0x9E37_79B9_7F4A_7C15);
    (0..mip_levels(TEXTURE_SIDE, TEXTURE_SIDE))
        .map(|l| {
            let side = (TEXTURE_SIDE >> l).max(1);
            noise.bytes(match block {
                Some(_) => block_level_bytes(side, side),
                None => u64::from(side) * u64::from(side) * 4,
            })
        })
        .collect()
}

/// One format's texture, bound for the sampling dispatch.
struct Sampled {
    _image: Image,
    set: DescriptorSet,
}

/// Times the sampling dispatch over the block texture (where the device samples a block
/// format) and the RGBA8 texture: one untimed round, then `rounds` rounds of one dispatch
/// per format in turn (so a device whose speed drifts slows both alike); the median of each.
/// Without timestamps, wall time of each submission.
pub fn measure(ctx: &Context, rounds: u32) -> crate::Result<SamplingTimes> {
    let pipeline: Arc<ComputePipeline> = ComputePipeline::cached(
        ctx,
        "texture sampling",
        crate::shaders::TEXTURE_SAMPLING_COMP,
        &bindings(&[
            (
                io::BINDING_TEXTURE_SAMPLING_IMAGE,
                Binding::SampledImages(1),
            ),
            (io::BINDING_TEXTURE_SAMPLING_SUMS, Binding::StorageBuffer),
        ]),
        std::mem::size_of::<TextureSamplingPush>() as u32,
    )?;
    let sums = Buffer::new(
        ctx,
        "texture sampling sums",
        u64::from(DISPATCH_SIDE * DISPATCH_SIDE) * 16,
        vk::BufferUsageFlags::empty(),
        MemoryLocation::GpuOnly,
    )?;
    let sampler = Sampler::new(
        ctx,
        &textures::sampler_create_info(&crate::scene::Sampler::default()),
    )?;
    let target = textures::block_target(ctx);
    let bind = |format: vk::Format, block: Option<BlockTarget>| -> VkResult<Sampled> {
        let image = textures::upload_levels(
            ctx,
            "texture-sampling texture",
            (TEXTURE_SIDE, TEXTURE_SIDE),
            format,
            &levels(block),
        )?;
        let set = pipeline.allocate_set()?;
        set.sampled_images(
            io::BINDING_TEXTURE_SAMPLING_IMAGE,
            &[(image.view(), sampler.raw())],
        )
        .buffer(
            io::BINDING_TEXTURE_SAMPLING_SUMS,
            &sums,
            Binding::StorageBuffer,
        );
        Ok(Sampled { _image: image, set })
    };
    let mut formats = Vec::new();
    if let Some(t) = target {
        formats.push(bind(textures::block_format(t, false), Some(t))?);
    }
    formats.push(bind(vk::Format::R8G8B8A8_UNORM, None)?);
    let push = TextureSamplingPush {
        side: DISPATCH_SIDE,
        samples: SAMPLES_PER_INVOCATION,
    };
    let groups = [DISPATCH_SIDE.div_ceil(8), DISPATCH_SIDE.div_ceil(8), 1];
    let mut profiler = GpuProfiler::new(ctx, 1).ok();
    let mut times = vec![Vec::new(); formats.len()];
    for round in 0..=rounds.max(1) {
        for (sampled, t) in formats.iter().zip(&mut times) {
            let start = std::time::Instant::now();
            ctx.run("texture sampling", |cmd| {
                if let Some(p) = profiler.as_mut() {
                    p.reset(cmd);
                    p.begin(cmd, "texture sampling");
                }
                pipeline.dispatch(cmd, Some(&sampled.set), push_bytes(&push), groups);
                if let Some(p) = profiler.as_mut() {
                    p.end(cmd);
                }
                Ok(())
            })?;
            let wall = start.elapsed().as_secs_f64() * 1e3;
            let ms = match &profiler {
                Some(p) => p.results()?.first().map_or(wall, |r| r.1),
                None => wall,
            };
            if round > 0 {
                t.push(ms);
            }
        }
    }
    let median = |mut t: Vec<f64>| {
        t.sort_by(f64::total_cmp);
        t[t.len() / 2]
    };
    let mut medians = times.into_iter().map(median);
    let block = target.and_then(|t| medians.next().map(|ms| (t.name(), ms)));
    let rgba8_ms = medians.next().unwrap_or(f64::NAN);
    Ok(SamplingTimes { block, rgba8_ms })
}
