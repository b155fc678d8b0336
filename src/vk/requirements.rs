//! What rqr requires of a device: one table that `rqr probe` reports and
//! [`super::Context::new`] enforces, so the probe cannot approve a device that opening then
//! refuses.
//!
//! [`DeviceSupport`] is a plain copy of the device's answers (filled from Vulkan by the probe,
//! or built by hand in tests); [`REQUIREMENTS`] names each need and says how to read it;
//! [`missing`] lists what a device lacks, in table order.

use ash::vk;

/// A device's answers to everything [`REQUIREMENTS`] asks: plain booleans, so the table's logic
/// can be tested with any combination.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DeviceSupport {
    /// `apiVersion` of the device.
    pub api_version: u32,
    /// `bufferDeviceAddress`.
    pub buffer_device_address: bool,
    /// `descriptorIndexing`.
    pub descriptor_indexing: bool,
    /// `runtimeDescriptorArray`.
    pub runtime_descriptor_array: bool,
    /// `descriptorBindingPartiallyBound`.
    pub descriptor_binding_partially_bound: bool,
    /// `shaderSampledImageArrayNonUniformIndexing` (the bindless texture array).
    pub sampled_image_array_non_uniform_indexing: bool,
    /// `scalarBlockLayout`.
    pub scalar_block_layout: bool,
    /// `timelineSemaphore`.
    pub timeline_semaphore: bool,
    /// `dynamicRendering`.
    pub dynamic_rendering: bool,
    /// `synchronization2`.
    pub synchronization2: bool,
    /// `shaderInt64`.
    pub shader_int64: bool,
    /// Subgroup basic, arithmetic and ballot operations in compute shaders.
    pub compute_subgroup_ops: bool,
    /// A queue family with graphics and compute.
    pub graphics_compute_queue: bool,
}

impl DeviceSupport {
    /// Everything [`REQUIREMENTS`] asks for (a device rqr runs on).
    pub fn complete() -> Self {
        Self {
            api_version: vk::API_VERSION_1_3,
            buffer_device_address: true,
            descriptor_indexing: true,
            runtime_descriptor_array: true,
            descriptor_binding_partially_bound: true,
            sampled_image_array_non_uniform_indexing: true,
            scalar_block_layout: true,
            timeline_semaphore: true,
            dynamic_rendering: true,
            synchronization2: true,
            shader_int64: true,
            compute_subgroup_ops: true,
            graphics_compute_queue: true,
        }
    }

    /// Reads the answers from the feature structs, the subgroup properties and the queue
    /// families the probe queried.
    pub fn from_vulkan(
        api_version: u32,
        base: &vk::PhysicalDeviceFeatures,
        f12: &vk::PhysicalDeviceVulkan12Features<'_>,
        f13: &vk::PhysicalDeviceVulkan13Features<'_>,
        subgroup: &vk::PhysicalDeviceSubgroupProperties<'_>,
        graphics_compute_queue: bool,
    ) -> Self {
        let on = |b: vk::Bool32| b == vk::TRUE;
        // Ray and sample counters are summed per subgroup before one atomic per subgroup
        // (shaders/common/counters.glsl); reprojection's job lists are compacted per subgroup
        // (shaders/temporal/job_lists.glsl: prefix sums and a broadcast), and frameless rendering counts
        // its candidates per row segment (clustered sums).
        let subgroup_ops = vk::SubgroupFeatureFlags::BASIC
            | vk::SubgroupFeatureFlags::ARITHMETIC
            | vk::SubgroupFeatureFlags::BALLOT
            | vk::SubgroupFeatureFlags::CLUSTERED;
        Self {
            api_version,
            buffer_device_address: on(f12.buffer_device_address),
            descriptor_indexing: on(f12.descriptor_indexing),
            runtime_descriptor_array: on(f12.runtime_descriptor_array),
            descriptor_binding_partially_bound: on(f12.descriptor_binding_partially_bound),
            sampled_image_array_non_uniform_indexing: on(
                f12.shader_sampled_image_array_non_uniform_indexing
            ),
            scalar_block_layout: on(f12.scalar_block_layout),
            timeline_semaphore: on(f12.timeline_semaphore),
            dynamic_rendering: on(f13.dynamic_rendering),
            synchronization2: on(f13.synchronization2),
            shader_int64: on(base.shader_int64),
            compute_subgroup_ops: subgroup
                .supported_stages
                .contains(vk::ShaderStageFlags::COMPUTE)
                && subgroup.supported_operations.contains(subgroup_ops),
            graphics_compute_queue,
        }
    }
}

/// One thing rqr cannot run without.
#[derive(Clone, Copy)]
pub struct Requirement {
    /// The name reported by `rqr probe` and in [`super::VkError::MissingFeature`].
    pub name: &'static str,
    /// Whether a device meets it.
    pub met: fn(&DeviceSupport) -> bool,
}

/// Everything rqr requires, in the order reports list it. [`super::Context`] enables each of
/// these features when it creates the device.
pub const REQUIREMENTS: &[Requirement] = &[
    Requirement {
        name: "Vulkan 1.3",
        met: |s| s.api_version >= vk::API_VERSION_1_3,
    },
    Requirement {
        name: "bufferDeviceAddress",
        met: |s| s.buffer_device_address,
    },
    Requirement {
        name: "descriptorIndexing",
        met: |s| s.descriptor_indexing,
    },
    Requirement {
        name: "runtimeDescriptorArray",
        met: |s| s.runtime_descriptor_array,
    },
    Requirement {
        name: "descriptorBindingPartiallyBound",
        met: |s| s.descriptor_binding_partially_bound,
    },
    Requirement {
        name: "shaderSampledImageArrayNonUniformIndexing",
        met: |s| s.sampled_image_array_non_uniform_indexing,
    },
    Requirement {
        name: "scalarBlockLayout",
        met: |s| s.scalar_block_layout,
    },
    Requirement {
        name: "timelineSemaphore",
        met: |s| s.timeline_semaphore,
    },
    Requirement {
        name: "dynamicRendering",
        met: |s| s.dynamic_rendering,
    },
    Requirement {
        name: "synchronization2",
        met: |s| s.synchronization2,
    },
    Requirement {
        name: "shaderInt64",
        met: |s| s.shader_int64,
    },
    Requirement {
        name: "subgroup arithmetic and ballot in compute shaders",
        met: |s| s.compute_subgroup_ops,
    },
    Requirement {
        name: "a graphics+compute queue",
        met: |s| s.graphics_compute_queue,
    },
];

/// The names of the requirements `support` does not meet, in table order (empty: rqr runs).
pub fn missing(support: &DeviceSupport) -> Vec<String> {
    REQUIREMENTS
        .iter()
        .filter(|r| !(r.met)(support))
        .map(|r| r.name.to_string())
        .collect()
}

/// What [`super::Context::new`] does with a device's [`missing`] list: `Ok` when empty, else
/// [`super::VkError::MissingFeature`] naming every missing requirement (comma-separated).
pub fn check(device: &str, missing: &[String]) -> super::VkResult<()> {
    if missing.is_empty() {
        Ok(())
    } else {
        Err(super::VkError::MissingFeature {
            device: device.to_string(),
            feature: missing.join(", "),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_complete_device_meets_every_requirement() {
        assert!(missing(&DeviceSupport::complete()).is_empty());
        assert!(check("dev", &missing(&DeviceSupport::complete())).is_ok());
    }

    /// Every requirement, taken away alone, is the one the probe reports and the one opening
    /// refuses with.
    #[test]
    fn each_requirement_alone_is_reported_and_refused_by_name() {
        let complete = DeviceSupport::complete();
        let mut toggles: Vec<(&str, DeviceSupport)> = Vec::new();
        let mut with = |name, f: fn(&mut DeviceSupport)| {
            let mut s = complete;
            f(&mut s);
            toggles.push((name, s));
        };
        with("Vulkan 1.3", |s| s.api_version = vk::API_VERSION_1_2);
        with("bufferDeviceAddress", |s| s.buffer_device_address = false);
        with("descriptorIndexing", |s| s.descriptor_indexing = false);
        with("runtimeDescriptorArray", |s| {
            s.runtime_descriptor_array = false
        });
        with("descriptorBindingPartiallyBound", |s| {
            s.descriptor_binding_partially_bound = false
        });
        with("shaderSampledImageArrayNonUniformIndexing", |s| {
            s.sampled_image_array_non_uniform_indexing = false
        });
        with("scalarBlockLayout", |s| s.scalar_block_layout = false);
        with("timelineSemaphore", |s| s.timeline_semaphore = false);
        with("dynamicRendering", |s| s.dynamic_rendering = false);
        with("synchronization2", |s| s.synchronization2 = false);
        with("shaderInt64", |s| s.shader_int64 = false);
        with("subgroup arithmetic and ballot in compute shaders", |s| {
            s.compute_subgroup_ops = false
        });
        with("a graphics+compute queue", |s| {
            s.graphics_compute_queue = false
        });
        assert_eq!(
            toggles.len(),
            REQUIREMENTS.len(),
            "a requirement has no case here"
        );
        for (name, support) in toggles {
            let reported = missing(&support);
            assert_eq!(reported, [name]);
            let refused = check("dev", &reported).unwrap_err().to_string();
            assert_eq!(
                refused,
                format!("device 'dev' lacks {name}, which rqr needs")
            );
        }
    }

    #[test]
    fn several_missing_requirements_are_all_named_in_table_order() {
        let support = DeviceSupport {
            scalar_block_layout: false,
            buffer_device_address: false,
            ..DeviceSupport::complete()
        };
        let reported = missing(&support);
        assert_eq!(reported, ["bufferDeviceAddress", "scalarBlockLayout"]);
        let refused = check("dev", &reported).unwrap_err().to_string();
        assert!(
            refused.contains("bufferDeviceAddress, scalarBlockLayout"),
            "{refused}"
        );
    }
}
