//! Device-memory estimates of a render, checked against the device before allocating.

use super::settings::{RenderPath, RenderSettings};
use crate::vk::VkError;

/// Bytes per texel of the formats the passes allocate.
fn format_bytes(format: ash::vk::Format) -> u64 {
    use ash::vk::Format;
    match format {
        Format::R32G32B32A32_SFLOAT | Format::R32G32B32A32_UINT => 16,
        Format::R16G16B16A16_SFLOAT | Format::R32G32_UINT => 8,
        _ => 4,
    }
}

/// Bytes of one `vec4` (colour, accumulation and adaptive-corner texels).
const RGBA32F: u64 = 16;
/// Bytes of one pixel's [`super::Aov`].
const AOV_BYTES: u64 = std::mem::size_of::<super::Aov>() as u64;

impl RenderSettings {
    /// Pixels of the image.
    pub fn pixels(&self) -> u64 {
        u64::from(self.width) * u64::from(self.height)
    }

    /// Device memory a render at these settings allocates for its own buffers and images:
    /// colour, adaptive corners and tonemap output (ray-traced), or accumulation, tonemap
    /// output and one G-buffer with depth per sample (hybrid), plus the per-pixel AOVs when
    /// `aov` (without, the passes bind a one-element placeholder), and the frame's readback
    /// slot ([`crate::render::readback::readback_bytes`]: tonemapped and linear
    /// colour, 20 bytes per pixel, the AOVs again when `aov`). The readback slot is
    /// host-visible: on a device with one memory heap (CPU devices, integrated GPUs) it takes
    /// the same memory; on a discrete GPU, counting it against the device heap errs on the
    /// safe side. The scene and the ray backend come on top (see [`crate::accel`]).
    pub fn estimate_bytes(&self, path: RenderPath, aov: bool) -> u64 {
        let readback = crate::render::readback::readback_bytes(self, aov);
        self.device_bytes(path, aov).saturating_add(readback)
    }

    /// [`Self::estimate_bytes`] without the readback slot: the buffers and images the passes
    /// use.
    fn device_bytes(&self, path: RenderPath, aov: bool) -> u64 {
        let pixels = self.pixels();
        // A denoiser reads the AOVs whether or not the caller does, and adds its own buffers.
        let denoise = if self.denoise.enabled() {
            super::denoise::bytes_per_pixel()
        } else {
            0
        };
        let aov = if aov || self.denoise.enabled() {
            AOV_BYTES
        } else {
            0
        };
        let tonemapped = 4 + denoise;
        match path {
            RenderPath::RayTraced => {
                let corners = (u64::from(self.width) + 1) * (u64::from(self.height) + 1);
                pixels
                    .saturating_mul(RGBA32F + aov + tonemapped)
                    .saturating_add(corners.saturating_mul(RGBA32F))
            }
            RenderPath::Hybrid => {
                let gbuffer: u64 = self
                    .gbuffer
                    .formats()
                    .iter()
                    .map(|&f| format_bytes(f))
                    .sum::<u64>()
                    + 4; // D32 depth
                pixels
                    .saturating_mul(RGBA32F + aov + tonemapped)
                    .saturating_add(pixels.saturating_mul(gbuffer * u64::from(self.spp)))
            }
        }
    }

    /// The largest buffer a pass binds as one storage buffer, to compare with
    /// `maxStorageBufferRange`: the per-pixel AOVs when `aov`, else the colour (or the
    /// ray-traced path's adaptive corners, one row and column larger).
    pub fn largest_buffer_bytes(&self, aov: bool) -> u64 {
        let corners = (u64::from(self.width) + 1) * (u64::from(self.height) + 1) * RGBA32F;
        let aov = if aov { self.pixels() * AOV_BYTES } else { 0 };
        aov.max(corners)
    }

    /// [`Self::validate`] against the device's image limit, then checks that every per-pixel
    /// buffer (the AOVs only when `aov`) fits `maxStorageBufferRange` and that
    /// [`Self::estimate_bytes`] plus `in_use` bytes fit the largest device-local heap: a
    /// clear error before anything is allocated, instead of an allocation failure or an
    /// invalid descriptor mid-frame.
    pub fn check_device(
        &self,
        info: &crate::vk::DeviceInfo,
        path: RenderPath,
        aov: bool,
        in_use: u64,
    ) -> crate::Result<()> {
        self.validate(info.max_image_dimension_2d)?;
        let mib = |b: u64| b.div_ceil(1 << 20);
        let range = u64::from(info.max_storage_buffer_range);
        let largest = self.largest_buffer_bytes(aov);
        if largest > range {
            // Name the way out: AOVs alone need five times the colour's range.
            let (what, hint) = if aov && self.largest_buffer_bytes(false) <= range {
                (
                    " with AOVs",
                    "lower the resolution or render without AOVs (--aov)",
                )
            } else {
                ("", "lower the resolution")
            };
            return Err(VkError::Limit {
                what: format!(
                "resolution {}x{}{what} needs a {} MiB per-pixel buffer, but '{}' binds at most {} MiB per storage buffer (maxStorageBufferRange); {hint}",
                self.width,
                self.height,
                mib(largest),
                info.name,
                mib(range)
            ),
                needed: largest,
                available: range,
            }
            .into());
        }
        let heap = info.largest_device_heap();
        let needed = self.estimate_bytes(path, aov);
        if needed.saturating_add(in_use) > heap {
            return Err(VkError::Limit {
                what: format!(
                "{}x{} at {} spp ({}{}) needs about {} MiB of device memory on top of {} MiB in use, more than the {} MiB device heap of '{}'; lower the resolution{}",
                self.width,
                self.height,
                self.spp,
                match path {
                    RenderPath::RayTraced => "ray traced",
                    RenderPath::Hybrid => "hybrid",
                },
                if aov { ", with AOVs" } else { "" },
                mib(needed),
                mib(in_use),
                mib(heap),
                info.name,
                match path {
                    RenderPath::RayTraced => "",
                    RenderPath::Hybrid => " or --spp (the hybrid path keeps one G-buffer per sample)",
                }
            ),
                needed: needed.saturating_add(in_use),
                available: heap,
            }
            .into());
        }
        Ok(())
    }
}
