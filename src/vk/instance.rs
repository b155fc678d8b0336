//! Instance creation and physical-device enumeration and selection: what both the probe
//! ([`super::probe`]) and [`super::Context`] need before a device is open.

use std::ffi::{CStr, CString};

use ash::{ext, vk};

use super::{CallExt, VkError, VkResult};

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// Which physical device to use.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum DeviceSelector {
    /// discrete > integrated > virtual > CPU > other, first of each kind.
    #[default]
    Auto,
    /// Index into the enumeration order (as `rqr probe` lists it).
    Index(usize),
    /// Case-insensitive substring of the device name.
    Name(String),
    /// `deviceUUID` (`uuid:GPU-…` or `uuid:…` on the command line: the CUDA / NVML UUID on
    /// NVIDIA; dashes and a `GPU-` prefix are ignored, a unique prefix is enough).
    Uuid(String),
}

/// What [`select_device`] knows of a physical device.
#[derive(Clone, Debug)]
pub(crate) struct DeviceIdentity {
    pub(crate) name: String,
    pub(crate) device_type: vk::PhysicalDeviceType,
    pub(crate) uuid: String,
}

/// A UUID reduced to lowercase hex digits: `GPU-` prefix and dashes dropped.
pub fn normalize_uuid(uuid: &str) -> String {
    let u = uuid.trim();
    let u = u
        .strip_prefix("GPU-")
        .or_else(|| u.strip_prefix("gpu-"))
        .unwrap_or(u);
    u.chars()
        .filter(|c| *c != '-')
        .collect::<String>()
        .to_lowercase()
}

impl std::str::FromStr for DeviceSelector {
    type Err = std::convert::Infallible;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(if s.eq_ignore_ascii_case("auto") {
            Self::Auto
        } else if let Some(uuid) = s.strip_prefix("uuid:") {
            Self::Uuid(uuid.to_string())
        } else if let Ok(i) = s.parse() {
            Self::Index(i)
        } else {
            Self::Name(s.to_string())
        })
    }
}

impl std::fmt::Display for DeviceSelector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Auto => write!(f, "auto"),
            Self::Index(i) => write!(f, "{i}"),
            Self::Name(n) => write!(f, "{n}"),
            Self::Uuid(u) => write!(f, "uuid:{u}"),
        }
    }
}

pub(crate) fn load_entry() -> VkResult<ash::Entry> {
    // SAFETY: loading the system Vulkan loader; no Vulkan calls are in flight.
    unsafe { ash::Entry::load() }.map_err(|e| VkError::Loader(e.to_string()))
}

/// Whether the Khronos validation layer is installed.
pub fn validation_layer_available(entry: &ash::Entry) -> bool {
    // SAFETY: plain enumeration call.
    unsafe { entry.enumerate_instance_layer_properties() }
        .map(|layers| {
            layers
                .iter()
                .any(|l| l.layer_name_as_c_str().ok() == Some(VALIDATION_LAYER))
        })
        .unwrap_or(false)
}

/// Whether the validation layer provides instance extension `name` (`VK_EXT_validation_features`
/// comes with the layer, not with the loader).
fn layer_has_extension(entry: &ash::Entry, name: &CStr) -> bool {
    // SAFETY: plain enumeration call with a NUL-terminated layer name.
    unsafe { entry.enumerate_instance_extension_properties(Some(VALIDATION_LAYER)) }
        .map(|exts| {
            exts.iter()
                .any(|e| e.extension_name_as_c_str().ok() == Some(name))
        })
        .unwrap_or(false)
}

/// Creates the instance; `sync` adds synchronization validation to `validation`. Returns
/// whether validation is active.
pub(crate) fn create_instance(
    entry: &ash::Entry,
    validation: bool,
    sync: bool,
) -> VkResult<(ash::Instance, bool)> {
    let app_name = CString::new("rqr").unwrap();
    let app = vk::ApplicationInfo::default()
        .application_name(&app_name)
        .application_version(1)
        .engine_name(&app_name)
        .api_version(vk::API_VERSION_1_3);
    let available_ext: Vec<CString> =
        // SAFETY: plain enumeration call.
        unsafe { entry.enumerate_instance_extension_properties(None) }
            .call("vkEnumerateInstanceExtensionProperties")?
            .iter()
            .filter_map(|e| e.extension_name_as_c_str().ok().map(CStr::to_owned))
            .collect();
    let has_utils = available_ext
        .iter()
        .any(|e| e.as_c_str() == ext::debug_utils::NAME);
    let mut extensions = Vec::new();
    if has_utils {
        extensions.push(ext::debug_utils::NAME.as_ptr());
    }
    let use_validation = validation && validation_layer_available(entry);
    if validation && !use_validation {
        log::warn!("validation requested but VK_LAYER_KHRONOS_validation is not installed (apt install vulkan-validationlayers)");
    }
    let layers = if use_validation {
        vec![VALIDATION_LAYER.as_ptr()]
    } else {
        vec![]
    };
    let sync_validation =
        use_validation && sync && layer_has_extension(entry, ext::validation_features::NAME);
    if sync && !sync_validation {
        log::warn!("synchronization validation requested but unavailable (needs the validation layer with VK_EXT_validation_features)");
    }
    if sync_validation {
        extensions.push(ext::validation_features::NAME.as_ptr());
    }
    let enables = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
    let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&enables);
    let mut info = vk::InstanceCreateInfo::default()
        .application_info(&app)
        .enabled_extension_names(&extensions)
        .enabled_layer_names(&layers);
    if sync_validation {
        info = info.push_next(&mut features);
    }
    log::debug!("synchronization validation: {sync_validation}");
    // SAFETY: all pointers in `info` point to locals alive for this call.
    let instance =
        unsafe { entry.create_instance(&info, None) }.map_err(|result| match result {
            vk::Result::ERROR_INCOMPATIBLE_DRIVER => VkError::NoDevice,
            result => VkError::Call {
                call: "vkCreateInstance",
                result,
            },
        })?;
    Ok((instance, use_validation && has_utils))
}

/// Orders devices for automatic selection: lower is better.
fn type_rank(t: vk::PhysicalDeviceType) -> u32 {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    }
}

/// Picks a device index.
pub(crate) fn select_device(
    devices: &[DeviceIdentity],
    selector: &DeviceSelector,
) -> VkResult<usize> {
    if devices.is_empty() {
        return Err(VkError::NoDevice);
    }
    let found = match selector {
        DeviceSelector::Auto => {
            (0..devices.len()).min_by_key(|&i| (type_rank(devices[i].device_type), i))
        }
        DeviceSelector::Index(i) => (*i < devices.len()).then_some(*i),
        DeviceSelector::Name(n) => {
            let n = n.to_lowercase();
            devices
                .iter()
                .position(|d| d.name.to_lowercase().contains(&n))
        }
        DeviceSelector::Uuid(u) => {
            let want = normalize_uuid(u);
            let hits: Vec<usize> = (0..devices.len())
                .filter(|&i| {
                    !want.is_empty() && normalize_uuid(&devices[i].uuid).starts_with(&want)
                })
                .collect();
            match hits.as_slice() {
                [one] => Some(*one),
                _ => None,
            }
        }
    };
    found.ok_or_else(|| VkError::NoMatchingDevice {
        selector: selector.to_string(),
        available: devices
            .iter()
            .enumerate()
            .map(|(i, d)| format!("{i}: {} (uuid {})", d.name, d.uuid))
            .collect::<Vec<_>>()
            .join(", "),
    })
}

pub(crate) fn device_identity(instance: &ash::Instance, pd: vk::PhysicalDevice) -> DeviceIdentity {
    let mut id = vk::PhysicalDeviceIDProperties::default();
    let props = {
        let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut id);
        // SAFETY: `pd` comes from this instance (Vulkan 1.1+: the ID properties are core).
        unsafe { instance.get_physical_device_properties2(pd, &mut props2) };
        props2.properties
    };
    let name = props
        .device_name_as_c_str()
        .map(|c| c.to_string_lossy().into_owned())
        .unwrap_or_default();
    DeviceIdentity {
        name,
        device_type: props.device_type,
        uuid: super::probe::uuid_string(&id.device_uuid),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn devices() -> Vec<DeviceIdentity> {
        [
            (
                "llvmpipe",
                vk::PhysicalDeviceType::CPU,
                "6c6c766d-7069-7065-5555-494400000000",
            ),
            (
                "NVIDIA H200",
                vk::PhysicalDeviceType::DISCRETE_GPU,
                "8932f937-d72c-4106-c12f-20bd9faed9f6",
            ),
            (
                "NVIDIA H200",
                vk::PhysicalDeviceType::DISCRETE_GPU,
                "8932aaaa-d72c-4106-c12f-20bd9faed9f6",
            ),
        ]
        .into_iter()
        .map(|(n, t, u)| DeviceIdentity {
            name: n.into(),
            device_type: t,
            uuid: u.into(),
        })
        .collect()
    }

    #[test]
    fn uuid_selectors_take_nvml_form_and_unique_prefixes() {
        let d = devices();
        let pick = |s: &str| select_device(&d, &s.parse().unwrap());
        assert_eq!(
            pick("uuid:GPU-8932f937-d72c-4106-c12f-20bd9faed9f6").unwrap(),
            1
        );
        assert_eq!(pick("uuid:8932AAAAD72C").unwrap(), 2);
        assert_eq!(pick("uuid:GPU-8932f937").unwrap(), 1);
        // Ambiguous and unknown prefixes match nothing, listing the UUIDs.
        let e = pick("uuid:GPU-8932").unwrap_err().to_string();
        assert!(e.contains("8932f937-d72c"), "{e}");
        assert!(pick("uuid:GPU-ffff").is_err());
        assert!(pick("uuid:").is_err());
        assert_eq!(pick("auto").unwrap(), 1);
        assert_eq!(
            "uuid:GPU-1".parse::<DeviceSelector>().unwrap().to_string(),
            "uuid:GPU-1"
        );
    }
}
