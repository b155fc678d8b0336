//! Texture samplers owned like buffers and images (destroyed with their last user).

use std::sync::Arc;

use ash::vk;

use super::context::Shared;
use super::{CallExt, Context, VkResult};

/// A `VkSampler` destroyed with its owner; like [`super::Buffer`] and [`super::Image`] it
/// keeps the device alive until it is dropped.
pub struct Sampler {
    shared: Arc<Shared>,
    raw: vk::Sampler,
}

impl Sampler {
    /// Creates a sampler.
    pub fn new(ctx: &Context, info: &vk::SamplerCreateInfo<'_>) -> VkResult<Self> {
        let shared = ctx.shared.clone();
        // SAFETY: valid create info; the device outlives the sampler through `shared`.
        let raw = unsafe { shared.device.create_sampler(info, None) }.call("vkCreateSampler")?;
        Ok(Self { shared, raw })
    }

    /// The Vulkan handle.
    pub fn raw(&self) -> vk::Sampler {
        self.raw
    }
}

impl Drop for Sampler {
    fn drop(&mut self) {
        let raw = self.raw;
        // SAFETY: GPU work using the sampler has completed (every submission waits;
        // `retire` defers past submissions that timed out).
        self.shared
            .retire(move |shared| unsafe { shared.device.destroy_sampler(raw, None) });
    }
}
