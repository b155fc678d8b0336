//! [`Context`]: the opened device with its queue, allocator, submission with fence timeouts,
//! validation-message log and pipeline cache. Requirements come from
//! [`super::requirements`], device facts from [`super::probe`].

use std::ffi::{c_void, CStr};
use std::mem::ManuallyDrop;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use ash::{ext, khr, vk};
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};

use super::instance::{
    create_instance, device_identity, load_entry, select_device, DeviceSelector,
};
use super::probe::{describe_device, DeviceInfo};
use super::{CallExt, VkError, VkResult};

/// Fence timeout used unless [`ContextOptions::fence_timeout`] says otherwise.
pub const DEFAULT_FENCE_TIMEOUT: Duration = Duration::from_secs(60);

/// How to create a [`Context`].
#[derive(Clone, Debug)]
pub struct ContextOptions {
    /// Device choice.
    pub device: DeviceSelector,
    /// Enable the Khronos validation layer. `None`: on when `RQR_VALIDATION=1`.
    pub validation: Option<bool>,
    /// Add synchronization validation (hazards between commands) to the validation layer;
    /// it slows every command down several times. `None`: on when `RQR_SYNC_VALIDATION=1`.
    pub sync_validation: Option<bool>,
    /// How long a submission may run before it is reported as a timeout.
    pub fence_timeout: Duration,
}

impl Default for ContextOptions {
    fn default() -> Self {
        Self {
            device: DeviceSelector::Auto,
            validation: None,
            sync_validation: None,
            fence_timeout: DEFAULT_FENCE_TIMEOUT,
        }
    }
}

/// Optional capabilities of the opened device (the required ones are checked at creation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Features {
    /// `VK_KHR_acceleration_structure` (+ deferred host operations) enabled.
    pub acceleration_structure: bool,
    /// `VK_KHR_ray_query` enabled.
    pub ray_query: bool,
    /// Timestamps usable on the chosen queue.
    pub timestamps: bool,
    /// `shaderBufferInt64Atomics` enabled: the compute rasterizer's one-pass 64-bit
    /// atomic-min (depth | triangle) path.
    pub buffer_int64_atomics: bool,
    /// `textureCompressionBC` enabled and BC7 sampleable ([`DeviceInfo::bc7_textures`]):
    /// KTX2 textures upload as BC7.
    pub bc7_textures: bool,
    /// `textureCompressionASTC_LDR` enabled and ASTC 4x4 sampleable
    /// ([`DeviceInfo::astc_4x4_textures`]).
    pub astc_4x4_textures: bool,
}

/// Validation messages collected by the debug messenger.
#[derive(Default)]
pub(crate) struct ValidationLog {
    errors: Mutex<Vec<String>>,
}

/// Instance-level objects; destroyed after the device (see [`Shared`]).
pub(crate) struct InstanceOwner {
    pub(crate) _entry: ash::Entry,
    pub(crate) instance: ash::Instance,
    debug: Option<(ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    // Boxed so the messenger's user-data pointer stays valid.
    log: Box<ValidationLog>,
}

impl Drop for InstanceOwner {
    fn drop(&mut self) {
        // SAFETY: the device (if any) was destroyed before; nothing else uses the instance.
        unsafe {
            if let Some((utils, messenger)) = self.debug.take() {
                utils.destroy_debug_utils_messenger(messenger, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

/// How long dropping a [`Context`] waits for submissions that timed out before it gives up
/// and leaks the device (a hung GPU must not hang the process).
pub const ABANDONED_WORK_GRACE: Duration = Duration::from_secs(10);

/// A resource destructor deferred by [`Shared::retire`].
type Destructor = Box<dyn FnOnce(&Shared) + Send>;

/// State shared by the context and every resource created from it; dropped last.
pub(crate) struct Shared {
    pub(crate) device: ash::Device,
    pub(crate) allocator: Mutex<Option<Allocator>>,
    pub(crate) accel: Option<khr::acceleration_structure::Device>,
    /// Set while a submission that timed out may still run: any resource can be in use.
    abandoned: AtomicBool,
    /// Destructors of resources dropped while `abandoned` was set.
    graveyard: Mutex<Vec<Destructor>>,
    /// Abandoned work never finished: destroying anything could free memory it still uses.
    leak: AtomicBool,
    /// Memory allocations made through the allocator since the device was opened (buffers,
    /// images, staging): what a steady frame loop must stop adding to.
    pub(crate) allocations: AtomicU64,
    // Dropped by hand after the device (or never, when leaking).
    pub(crate) owner: ManuallyDrop<InstanceOwner>,
}

impl Shared {
    /// Destroys a resource now, or, while a timed-out submission may still use it, once
    /// that submission has finished (see [`Context::wait_idle`] and `Context`'s drop):
    /// destroying memory the GPU still reads is undefined behaviour, not just a validation
    /// error.
    pub(crate) fn retire(&self, destroy: impl FnOnce(&Shared) + Send + 'static) {
        if self.abandoned.load(Ordering::Acquire) {
            if let Ok(mut graveyard) = self.graveyard.lock() {
                graveyard.push(Box::new(destroy));
                return;
            }
        }
        destroy(self);
    }

    /// Runs the deferred destructors; the caller knows the device is idle.
    fn bury(&self) {
        let deferred = self
            .graveyard
            .lock()
            .map(|mut g| std::mem::take(&mut *g))
            .unwrap_or_default();
        self.abandoned.store(false, Ordering::Release);
        for destroy in deferred {
            destroy(self);
        }
    }
}

impl Drop for Shared {
    fn drop(&mut self) {
        if *self.leak.get_mut() {
            // The GPU may still run abandoned work: keep its memory, device and instance
            // alive until the process exits.
            log::warn!("GPU work that timed out never finished; leaking the Vulkan device");
            std::mem::forget(self.allocator.get_mut().map(Option::take));
            return;
        }
        // SAFETY: every resource holding an Arc<Shared> is gone, so nothing else uses the
        // device; after wait-idle no submission uses the deferred resources; the instance
        // outlives the device and is dropped exactly once, here.
        unsafe {
            let _ = self.device.device_wait_idle();
            self.bury();
            drop(self.allocator.lock().map(|mut a| a.take()));
            self.device.destroy_device(None);
            ManuallyDrop::drop(&mut self.owner);
        }
    }
}

struct Submission {
    pool: vk::CommandPool,
    // Submissions that timed out: still owned by the GPU, freed after wait-idle on drop.
    abandoned: Vec<(vk::CommandBuffer, vk::Fence)>,
}

/// [`Context`]'s cache of built objects (see its `pipelines` field).
pub(crate) type ObjectCache = std::collections::HashMap<u64, Arc<dyn std::any::Any + Send + Sync>>;

/// An opened Vulkan device with one graphics+compute queue.
pub struct Context {
    pub(crate) shared: Arc<Shared>,
    queue: vk::Queue,
    queue_family: u32,
    submission: Mutex<Submission>,
    info: DeviceInfo,
    features: Features,
    fence_timeout: Duration,
    validation: bool,
    /// Objects built once and shared by every user that asks for the same one, keyed by a hash
    /// of what built them: the pipelines of [`super::ComputePipeline::cached`] and
    /// [`super::GraphicsPipeline::cached`]; dropped with the context. Typed as `Any` so that
    /// this module does not depend on the pipeline module that depends on it.
    pub(crate) pipelines: Mutex<ObjectCache>,
    /// The driver's pipeline cache every pipeline is created through.
    pipeline_cache: vk::PipelineCache,
    /// Where [`Self::save_pipeline_cache`] (and dropping the context) writes it, if anywhere.
    pipeline_cache_file: Option<std::path::PathBuf>,
    /// Checksum of the data the file holds (loaded or last written); 0: unknown.
    pipeline_cache_sum: AtomicU64,
}

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    kind: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    // SAFETY: the loader passes valid callback data; `user` is the boxed ValidationLog that
    // outlives the messenger (destroyed first in Shared::drop).
    let (message, log) = unsafe {
        let msg = if data.is_null() || (*data).p_message.is_null() {
            String::from("(no message)")
        } else {
            CStr::from_ptr((*data).p_message)
                .to_string_lossy()
                .into_owned()
        };
        (msg, &*(user as *const ValidationLog))
    };
    if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        log::error!("vulkan {kind:?}: {message}");
        if let Ok(mut errors) = log.errors.lock() {
            errors.push(message);
        }
    } else if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING) {
        log::warn!("vulkan {kind:?}: {message}");
    } else {
        log::debug!("vulkan {kind:?}: {message}");
    }
    vk::FALSE
}

impl Context {
    /// Opens a device. Fails with [`VkError::MissingFeature`], naming every missing one, when
    /// the device lacks a requirement of [`super::requirements::REQUIREMENTS`] (the table
    /// `rqr probe` reports from).
    pub fn new(opts: &ContextOptions) -> VkResult<Self> {
        let entry = load_entry()?;
        let validation = opts
            .validation
            .unwrap_or_else(|| std::env::var("RQR_VALIDATION").is_ok_and(|v| v == "1"));
        let sync = opts
            .sync_validation
            .unwrap_or_else(|| std::env::var("RQR_SYNC_VALIDATION").is_ok_and(|v| v == "1"));
        let (instance, validation) = create_instance(&entry, validation, sync)?;
        let log = Box::<ValidationLog>::default();
        let debug = if validation {
            let utils = ext::debug_utils::Instance::new(&entry, &instance);
            let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(
                    vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
                        | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                        | vk::DebugUtilsMessageSeverityFlagsEXT::INFO,
                )
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                        | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                        | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
                )
                .pfn_user_callback(Some(debug_callback))
                .user_data(&*log as *const ValidationLog as *mut c_void);
            // SAFETY: `log` is boxed and lives in Shared until after the messenger is destroyed.
            let messenger = unsafe { utils.create_debug_utils_messenger(&info, None) }
                .call("vkCreateDebugUtilsMessengerEXT")?;
            Some((utils, messenger))
        } else {
            None
        };
        let owner = InstanceOwner {
            _entry: entry,
            instance,
            debug,
            log,
        };
        Self::open_device(owner, opts, validation)
    }

    fn open_device(
        owner: InstanceOwner,
        opts: &ContextOptions,
        validation: bool,
    ) -> VkResult<Self> {
        let instance = &owner.instance;
        // SAFETY: plain enumeration call.
        let physicals =
            unsafe { instance.enumerate_physical_devices() }.call("vkEnumeratePhysicalDevices")?;
        let names: Vec<_> = physicals
            .iter()
            .map(|&p| device_identity(instance, p))
            .collect();
        let index = select_device(&names, &opts.device)?;
        let physical = physicals[index];
        let info = describe_device(instance, physical, index);
        let (device, queue_family, features) = Self::create_device(instance, physical, &info)?;
        let allocator = match Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device: physical,
            debug_settings: Default::default(),
            buffer_device_address: true,
            allocation_sizes: Default::default(),
        }) {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: the device has no child objects yet.
                unsafe { device.destroy_device(None) };
                return Err(VkError::Invalid(format!(
                    "cannot create the memory allocator: {e}"
                )));
            }
        };
        let accel = features
            .acceleration_structure
            .then(|| khr::acceleration_structure::Device::new(instance, &device));
        let shared = Arc::new(Shared {
            device,
            allocator: Mutex::new(Some(allocator)),
            accel,
            abandoned: AtomicBool::new(false),
            graveyard: Mutex::new(Vec::new()),
            leak: AtomicBool::new(false),
            allocations: AtomicU64::new(0),
            owner: ManuallyDrop::new(owner),
        });
        let device = &shared.device;
        // SAFETY: valid device and family index.
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid device; on error `shared` drops and cleans up.
        let pool =
            unsafe { device.create_command_pool(&pool_info, None) }.call("vkCreateCommandPool")?;
        let pipeline_cache = match super::pipeline_cache::create(device, &info, None) {
            Ok((cache, _)) => cache,
            Err(e) => {
                // SAFETY: the pool is unused.
                unsafe { device.destroy_command_pool(pool, None) };
                return Err(e);
            }
        };
        log::info!(
            "device {}: {} ({}), ray query: {}, validation: {}",
            index,
            info.name,
            info.driver_info,
            features.ray_query,
            validation
        );
        Ok(Self {
            shared,
            queue,
            queue_family,
            submission: Mutex::new(Submission {
                pool,
                abandoned: Vec::new(),
            }),
            info,
            features,
            fence_timeout: opts.fence_timeout,
            validation,
            pipelines: Mutex::default(),
            pipeline_cache,
            pipeline_cache_file: None,
            pipeline_cache_sum: AtomicU64::new(0),
        })
    }

    /// The pipeline cache to create pipelines through.
    pub fn pipeline_cache(&self) -> vk::PipelineCache {
        self.pipeline_cache
    }

    /// Keeps the pipeline cache in `dir` ([`super::pipeline_cache`]): seeds it from this
    /// device's file there when one is valid (a corrupt or foreign file gives one warning and
    /// an empty cache), and writes it back when the context is dropped or on
    /// [`Self::save_pipeline_cache`]. Call before building pipelines; returns whether cached
    /// data was loaded.
    pub fn use_pipeline_cache_dir(&mut self, dir: &std::path::Path) -> VkResult<bool> {
        let path = super::pipeline_cache::cache_file(dir, &self.info);
        let (cache, sum) = super::pipeline_cache::create(self.device(), &self.info, Some(&path))?;
        let loaded = sum.is_some();
        self.pipeline_cache_sum
            .store(sum.unwrap_or(0), Ordering::Relaxed);
        // SAFETY: pipelines made through the old cache do not depend on it; nothing else
        // uses the handle (it is only read by pipeline creation on this thread's context).
        unsafe {
            self.device()
                .destroy_pipeline_cache(self.pipeline_cache, None)
        };
        self.pipeline_cache = cache;
        log::info!(
            "pipeline cache {} ({})",
            path.display(),
            if loaded { "loaded" } else { "empty" }
        );
        self.pipeline_cache_file = Some(path);
        Ok(loaded)
    }

    /// Writes the pipeline cache to its file now; returns the file (`None` without one).
    pub fn save_pipeline_cache(&self) -> VkResult<Option<std::path::PathBuf>> {
        let Some(path) = &self.pipeline_cache_file else {
            return Ok(None);
        };
        let known = match self.pipeline_cache_sum.load(Ordering::Relaxed) {
            0 => None,
            sum => Some(sum),
        };
        let sum = super::pipeline_cache::save(self.device(), self.pipeline_cache, path, known)?;
        self.pipeline_cache_sum.store(sum, Ordering::Relaxed);
        Ok(Some(path.clone()))
    }

    fn create_device(
        instance: &ash::Instance,
        physical: vk::PhysicalDevice,
        info: &DeviceInfo,
    ) -> VkResult<(ash::Device, u32, Features)> {
        // The probe's list of missing requirements (one table: super::requirements).
        super::requirements::check(&info.name, &info.missing_features)?;
        // SAFETY: `physical` comes from `instance`.
        let props = unsafe { instance.get_physical_device_properties(physical) };
        // SAFETY: as above.
        let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
        let wanted = vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE;
        let queue_family = families
            .iter()
            .position(|f| f.queue_flags.contains(wanted))
            .ok_or_else(|| VkError::MissingFeature {
                device: info.name.clone(),
                feature: "a graphics+compute queue".into(),
            })? as u32;
        let timestamps = families[queue_family as usize].timestamp_valid_bits > 0
            && props.limits.timestamp_compute_and_graphics == vk::TRUE;

        let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
        let mut f13 = vk::PhysicalDeviceVulkan13Features::default();
        let mut fas = vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default();
        let mut frq = vk::PhysicalDeviceRayQueryFeaturesKHR::default();
        let base = {
            let mut f2 = vk::PhysicalDeviceFeatures2::default()
                .push_next(&mut f12)
                .push_next(&mut f13)
                .push_next(&mut fas)
                .push_next(&mut frq);
            // SAFETY: the chain only holds structs the 1.3 device knows; unknown ones are ignored.
            unsafe { instance.get_physical_device_features2(physical, &mut f2) };
            f2.features
        };
        // SAFETY: as above.
        let exts = unsafe { instance.enumerate_device_extension_properties(physical) }
            .call("vkEnumerateDeviceExtensionProperties")?;
        let has = |name: &CStr| {
            exts.iter()
                .any(|e| e.extension_name_as_c_str().ok() == Some(name))
        };
        let acceleration_structure = has(khr::acceleration_structure::NAME)
            && has(khr::deferred_host_operations::NAME)
            && fas.acceleration_structure == vk::TRUE;
        let ray_query =
            acceleration_structure && has(khr::ray_query::NAME) && frq.ray_query == vk::TRUE;

        let mut extensions = Vec::new();
        if acceleration_structure {
            extensions.push(khr::acceleration_structure::NAME.as_ptr());
            extensions.push(khr::deferred_host_operations::NAME.as_ptr());
        }
        if ray_query {
            extensions.push(khr::ray_query::NAME.as_ptr());
        }

        let base_enable = vk::PhysicalDeviceFeatures::default()
            .shader_int64(true)
            .sampler_anisotropy(base.sampler_anisotropy == vk::TRUE)
            // Block-compressed KTX2 textures, where the probe found the formats sampleable.
            .texture_compression_bc(info.bc7_textures)
            .texture_compression_astc_ldr(info.astc_4x4_textures)
            .fragment_stores_and_atomics(base.fragment_stores_and_atomics == vk::TRUE);
        let mut e12 = vk::PhysicalDeviceVulkan12Features::default()
            .buffer_device_address(true)
            .descriptor_indexing(true)
            .runtime_descriptor_array(true)
            .descriptor_binding_partially_bound(true)
            .descriptor_binding_variable_descriptor_count(
                f12.descriptor_binding_variable_descriptor_count == vk::TRUE,
            )
            .shader_sampled_image_array_non_uniform_indexing(true)
            .shader_storage_buffer_array_non_uniform_indexing(
                f12.shader_storage_buffer_array_non_uniform_indexing == vk::TRUE,
            )
            .scalar_block_layout(true)
            .timeline_semaphore(true)
            .host_query_reset(f12.host_query_reset == vk::TRUE)
            .shader_float16(f12.shader_float16 == vk::TRUE)
            .storage_buffer8_bit_access(f12.storage_buffer8_bit_access == vk::TRUE)
            .shader_int8(f12.shader_int8 == vk::TRUE)
            .shader_buffer_int64_atomics(f12.shader_buffer_int64_atomics == vk::TRUE);
        let mut e13 = vk::PhysicalDeviceVulkan13Features::default()
            .dynamic_rendering(true)
            .synchronization2(true)
            .maintenance4(f13.maintenance4 == vk::TRUE);
        let mut eas = vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default()
            .acceleration_structure(true);
        let mut erq = vk::PhysicalDeviceRayQueryFeaturesKHR::default().ray_query(true);
        let priorities = [1.0f32];
        let queue_info = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        let mut create = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_info)
            .enabled_extension_names(&extensions)
            .enabled_features(&base_enable)
            .push_next(&mut e12)
            .push_next(&mut e13);
        if acceleration_structure {
            create = create.push_next(&mut eas);
        }
        if ray_query {
            create = create.push_next(&mut erq);
        }
        // SAFETY: every enabled feature/extension was checked above.
        let device =
            unsafe { instance.create_device(physical, &create, None) }.call("vkCreateDevice")?;
        Ok((
            device,
            queue_family,
            Features {
                acceleration_structure,
                ray_query,
                timestamps,
                buffer_int64_atomics: f12.shader_buffer_int64_atomics == vk::TRUE,
                bc7_textures: info.bc7_textures,
                astc_4x4_textures: info.astc_4x4_textures,
            },
        ))
    }

    /// The logical device, for recording commands.
    pub fn device(&self) -> &ash::Device {
        &self.shared.device
    }

    /// `VK_KHR_acceleration_structure` entry points, when enabled.
    pub fn accel(&self) -> Option<&khr::acceleration_structure::Device> {
        self.shared.accel.as_ref()
    }

    /// What the device is and can do (the same record `rqr probe` prints).
    pub fn info(&self) -> &DeviceInfo {
        &self.info
    }

    /// Optional capabilities in use.
    pub fn features(&self) -> Features {
        self.features
    }

    /// Queue family of the single queue.
    pub fn queue_family(&self) -> u32 {
        self.queue_family
    }

    /// Whether the validation layer is active on this context.
    pub fn validation_enabled(&self) -> bool {
        self.validation
    }

    /// Validation errors reported so far (empty when validation is off).
    pub fn validation_errors(&self) -> Vec<String> {
        self.shared
            .owner
            .log
            .errors
            .lock()
            .map(|e| e.clone())
            .unwrap_or_default()
    }

    /// Bytes of device memory the allocator holds now (whole memory blocks, so somewhat more
    /// than the live resources need).
    pub fn allocated_bytes(&self) -> u64 {
        self.shared
            .allocator
            .lock()
            .ok()
            .and_then(|a| a.as_ref().map(Allocator::capacity))
            .unwrap_or(0)
    }

    /// How many device-memory allocations (buffers, images, staging buffers) were made since
    /// the device was opened. A frame loop that reuses its resources leaves it unchanged from
    /// one frame to the next.
    pub fn allocation_count(&self) -> u64 {
        self.shared.allocations.load(Ordering::Relaxed)
    }

    /// Refuses to allocate `bytes` more for `what` when they, plus what is allocated now,
    /// exceed the largest device-local heap: a clear error before the allocation instead of
    /// an out-of-memory failure halfway through an upload.
    pub fn check_memory(&self, what: &str, bytes: u64) -> VkResult<()> {
        let heap = self.info.largest_device_heap();
        let in_use = self.allocated_bytes();
        if bytes.saturating_add(in_use) > heap {
            let mib = |b: u64| b.div_ceil(1 << 20);
            return Err(VkError::Limit {
                what: format!(
                    "{what} need about {} MiB of device memory on top of {} MiB in use, more than the {} MiB device heap of '{}'",
                    mib(bytes),
                    mib(in_use),
                    mib(heap),
                    self.info.name
                ),
                needed: bytes.saturating_add(in_use),
                available: heap,
            });
        }
        Ok(())
    }

    /// Makes every memory heap look at most `bytes` large to the checks that run before
    /// allocating (render targets, acceleration structures, BVH): work that would not fit
    /// a device with that much memory fails with the same clear error. For tests and for
    /// keeping rqr within a budget; the driver's limits are unchanged.
    pub fn limit_device_memory(&mut self, bytes: u64) {
        for heap in &mut self.info.memory_heaps {
            heap.size_bytes = heap.size_bytes.min(bytes);
        }
    }

    /// The timeout applied to every submission.
    pub fn fence_timeout(&self) -> Duration {
        self.fence_timeout
    }

    /// Changes the timeout applied to later submissions.
    pub fn set_fence_timeout(&mut self, timeout: Duration) {
        self.fence_timeout = timeout;
    }

    /// Records commands with `record`, submits them and waits for completion.
    ///
    /// `pass` names the work in errors: a fence that does not signal within the fence
    /// timeout returns [`VkError::Timeout`] naming it, never a hang.
    pub fn run<T>(
        &self,
        pass: &str,
        record: impl FnOnce(vk::CommandBuffer) -> VkResult<T>,
    ) -> VkResult<T> {
        let device = self.device();
        let mut sub = self.submission.lock().expect("command pool lock poisoned");
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(sub.pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: the pool is externally synchronised by `submission`'s lock.
        let cmd =
            unsafe { device.allocate_command_buffers(&alloc) }.call("vkAllocateCommandBuffers")?[0];
        let free = |sub: &Submission| {
            // SAFETY: `cmd` is not pending (never submitted or completed).
            unsafe { device.free_command_buffers(sub.pool, &[cmd]) }
        };
        let begin = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        // SAFETY: fresh command buffer.
        if let Err(e) =
            unsafe { device.begin_command_buffer(cmd, &begin) }.call("vkBeginCommandBuffer")
        {
            free(&sub);
            return Err(e);
        }
        let value = match record(cmd) {
            Ok(v) => v,
            Err(e) => {
                // SAFETY: recording state; end then free.
                let _ = unsafe { device.end_command_buffer(cmd) };
                free(&sub);
                return Err(e);
            }
        };
        // SAFETY: recording state.
        if let Err(e) = unsafe { device.end_command_buffer(cmd) }.call("vkEndCommandBuffer") {
            free(&sub);
            return Err(e);
        }
        // SAFETY: plain object creation.
        let fence = unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None) }
            .call("vkCreateFence")?;
        let cmds = [cmd];
        let submit = vk::SubmitInfo::default().command_buffers(&cmds);
        // SAFETY: the command buffer is executable, the queue is used only under this lock.
        let submitted = unsafe { device.queue_submit(self.queue, &[submit], fence) };
        if let Err(result) = submitted {
            // SAFETY: the submission failed, so neither object is in use.
            unsafe { device.destroy_fence(fence, None) };
            free(&sub);
            return Err(self.map_device_error(pass, "vkQueueSubmit", result));
        }
        let timeout_ns = u64::try_from(self.fence_timeout.as_nanos()).unwrap_or(u64::MAX);
        // SAFETY: the fence belongs to this device.
        match unsafe { device.wait_for_fences(&[fence], true, timeout_ns) } {
            Ok(()) => {
                // SAFETY: the fence signalled: the command buffer is complete.
                unsafe { device.destroy_fence(fence, None) };
                free(&sub);
                Ok(value)
            }
            Err(vk::Result::TIMEOUT) => {
                sub.abandoned.push((cmd, fence));
                self.shared.abandoned.store(true, Ordering::Release);
                Err(VkError::Timeout {
                    pass: pass.to_string(),
                    timeout_ms: self.fence_timeout.as_millis() as u64,
                })
            }
            Err(result) => {
                sub.abandoned.push((cmd, fence));
                self.shared.abandoned.store(true, Ordering::Release);
                Err(self.map_device_error(pass, "vkWaitForFences", result))
            }
        }
    }

    fn map_device_error(&self, pass: &str, call: &'static str, result: vk::Result) -> VkError {
        // Name the pass rather than the call: that is what the user can act on.
        match VkError::from_call(call, result) {
            VkError::DeviceLost { .. } => VkError::DeviceLost {
                pass: pass.to_string(),
            },
            VkError::OutOfMemory { bytes, reason, .. } => VkError::OutOfMemory {
                what: pass.to_string(),
                bytes,
                reason,
            },
            other => other,
        }
    }

    /// Waits until the device is idle (with no timeout: use before teardown only), then frees
    /// what submissions that timed out had kept alive.
    pub fn wait_idle(&self) -> VkResult<()> {
        let mut sub = self.submission.lock().expect("command pool lock poisoned");
        let device = self.device();
        // SAFETY: the queue is not being submitted to concurrently (`run` holds the lock we
        // hold); after wait-idle no abandoned command buffer is pending.
        unsafe {
            device.device_wait_idle().call("vkDeviceWaitIdle")?;
            for (cmd, fence) in std::mem::take(&mut sub.abandoned) {
                device.destroy_fence(fence, None);
                device.free_command_buffers(sub.pool, &[cmd]);
            }
        }
        self.shared.bury();
        Ok(())
    }
}

impl Drop for Context {
    fn drop(&mut self) {
        // Saved first: a context whose work never finished still compiled its pipelines.
        if let Err(e) = self.save_pipeline_cache() {
            log::warn!("{e}");
        }
        let device = &self.shared.device;
        // A panic while recording poisons the lock; the pool must still be destroyed.
        let sub = self.submission.get_mut().unwrap_or_else(|e| e.into_inner());
        if !sub.abandoned.is_empty() {
            let fences: Vec<vk::Fence> = sub.abandoned.iter().map(|&(_, f)| f).collect();
            let grace = u64::try_from(ABANDONED_WORK_GRACE.as_nanos()).unwrap_or(u64::MAX);
            // SAFETY: the fences belong to this device.
            if let Err(vk::Result::TIMEOUT) =
                unsafe { device.wait_for_fences(&fences, true, grace) }
            {
                // Still running: the pool, the fences and every resource must outlive it.
                self.shared.leak.store(true, Ordering::Release);
                return;
            }
        }
        // SAFETY: after wait-idle no command buffer is pending; the pool and the pipeline
        // cache are ours (pipelines do not depend on the cache they were made through).
        unsafe {
            let _ = device.device_wait_idle();
            device.destroy_pipeline_cache(self.pipeline_cache, None);
            for (_, fence) in sub.abandoned.drain(..) {
                device.destroy_fence(fence, None);
            }
            device.destroy_command_pool(sub.pool, None);
        }
        self.shared.bury();
    }
}
