//! Which device a run uses and what `auto` picks on it, above the Vulkan layer (which only
//! reports what devices offer): the GPU a cluster scheduler assigned (this module), the
//! choices `auto` makes by measurement ([`autotune`]), and `rqr probe`'s report of both
//! ([`report`]).
//!
//! ## The GPU a cluster scheduler assigned
//!
//! Vulkan ignores `CUDA_VISIBLE_DEVICES`, which is how Slurm (`--gres=gpu`), Ray, Dask and
//! the NVIDIA container runtime (`NVIDIA_VISIBLE_DEVICES`) hand a GPU to a process; without
//! these rules every worker on an 8-GPU node would open the same first discrete GPU. When the
//! device selector is `auto`:
//!
//! 1. the first entry of `CUDA_VISIBLE_DEVICES`, else of `NVIDIA_VISIBLE_DEVICES`, picks the
//!    device: a UUID (`GPU-…`, matched against Vulkan's `deviceUUID`, which NVIDIA sets to the
//!    same value; a unique prefix is enough), or an index into the NVIDIA devices sorted by
//!    PCI bus id (`VK_EXT_pci_bus_info`; the order `nvidia-smi` and
//!    `CUDA_DEVICE_ORDER=PCI_BUS_ID` use);
//! 2. unset, `all`, or no NVIDIA device present (one warning): Vulkan's automatic choice;
//! 3. empty, `none`, `void` or `NoDevFiles` (no GPU assigned): one warning, automatic choice;
//! 4. an index out of range, an unknown UUID, a MIG instance or anything else: an error naming
//!    the variable (rendering on the wrong GPU is worse than not rendering).
//!
//! An explicit `--device` always wins. The device list is passed in, so the rules are
//! testable without GPUs.

pub mod autotune;
pub mod report;

use crate::vk::{DeviceInfo, DeviceSelector};

/// PCI vendor id of NVIDIA.
pub const NVIDIA_VENDOR_ID: u32 = 0x10de;

/// The variables read, in order.
pub const VISIBLE_DEVICES_VARS: [&str; 2] = ["CUDA_VISIBLE_DEVICES", "NVIDIA_VISIBLE_DEVICES"];

/// What [`choose`] decided.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Choice {
    /// The selector to open.
    pub selector: DeviceSelector,
    /// Why (for the log).
    pub reason: String,
    /// A warning to print once (the variable was set but could not be used).
    pub warning: Option<String>,
}

/// A variable that names no usable device.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct SelectError(pub String);

/// Applies the rules of this module to `requested` (the `--device` value), reading variables
/// through `env` and matching against `devices` (as `rqr probe` lists them).
pub fn choose(
    requested: &DeviceSelector,
    env: &dyn Fn(&str) -> Option<String>,
    devices: &[DeviceInfo],
) -> Result<Choice, SelectError> {
    let keep = |reason: &str, warning: Option<String>| Choice {
        selector: requested.clone(),
        reason: reason.to_string(),
        warning,
    };
    if *requested != DeviceSelector::Auto {
        return Ok(keep("--device", None));
    }
    let Some((var, value)) = VISIBLE_DEVICES_VARS
        .iter()
        .find_map(|v| env(v).map(|value| (*v, value)))
    else {
        return Ok(keep("automatic (no visible-devices variable)", None));
    };
    let first = value.split(',').next().unwrap_or("").trim();
    if first.eq_ignore_ascii_case("all") {
        return Ok(keep(&format!("automatic ({var}=all)"), None));
    }
    if first.is_empty()
        || ["none", "void", "NoDevFiles"]
            .iter()
            .any(|n| first.eq_ignore_ascii_case(n))
    {
        return Ok(keep(
            "automatic",
            Some(format!(
                "{var}='{value}' assigns no GPU; using Vulkan's automatic device choice"
            )),
        ));
    }
    let mut nvidia: Vec<&DeviceInfo> = devices
        .iter()
        .filter(|d| d.vendor_id == NVIDIA_VENDOR_ID)
        .collect();
    if nvidia.is_empty() {
        return Ok(keep(
            "automatic",
            Some(format!("{var}={value} is set but no NVIDIA Vulkan device is present; using Vulkan's automatic device choice")),
        ));
    }
    if first.starts_with("MIG-") {
        return Err(SelectError(format!(
            "{var}={value}: MIG instances are not Vulkan devices; assign a whole GPU or pass --device uuid:GPU-…"
        )));
    }
    if let Ok(index) = first.parse::<usize>() {
        // nvidia-smi's order: PCI bus id; devices without one after, in enumeration order.
        nvidia.sort_by(|a, b| {
            (a.pci_bus_id.is_none(), &a.pci_bus_id, a.index).cmp(&(
                b.pci_bus_id.is_none(),
                &b.pci_bus_id,
                b.index,
            ))
        });
        let Some(d) = nvidia.get(index) else {
            return Err(SelectError(format!(
                "{var}={value}: index {index}, but there are {} NVIDIA Vulkan device(s) (indices follow PCI bus order, as in nvidia-smi)",
                nvidia.len()
            )));
        };
        return Ok(Choice {
            selector: DeviceSelector::Uuid(d.device_uuid.clone()),
            reason: format!(
                "{var}={value}: NVIDIA device {index} in PCI bus order ({}, {})",
                d.pci_bus_id.as_deref().unwrap_or("no PCI bus id"),
                d.name
            ),
            warning: None,
        });
    }
    let want = crate::vk::normalize_uuid(first);
    let looks_like_uuid =
        first.starts_with("GPU-") && want.len() >= 4 && want.chars().all(|c| c.is_ascii_hexdigit());
    if !looks_like_uuid {
        return Err(SelectError(format!(
            "{var}={value}: the first entry '{first}' is neither a device index nor a GPU-… UUID"
        )));
    }
    let hits: Vec<&&DeviceInfo> = nvidia
        .iter()
        .filter(|d| crate::vk::normalize_uuid(&d.device_uuid).starts_with(&want))
        .collect();
    match hits.as_slice() {
        [d] => Ok(Choice {
            selector: DeviceSelector::Uuid(d.device_uuid.clone()),
            reason: format!("{var}={value}: {} ({})", d.name, d.device_uuid),
            warning: None,
        }),
        [] => Err(SelectError(format!(
            "{var}={value}: no Vulkan device has UUID {first} (devices: {})",
            nvidia
                .iter()
                .map(|d| format!("GPU-{}", d.device_uuid))
                .collect::<Vec<_>>()
                .join(", ")
        ))),
        _ => Err(SelectError(format!(
            "{var}={value}: UUID prefix {first} matches several devices"
        ))),
    }
}

/// [`choose`] on this process's environment and devices: lists the devices only when a
/// variable is set and `requested` is `auto`; logs the warning once.
pub fn resolve(
    requested: &DeviceSelector,
) -> Result<DeviceSelector, Box<dyn std::error::Error + Send + Sync>> {
    let env = |name: &str| std::env::var(name).ok();
    if *requested != DeviceSelector::Auto || VISIBLE_DEVICES_VARS.iter().all(|v| env(v).is_none()) {
        return Ok(requested.clone());
    }
    let list = crate::vk::describe_devices(&DeviceSelector::Auto)?;
    let choice = choose(requested, &env, &list.devices)?;
    if let Some(w) = &choice.warning {
        log::warn!("{w}");
    }
    log::info!("device: {}", choice.reason);
    Ok(choice.selector)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// Two NVIDIA GPUs enumerated in the opposite order of their PCI bus ids, and lavapipe.
    fn node() -> Vec<DeviceInfo> {
        let base = DeviceInfo::default();
        let gpu = |index: usize, uuid: &str, pci: &str| DeviceInfo {
            index,
            name: format!("NVIDIA H200 ({pci})"),
            vendor_id: NVIDIA_VENDOR_ID,
            device_uuid: uuid.into(),
            pci_bus_id: Some(pci.into()),
            ..base.clone()
        };
        vec![
            gpu(0, "bbbbbbbb-0000-0000-0000-000000000002", "0000:b3:00.0"),
            gpu(1, "aaaaaaaa-0000-0000-0000-000000000001", "0000:1b:00.0"),
            DeviceInfo {
                index: 2,
                vendor_id: 0x10005,
                pci_bus_id: None,
                ..base
            },
        ]
    }

    fn with(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let map: HashMap<String, String> = pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        move |k| map.get(k).cloned()
    }

    fn pick(pairs: &[(&str, &str)], devices: &[DeviceInfo]) -> Result<Choice, SelectError> {
        choose(&DeviceSelector::Auto, &with(pairs), devices)
    }

    #[test]
    fn an_index_counts_nvidia_devices_in_pci_bus_order() {
        let c = pick(&[("CUDA_VISIBLE_DEVICES", "0,1")], &node()).unwrap();
        assert_eq!(
            c.selector,
            DeviceSelector::Uuid("aaaaaaaa-0000-0000-0000-000000000001".into())
        );
        assert!(c.reason.contains("0000:1b:00.0"), "{}", c.reason);
        let c = pick(&[("CUDA_VISIBLE_DEVICES", "1")], &node()).unwrap();
        assert_eq!(
            c.selector,
            DeviceSelector::Uuid("bbbbbbbb-0000-0000-0000-000000000002".into())
        );
        let e = pick(&[("CUDA_VISIBLE_DEVICES", "2")], &node()).unwrap_err();
        assert!(e.0.contains("there are 2 NVIDIA"), "{e}");
    }

    #[test]
    fn a_uuid_picks_its_device() {
        let c = pick(
            &[(
                "CUDA_VISIBLE_DEVICES",
                "GPU-bbbbbbbb-0000-0000-0000-000000000002",
            )],
            &node(),
        )
        .unwrap();
        assert_eq!(
            c.selector,
            DeviceSelector::Uuid("bbbbbbbb-0000-0000-0000-000000000002".into())
        );
        // A prefix, as CUDA accepts, and NVIDIA_VISIBLE_DEVICES when CUDA's is unset.
        let c = pick(&[("NVIDIA_VISIBLE_DEVICES", "GPU-aaaa")], &node()).unwrap();
        assert_eq!(
            c.selector,
            DeviceSelector::Uuid("aaaaaaaa-0000-0000-0000-000000000001".into())
        );
        let e = pick(&[("CUDA_VISIBLE_DEVICES", "GPU-cccccccc")], &node()).unwrap_err();
        assert!(
            e.0.contains("no Vulkan device has UUID GPU-cccccccc"),
            "{e}"
        );
        assert!(pick(&[("CUDA_VISIBLE_DEVICES", "MIG-aaaa")], &node()).is_err());
    }

    #[test]
    fn cuda_visible_devices_wins_and_device_flag_wins_over_both() {
        let env = [
            ("CUDA_VISIBLE_DEVICES", "1"),
            ("NVIDIA_VISIBLE_DEVICES", "0"),
        ];
        let c = pick(&env, &node()).unwrap();
        assert_eq!(
            c.selector,
            DeviceSelector::Uuid("bbbbbbbb-0000-0000-0000-000000000002".into())
        );
        let c = choose(&DeviceSelector::Index(2), &with(&env), &node()).unwrap();
        assert_eq!(c.selector, DeviceSelector::Index(2));
    }

    #[test]
    fn empty_unset_and_all_fall_back_to_automatic() {
        let c = pick(&[("CUDA_VISIBLE_DEVICES", "")], &node()).unwrap();
        assert_eq!(c.selector, DeviceSelector::Auto);
        assert!(c.warning.unwrap().contains("assigns no GPU"));
        let c = pick(&[("NVIDIA_VISIBLE_DEVICES", "void")], &node()).unwrap();
        assert!(c.warning.is_some());
        let c = pick(&[], &node()).unwrap();
        assert_eq!((c.selector, c.warning), (DeviceSelector::Auto, None));
        let c = pick(&[("NVIDIA_VISIBLE_DEVICES", "all")], &node()).unwrap();
        assert_eq!((c.selector, c.warning), (DeviceSelector::Auto, None));
    }

    #[test]
    fn garbage_is_an_error_and_no_nvidia_device_is_one_warning() {
        let e = pick(&[("CUDA_VISIBLE_DEVICES", "banana")], &node()).unwrap_err();
        assert!(
            e.0.contains("CUDA_VISIBLE_DEVICES=banana") && e.0.contains("neither"),
            "{e}"
        );
        assert!(pick(&[("CUDA_VISIBLE_DEVICES", "-1")], &node()).is_err());
        let lavapipe_only = vec![node().pop().unwrap()];
        for value in ["0", "GPU-aaaa", "banana"] {
            let c = pick(&[("CUDA_VISIBLE_DEVICES", value)], &lavapipe_only).unwrap();
            assert_eq!(c.selector, DeviceSelector::Auto);
            assert!(c.warning.unwrap().contains("no NVIDIA Vulkan device"));
        }
    }
}
