//! What every physical device offers, read without opening it ([`DeviceInfo`]), including
//! what it lacks of [`super::requirements::REQUIREMENTS`]: the raw capabilities only. What rqr
//! would choose on each device (ray backend, visibility pass, texture format) is decided above
//! this layer, in `device_select`.

use std::ffi::CStr;

use ash::{ext, khr, vk};
use serde::Serialize;

use super::instance::{
    create_instance, device_identity, load_entry, select_device, DeviceIdentity, DeviceSelector,
};
use super::requirements::{self, DeviceSupport};
use super::{CallExt, VkResult};

/// Acceleration-structure limits (present when the extension is supported).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct AsProperties {
    /// `maxGeometryCount`.
    pub max_geometry_count: u64,
    /// `maxInstanceCount`.
    pub max_instance_count: u64,
    /// `maxPrimitiveCount`.
    pub max_primitive_count: u64,
    /// `minAccelerationStructureScratchOffsetAlignment`.
    pub min_scratch_offset_alignment: u32,
}

/// Timestamp support on the graphics+compute queue.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct TimestampInfo {
    /// Whether timestamps can be written on that queue.
    pub supported: bool,
    /// Nanoseconds per timestamp tick.
    pub period_ns: f32,
}

/// One memory heap.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct MemoryHeapInfo {
    /// Heap size.
    pub size_bytes: u64,
    /// `VK_MEMORY_HEAP_DEVICE_LOCAL_BIT`.
    pub device_local: bool,
}

/// Everything `rqr probe` reports about one physical device.
///
/// `Default` is an empty description (no name, no features): a base for device lists
/// injected in tests of selection rules.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct DeviceInfo {
    /// Enumeration index (what `--device N` takes).
    pub index: usize,
    /// Device name.
    pub name: String,
    /// PCI vendor id.
    pub vendor_id: u32,
    /// `cpu|discrete|integrated|virtual|other`.
    pub device_type: String,
    /// Device API version, `major.minor.patch`.
    pub api_version: String,
    /// Driver name (`VkPhysicalDeviceDriverProperties`).
    pub driver_name: String,
    /// Driver info string.
    pub driver_info: String,
    /// `VkPhysicalDeviceProperties::driverVersion` (vendor-specific encoding).
    pub driver_version: u32,
    /// `deviceUUID`, hex with dashes (the autotune cache key, with the driver version). On
    /// NVIDIA it is the CUDA / NVML UUID (`nvidia-smi -L` prints it as `GPU-<this>`).
    pub device_uuid: String,
    /// PCI device id (`VkPhysicalDeviceProperties::deviceID`).
    pub device_id: u32,
    /// PCI address `domain:bus:device.function` (`0000:3b:00.0`, as `nvidia-smi` prints it)
    /// from `VK_EXT_pci_bus_info`; `None` where the device does not expose it.
    pub pci_bus_id: Option<String>,
    /// `pipelineCacheUUID`, hex: pipeline caches are only valid for the same value.
    pub pipeline_cache_uuid: String,
    /// `shaderBufferInt64Atomics`: the compute rasterizer's one-pass depth test.
    pub buffer_int64_atomics: bool,
    /// `VK_KHR_ray_query` usable.
    pub ray_query: bool,
    /// BC7 textures usable: `textureCompressionBC`, and `BC7_SRGB_BLOCK` and `BC7_UNORM_BLOCK`
    /// sampled with linear filtering and copied to and from (KTX2 textures upload as BC7).
    pub bc7_textures: bool,
    /// ASTC 4x4 LDR textures usable, checked as for [`Self::bc7_textures`]
    /// (`textureCompressionASTC_LDR`, `ASTC_4X4_SRGB_BLOCK` and `ASTC_4X4_UNORM_BLOCK`).
    pub astc_4x4_textures: bool,
    /// `VK_KHR_acceleration_structure` usable.
    pub acceleration_structure: bool,
    /// `VK_KHR_ray_tracing_pipeline` supported (rqr does not use it).
    pub ray_tracing_pipeline: bool,
    /// Acceleration-structure limits.
    pub as_properties: Option<AsProperties>,
    /// Default subgroup size.
    pub subgroup_size: u32,
    /// `maxComputeWorkGroupInvocations`.
    pub max_compute_workgroup_invocations: u32,
    /// Timestamp support.
    pub timestamps: TimestampInfo,
    /// Memory heaps.
    pub memory_heaps: Vec<MemoryHeapInfo>,
    /// `maxImageDimension2D`.
    pub max_image_dimension_2d: u32,
    /// `maxPushConstantsSize`.
    pub max_push_constants_size: u32,
    /// `maxStorageBufferRange`: the most a storage-buffer descriptor binds.
    pub max_storage_buffer_range: u32,
    /// `maxMemoryAllocationSize` (Vulkan 1.1): the largest single allocation, so the largest
    /// buffer a shader reaches through a buffer reference rather than a descriptor.
    pub max_memory_allocation_size: u64,
    /// The most combined image samplers one binding may hold in a compute or fragment stage
    /// (the least of the per-stage and per-set sampler and sampled-image limits); 0: unknown.
    pub max_sampled_image_array: u32,
    /// Required features the device lacks (empty: rqr can run on it).
    pub missing_features: Vec<String>,
}

/// Size of the largest device-local heap (of the largest heap when none is device-local):
/// what memory checks compare against before allocating.
pub fn largest_device_heap(heaps: &[MemoryHeapInfo]) -> u64 {
    heaps
        .iter()
        .filter(|h| h.device_local)
        .map(|h| h.size_bytes)
        .max()
        .or_else(|| heaps.iter().map(|h| h.size_bytes).max())
        .unwrap_or(0)
}

impl DeviceInfo {
    /// [`largest_device_heap`] of this device.
    pub fn largest_device_heap(&self) -> u64 {
        largest_device_heap(&self.memory_heaps)
    }
}

/// Every physical device, described, and the one a selector picks.
#[derive(Clone, Debug)]
pub struct DeviceList {
    /// Index of the device rqr would open with the selector.
    pub selected: usize,
    /// Every physical device, in enumeration order.
    pub devices: Vec<DeviceInfo>,
}

fn version_string(v: u32) -> String {
    format!(
        "{}.{}.{}",
        vk::api_version_major(v),
        vk::api_version_minor(v),
        vk::api_version_patch(v)
    )
}

pub(super) fn uuid_string(bytes: &[u8; vk::UUID_SIZE]) -> String {
    let mut s = String::with_capacity(36);
    for (i, b) in bytes.iter().enumerate() {
        if matches!(i, 4 | 6 | 8 | 10) {
            s.push('-');
        }
        s.push_str(&format!("{b:02x}"));
    }
    s
}

fn c_string(chars: &[std::ffi::c_char]) -> String {
    // SAFETY: Vulkan strings are NUL-terminated within their fixed arrays.
    let bytes: &[u8] = unsafe { std::slice::from_raw_parts(chars.as_ptr().cast(), chars.len()) };
    CStr::from_bytes_until_nul(bytes)
        .map(|c| c.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Format features a block-compressed texture format needs: copied into from a staging buffer,
/// sampled with linear filtering (rqr's samplers are linear unless glTF asks otherwise), and
/// copied out (like every rqr texture: tests read the uploaded levels back).
const BLOCK_TEXTURE_FEATURES: vk::FormatFeatureFlags = vk::FormatFeatureFlags::from_raw(
    vk::FormatFeatureFlags::SAMPLED_IMAGE.as_raw()
        | vk::FormatFeatureFlags::SAMPLED_IMAGE_FILTER_LINEAR.as_raw()
        | vk::FormatFeatureFlags::TRANSFER_DST.as_raw()
        | vk::FormatFeatureFlags::TRANSFER_SRC.as_raw(),
);

/// Whether every format of `formats` (an sRGB and a UNORM variant) has
/// [`BLOCK_TEXTURE_FEATURES`] with optimal tiling. The caller checks the feature bit that
/// makes these formats legal at all.
fn block_formats_usable(
    instance: &ash::Instance,
    pd: vk::PhysicalDevice,
    formats: [vk::Format; 2],
) -> bool {
    formats.iter().all(|&f| {
        // SAFETY: `pd` comes from `instance`; a plain property read.
        let props = unsafe { instance.get_physical_device_format_properties(pd, f) };
        props
            .optimal_tiling_features
            .contains(BLOCK_TEXTURE_FEATURES)
    })
}

/// Reads a physical device's properties, limits and support.
pub(crate) fn describe_device(
    instance: &ash::Instance,
    pd: vk::PhysicalDevice,
    index: usize,
) -> DeviceInfo {
    // SAFETY: `pd` comes from `instance`; every query below is a plain property read.
    let exts = unsafe { instance.enumerate_device_extension_properties(pd) }.unwrap_or_default();
    let has = |name: &CStr| {
        exts.iter()
            .any(|e| e.extension_name_as_c_str().ok() == Some(name))
    };
    let has_as = has(khr::acceleration_structure::NAME) && has(khr::deferred_host_operations::NAME);
    let has_rq = has(khr::ray_query::NAME);
    let has_rtp = has(khr::ray_tracing_pipeline::NAME);

    let mut driver = vk::PhysicalDeviceDriverProperties::default();
    let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
    let mut id_props = vk::PhysicalDeviceIDProperties::default();
    let mut maintenance3 = vk::PhysicalDeviceMaintenance3Properties::default();
    let mut as_props = vk::PhysicalDeviceAccelerationStructurePropertiesKHR::default();
    let has_pci = has(ext::pci_bus_info::NAME);
    let mut pci = vk::PhysicalDevicePCIBusInfoPropertiesEXT::default();
    let props = {
        let mut props2 = vk::PhysicalDeviceProperties2::default()
            .push_next(&mut driver)
            .push_next(&mut subgroup)
            .push_next(&mut id_props)
            .push_next(&mut maintenance3);
        if has_as {
            props2 = props2.push_next(&mut as_props);
        }
        if has_pci {
            props2 = props2.push_next(&mut pci);
        }
        // SAFETY: the chain holds only structs the device knows (AS and PCI properties only
        // with their extensions).
        unsafe { instance.get_physical_device_properties2(pd, &mut props2) };
        props2.properties
    };

    let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
    let mut f13 = vk::PhysicalDeviceVulkan13Features::default();
    let mut fas = vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default();
    let mut frq = vk::PhysicalDeviceRayQueryFeaturesKHR::default();
    let base_features = {
        let mut f2 = vk::PhysicalDeviceFeatures2::default()
            .push_next(&mut f12)
            .push_next(&mut f13)
            .push_next(&mut fas)
            .push_next(&mut frq);
        // SAFETY: unknown structs in the chain are ignored by the loader/driver.
        unsafe { instance.get_physical_device_features2(pd, &mut f2) };
        f2.features
    };
    let acceleration_structure = has_as && fas.acceleration_structure == vk::TRUE;
    let ray_query = acceleration_structure && has_rq && frq.ray_query == vk::TRUE;
    let bc7_textures = base_features.texture_compression_bc == vk::TRUE
        && block_formats_usable(
            instance,
            pd,
            [vk::Format::BC7_SRGB_BLOCK, vk::Format::BC7_UNORM_BLOCK],
        );
    let astc_4x4_textures = base_features.texture_compression_astc_ldr == vk::TRUE
        && block_formats_usable(
            instance,
            pd,
            [
                vk::Format::ASTC_4X4_SRGB_BLOCK,
                vk::Format::ASTC_4X4_UNORM_BLOCK,
            ],
        );

    // SAFETY: as above.
    let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
    let wanted = vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE;
    let family = families.iter().find(|f| f.queue_flags.contains(wanted));
    let support = DeviceSupport::from_vulkan(
        props.api_version,
        &base_features,
        &f12,
        &f13,
        &subgroup,
        family.is_some(),
    );
    let missing = requirements::missing(&support);
    let timestamps = TimestampInfo {
        supported: family.is_some_and(|f| f.timestamp_valid_bits > 0)
            && props.limits.timestamp_compute_and_graphics == vk::TRUE,
        period_ns: props.limits.timestamp_period,
    };
    // SAFETY: as above.
    let memory = unsafe { instance.get_physical_device_memory_properties(pd) };
    let memory_heaps = memory.memory_heaps[..memory.memory_heap_count as usize]
        .iter()
        .map(|h| MemoryHeapInfo {
            size_bytes: h.size,
            device_local: h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL),
        })
        .collect();
    let DeviceIdentity {
        name, device_type, ..
    } = device_identity(instance, pd);
    DeviceInfo {
        index,
        name,
        vendor_id: props.vendor_id,
        device_type: match device_type {
            vk::PhysicalDeviceType::CPU => "cpu",
            vk::PhysicalDeviceType::DISCRETE_GPU => "discrete",
            vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated",
            vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual",
            _ => "other",
        }
        .to_string(),
        api_version: version_string(props.api_version),
        driver_name: c_string(&driver.driver_name),
        driver_info: c_string(&driver.driver_info),
        driver_version: props.driver_version,
        device_uuid: uuid_string(&id_props.device_uuid),
        device_id: props.device_id,
        pci_bus_id: has_pci.then(|| {
            format!(
                "{:04x}:{:02x}:{:02x}.{:x}",
                pci.pci_domain, pci.pci_bus, pci.pci_device, pci.pci_function
            )
        }),
        pipeline_cache_uuid: props
            .pipeline_cache_uuid
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect(),
        buffer_int64_atomics: f12.shader_buffer_int64_atomics == vk::TRUE,
        ray_query,
        bc7_textures,
        astc_4x4_textures,
        acceleration_structure,
        ray_tracing_pipeline: has_rtp,
        as_properties: acceleration_structure.then_some(AsProperties {
            max_geometry_count: as_props.max_geometry_count,
            max_instance_count: as_props.max_instance_count,
            max_primitive_count: as_props.max_primitive_count,
            min_scratch_offset_alignment: as_props
                .min_acceleration_structure_scratch_offset_alignment,
        }),
        subgroup_size: subgroup.subgroup_size,
        max_compute_workgroup_invocations: props.limits.max_compute_work_group_invocations,
        timestamps,
        memory_heaps,
        max_image_dimension_2d: props.limits.max_image_dimension2_d,
        max_push_constants_size: props.limits.max_push_constants_size,
        max_storage_buffer_range: props.limits.max_storage_buffer_range,
        max_memory_allocation_size: maintenance3.max_memory_allocation_size,
        max_sampled_image_array: [
            props.limits.max_per_stage_descriptor_samplers,
            props.limits.max_per_stage_descriptor_sampled_images,
            props.limits.max_descriptor_set_samplers,
            props.limits.max_descriptor_set_sampled_images,
        ]
        .into_iter()
        .min()
        .unwrap_or(0),
        missing_features: missing,
    }
}

/// Describes every physical device without opening any; `selector` picks `selected`.
pub fn describe_devices(selector: &DeviceSelector) -> VkResult<DeviceList> {
    let entry = load_entry()?;
    let (instance, _) = create_instance(&entry, false, false)?;
    // SAFETY: plain enumeration call on a live instance.
    let physicals =
        unsafe { instance.enumerate_physical_devices() }.call("vkEnumeratePhysicalDevices");
    let result = physicals.and_then(|physicals| {
        let names: Vec<_> = physicals
            .iter()
            .map(|&p| device_identity(&instance, p))
            .collect();
        let selected = select_device(&names, selector)?;
        let devices = physicals
            .iter()
            .enumerate()
            .map(|(i, &p)| describe_device(&instance, p, i))
            .collect();
        Ok(DeviceList { selected, devices })
    });
    // SAFETY: no device was created; nothing else uses the instance.
    unsafe { instance.destroy_instance(None) };
    result
}
