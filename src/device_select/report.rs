//! `rqr probe`'s report: every device's raw capabilities ([`crate::vk::DeviceInfo`]) with what
//! rqr would choose on it: the ray backend a [`BackendChoice`] resolves to, and what `auto`
//! picks for the visibility pass and the texture format, with the autotune numbers behind it.

use serde::Serialize;

use super::autotune::Measurement;
use crate::accel::BackendChoice;
use crate::vk::{describe_devices, DeviceInfo, DeviceSelector, VkResult};

/// One device of the report: its capabilities, then rqr's choices on it.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct DeviceReport {
    /// What the device offers (its fields are this record's first fields in JSON).
    #[serde(flatten)]
    pub device: DeviceInfo,
    /// Ray backend rqr would use (`hw` or `bvh`); `null` when the requested one is unavailable.
    pub backend: Option<String>,
    /// Why that backend.
    pub backend_reason: String,
    /// What runs the hybrid visibility pass (`graphics` or `compute`) under `--raster auto`.
    pub raster: String,
    /// Why that visibility pass.
    pub raster_reason: String,
    /// How KTX2 textures upload under `--texture-format auto` (`block` or `rgba8`).
    pub texture_format: String,
    /// Why that format.
    pub texture_format_reason: String,
    /// The autotune numbers behind `backend`/`raster`/`texture_format` (`null`: the feature
    /// rule decided).
    pub autotune: Option<Measurement>,
}

impl std::ops::Deref for DeviceReport {
    type Target = DeviceInfo;

    fn deref(&self) -> &DeviceInfo {
        &self.device
    }
}

impl DeviceReport {
    /// `device` with the ray backend `backend` resolves to on it, and the feature rules for
    /// the visibility pass and the texture format (no measurement).
    pub fn new(device: DeviceInfo, backend: BackendChoice) -> Self {
        let (backend, backend_reason) = match backend.resolve(&device) {
            Ok((b, reason)) => (Some(b.as_str().to_string()), reason),
            Err(why) => (None, why.to_string()),
        };
        Self {
            device,
            backend,
            backend_reason,
            raster: "graphics".into(),
            raster_reason: "auto (feature rule): graphics pipeline".into(),
            texture_format: "block".into(),
            texture_format_reason: "auto (feature rule): the device's block format".into(),
            autotune: None,
        }
    }
}

/// The `rqr probe --json` document.
#[derive(Clone, Debug, Serialize)]
pub struct ProbeReport {
    /// Schema version of this document.
    pub schema: u32,
    /// Index of the device rqr would open with the given selector.
    pub selected: Option<usize>,
    /// Every physical device.
    pub devices: Vec<DeviceReport>,
}

/// Describes every physical device without opening any, each with the backend `backend`
/// resolves to; `selector` picks `selected`.
pub fn probe_devices(selector: &DeviceSelector, backend: BackendChoice) -> VkResult<ProbeReport> {
    let list = describe_devices(selector)?;
    Ok(ProbeReport {
        schema: 1,
        selected: Some(list.selected),
        devices: list
            .devices
            .into_iter()
            .map(|d| DeviceReport::new(d, backend))
            .collect(),
    })
}
