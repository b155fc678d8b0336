//! Vulkan plumbing: instance, device selection and feature probing, memory, command
//! submission with timeouts, compute pipelines and GPU timestamps.
//!
//! This is the only module that performs raw `ash` setup; passes build on [`Context`],
//! [`Buffer`], [`Image`], [`Sampler`], [`ComputePipeline`] and [`GpuProfiler`].

mod context;
mod graphics_pipeline;
mod instance;
mod memory;
mod pipeline;
pub mod pipeline_cache;
mod probe;
mod profiler;
pub mod requirements;
mod sampler;

pub(crate) use context::Shared;
pub use context::{Context, ContextOptions, Features, ABANDONED_WORK_GRACE, DEFAULT_FENCE_TIMEOUT};
pub use graphics_pipeline::{GraphicsPipeline, GraphicsTargets};
pub use instance::{normalize_uuid, validation_layer_available, DeviceSelector};
pub use memory::{host_read_barrier, Buffer, Image};
pub use pipeline::{
    memory_barrier, rows_of_groups, spirv_words, Binding, ComputePipeline, DescriptorSet,
};
pub use probe::{
    describe_devices, largest_device_heap, AsProperties, DeviceInfo, DeviceList, MemoryHeapInfo,
    TimestampInfo,
};
pub use profiler::{FrameTiming, GpuProfiler};
pub use sampler::Sampler;

pub use ash::vk;
pub use gpu_allocator::MemoryLocation;

/// Errors from the Vulkan layer. Every message says what failed and, where it helps,
/// what to do about it.
#[derive(Debug, thiserror::Error)]
pub enum VkError {
    /// The Vulkan loader library could not be opened.
    #[error("cannot load the Vulkan loader ({0}); install a Vulkan driver and loader, e.g. `scripts/setup-vulkan.sh` (Mesa lavapipe)")]
    Loader(String),
    /// No physical device is visible.
    #[error("no Vulkan device found; install a driver, e.g. `scripts/setup-vulkan.sh` (Mesa lavapipe, CPU)")]
    NoDevice,
    /// `--device` matched nothing.
    #[error("no Vulkan device matches '{selector}' (devices: {available})")]
    NoMatchingDevice {
        /// What the user asked for.
        selector: String,
        /// The devices that exist, as `index: name`.
        available: String,
    },
    /// A device lacks something rqr cannot work without.
    #[error("device '{device}' lacks {feature}, which rqr needs")]
    MissingFeature {
        /// Device name.
        device: String,
        /// The feature or extension.
        feature: String,
    },
    /// A Vulkan call returned an error.
    #[error("{call} failed: {result}")]
    Call {
        /// The Vulkan function.
        call: &'static str,
        /// Its result code.
        result: vk::Result,
    },
    /// The GPU did not finish a submission within the fence timeout.
    #[error("GPU timeout: pass '{pass}' did not finish within {timeout_ms} ms (raise --timeout-ms, or lower the resolution/spp)")]
    Timeout {
        /// The pass that was running.
        pass: String,
        /// The timeout that expired.
        timeout_ms: u64,
    },
    /// The device was lost (driver crash, hang recovery).
    #[error("device lost while running pass '{pass}'")]
    DeviceLost {
        /// The pass that was running.
        pass: String,
    },
    /// Device or host memory ran out.
    #[error("out of memory allocating '{what}' ({bytes} bytes): {reason}")]
    OutOfMemory {
        /// The resource being allocated.
        what: String,
        /// Requested size.
        bytes: u64,
        /// The allocator's explanation.
        reason: String,
    },
    /// A request beyond a limit of the device (its heap, `maxStorageBufferRange`,
    /// `maxPrimitiveCount`, ...) or of a fixed-width index in rqr's own layouts: it can never
    /// succeed on this device with these inputs.
    #[error("{what}")]
    Limit {
        /// The sentence people read: what asked for more than the limit allows, the limit's
        /// name, both amounts with their units and, where there is one, the way out.
        what: String,
        /// The amount asked for (in the limit's own unit: bytes, triangles, instances, ...).
        needed: u64,
        /// The most the limit allows, in the same unit.
        available: u64,
    },
    /// A request that is wrong whatever the device: sizes or data that do not match, a buffer
    /// used in a way its creation did not allow, invalid SPIR-V. A bug in rqr or in a library
    /// caller's data, never a user's setting.
    #[error("{0}")]
    Invalid(String),
    /// The pipeline cache could not be written. The OS error is the source.
    #[error("cannot write the pipeline cache '{path}'")]
    PipelineCacheWrite {
        /// The cache file.
        path: String,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
}

/// Result alias for the Vulkan layer.
pub type VkResult<T> = Result<T, VkError>;

/// Attaches the Vulkan call name to an `ash` result.
pub(crate) trait CallExt<T> {
    fn call(self, name: &'static str) -> VkResult<T>;
}

impl<T> CallExt<T> for Result<T, vk::Result> {
    fn call(self, name: &'static str) -> VkResult<T> {
        self.map_err(|result| VkError::from_call(name, result))
    }
}

impl VkError {
    /// The error for a failed Vulkan call: a lost device and exhausted memory get their own
    /// variants (callers and the CLI treat them differently from a plain failure).
    pub fn from_call(call: &'static str, result: vk::Result) -> Self {
        match result {
            vk::Result::ERROR_DEVICE_LOST => Self::DeviceLost {
                pass: call.to_string(),
            },
            vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY => {
                Self::OutOfMemory {
                    what: call.to_string(),
                    bytes: 0,
                    reason: result.to_string(),
                }
            }
            _ => Self::Call { call, result },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lost_devices_and_exhausted_memory_get_their_own_errors() {
        let lost: Result<(), vk::Result> = Err(vk::Result::ERROR_DEVICE_LOST);
        assert!(matches!(
            lost.call("vkQueueSubmit"),
            Err(VkError::DeviceLost { pass }) if pass == "vkQueueSubmit"
        ));
        for oom in [
            vk::Result::ERROR_OUT_OF_DEVICE_MEMORY,
            vk::Result::ERROR_OUT_OF_HOST_MEMORY,
        ] {
            let e = Err::<(), _>(oom).call("vkCreateBuffer").unwrap_err();
            assert!(matches!(&e, VkError::OutOfMemory { what, .. } if what == "vkCreateBuffer"));
            assert!(e.to_string().contains("out of memory"), "{e}");
        }
        let other = Err::<(), _>(vk::Result::ERROR_INITIALIZATION_FAILED).call("vkCreateDevice");
        assert!(matches!(
            other,
            Err(VkError::Call {
                call: "vkCreateDevice",
                ..
            })
        ));
    }
}
