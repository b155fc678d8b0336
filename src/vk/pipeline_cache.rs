//! The on-disk `VkPipelineCache`: pipelines compiled by one process are reused by the next
//! (and, through a shared directory, by every process of a fleet with the same GPU and driver).
//!
//! One file per device and driver: `pipelines-<vendor>-<device>-<driver version>-<pipeline
//! cache UUID>.bin`, holding a checksummed envelope around the driver's cache data. The
//! driver's own header (vendor, device, `pipelineCacheUUID`) is checked against the device
//! before the data reaches the driver; a file that fails any check is reported with one
//! warning and the cache starts empty (and is rewritten when the context closes). Writes go
//! to a temporary file renamed over the old one, so a reader never sees half a file.

use std::path::{Path, PathBuf};

use ash::vk;

use super::probe::DeviceInfo;
use super::{CallExt, VkResult};

/// Envelope magic and version.
const MAGIC: &[u8; 8] = b"RQRPIPE1";
/// Envelope header: magic, payload length, payload FNV-1a 64.
const ENVELOPE_BYTES: usize = 8 + 8 + 8;
/// `VkPipelineCacheHeaderVersionOne`: header size, version, vendor, device, UUID.
const VK_HEADER_BYTES: usize = 16 + vk::UUID_SIZE;

/// FNV-1a 64 over `bytes`: catches truncation and bit rot (not an adversary).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// The cache file of `device` in `dir`.
pub fn cache_file(dir: &Path, device: &DeviceInfo) -> PathBuf {
    dir.join(format!(
        "pipelines-{:04x}-{:04x}-{:08x}-{}.bin",
        device.vendor_id, device.device_id, device.driver_version, device.pipeline_cache_uuid
    ))
}

/// Wraps the driver's cache data in the envelope.
pub fn encode(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(ENVELOPE_BYTES + data.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&(data.len() as u64).to_le_bytes());
    out.extend_from_slice(&fnv1a(data).to_le_bytes());
    out.extend_from_slice(data);
    out
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

/// Checks a cache file's bytes for `device`; returns the driver data, or why it is unusable.
pub fn decode<'a>(file: &'a [u8], device: &DeviceInfo) -> Result<&'a [u8], String> {
    if file.len() < ENVELOPE_BYTES || &file[..8] != MAGIC {
        return Err("not an rqr pipeline cache".into());
    }
    let len = u64::from_le_bytes(file[8..16].try_into().unwrap_or_default());
    let sum = u64::from_le_bytes(file[16..24].try_into().unwrap_or_default());
    let data = &file[ENVELOPE_BYTES..];
    if data.len() as u64 != len {
        return Err(format!("truncated: {} of {len} bytes", data.len()));
    }
    if fnv1a(data) != sum {
        return Err("checksum mismatch".into());
    }
    if data.len() < VK_HEADER_BYTES {
        return Err("shorter than the Vulkan pipeline cache header".into());
    }
    let (size, version) = (u32_at(data, 0), u32_at(data, 4));
    if size as usize != VK_HEADER_BYTES
        || version != vk::PipelineCacheHeaderVersion::ONE.as_raw() as u32
    {
        return Err(format!(
            "unknown Vulkan header (size {size}, version {version})"
        ));
    }
    let (vendor, device_id) = (u32_at(data, 8), u32_at(data, 12));
    let uuid: String = data[16..VK_HEADER_BYTES]
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    if vendor != device.vendor_id
        || device_id != device.device_id
        || uuid != device.pipeline_cache_uuid
    {
        return Err(format!(
            "written for another device or driver (vendor {vendor:#x}, device {device_id:#x}, cache UUID {uuid})"
        ));
    }
    Ok(data)
}

/// Writes `bytes` to `path` through a temporary file in the same directory and a rename.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)?;
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let temp = path.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
    let written = std::fs::write(&temp, bytes).and_then(|()| std::fs::rename(&temp, path));
    if written.is_err() {
        let _ = std::fs::remove_file(&temp);
    }
    written
}

/// Creates a pipeline cache, seeded from `path` when it holds a valid cache for `device`.
/// Returns the handle and the checksum of the data loaded (`None`: started empty).
pub(crate) fn create(
    device: &ash::Device,
    info: &DeviceInfo,
    path: Option<&Path>,
) -> VkResult<(vk::PipelineCache, Option<u64>)> {
    let file = path.and_then(|p| match std::fs::read(p) {
        Ok(bytes) => Some((p, bytes)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => {
            log::warn!(
                "cannot read the pipeline cache '{}': {e}; starting empty",
                p.display()
            );
            None
        }
    });
    let data = match &file {
        Some((p, bytes)) => match decode(bytes, info) {
            Ok(d) => Some(d),
            Err(why) => {
                log::warn!(
                    "pipeline cache '{}' is unusable ({why}); rebuilding it",
                    p.display()
                );
                None
            }
        },
        None => None,
    };
    let create_info = vk::PipelineCacheCreateInfo::default().initial_data(data.unwrap_or(&[]));
    // SAFETY: the initial data passed the header check for this very device.
    let cache = unsafe { device.create_pipeline_cache(&create_info, None) }
        .call("vkCreatePipelineCache")?;
    Ok((cache, data.map(fnv1a)))
}

/// Writes the cache's current data to `path`, unless its checksum is `unchanged` (many
/// processes sharing one directory then do not rewrite a file that already holds it).
/// Returns the checksum of the data, written or not.
pub(crate) fn save(
    device: &ash::Device,
    cache: vk::PipelineCache,
    path: &Path,
    unchanged: Option<u64>,
) -> VkResult<u64> {
    // SAFETY: `cache` belongs to `device`.
    let data = unsafe { device.get_pipeline_cache_data(cache) }.call("vkGetPipelineCacheData")?;
    let sum = fnv1a(&data);
    if unchanged == Some(sum) {
        return Ok(sum);
    }
    write_atomically(path, &encode(&data)).map_err(|source| {
        super::VkError::PipelineCacheWrite {
            path: path.display().to_string(),
            source,
        }
    })?;
    Ok(sum)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn device() -> DeviceInfo {
        DeviceInfo {
            vendor_id: 0x10de,
            device_id: 0x2335,
            driver_version: 0x8a40_0000,
            pipeline_cache_uuid: "00112233445566778899aabbccddeeff".into(),
            ..Default::default()
        }
    }

    fn driver_data(d: &DeviceInfo) -> Vec<u8> {
        let mut v = Vec::new();
        v.extend_from_slice(&(VK_HEADER_BYTES as u32).to_le_bytes());
        v.extend_from_slice(&1u32.to_le_bytes());
        v.extend_from_slice(&d.vendor_id.to_le_bytes());
        v.extend_from_slice(&d.device_id.to_le_bytes());
        for k in 0..16 {
            v.push(u8::from_str_radix(&d.pipeline_cache_uuid[2 * k..2 * k + 2], 16).unwrap());
        }
        v.extend_from_slice(b"pipelines");
        v
    }

    #[test]
    fn envelope_round_trips_and_refuses_damage_and_other_devices() {
        let d = device();
        let data = driver_data(&d);
        let file = encode(&data);
        assert_eq!(decode(&file, &d).unwrap(), &data[..]);
        assert!(decode(&file[..file.len() - 1], &d)
            .unwrap_err()
            .contains("truncated"));
        let mut flipped = file.clone();
        *flipped.last_mut().unwrap() ^= 1;
        assert!(decode(&flipped, &d).unwrap_err().contains("checksum"));
        assert!(decode(b"garbage", &d).is_err());
        let other = DeviceInfo {
            device_id: 0x2330,
            ..device()
        };
        assert!(decode(&file, &other)
            .unwrap_err()
            .contains("another device"));
        let newer = DeviceInfo {
            pipeline_cache_uuid: "ff".repeat(16),
            ..device()
        };
        assert!(decode(&file, &newer).is_err());
    }

    #[test]
    fn the_file_name_carries_the_whole_key() {
        let name = cache_file(Path::new("/c"), &device()).display().to_string();
        assert_eq!(
            name,
            "/c/pipelines-10de-2335-8a400000-00112233445566778899aabbccddeeff.bin"
        );
    }
}
