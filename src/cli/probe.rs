use anyhow::Result;
use clap::Args;
use rqr::accel::BackendChoice;
use rqr::device_select::report::DeviceReport;
use rqr::vk::DeviceSelector;

use super::{outln, StdoutError};

/// `rqr probe` arguments.
#[derive(Args, Debug)]
pub struct ProbeArgs {
    /// Print the machine-readable JSON document (schema 1).
    #[arg(long)]
    json: bool,
    /// Device to mark as selected: index, name substring or uuid:… (default: the
    /// CUDA_VISIBLE_DEVICES / NVIDIA_VISIBLE_DEVICES rules, else discrete > integrated >
    /// virtual > CPU).
    #[arg(long, default_value = "auto")]
    device: DeviceSelector,
    /// Backend choice to resolve for each device.
    #[arg(long, value_enum, default_value_t = BackendChoice::Auto)]
    backend: BackendChoice,
}

fn gib(bytes: u64) -> String {
    format!("{:.1} GiB", bytes as f64 / (1u64 << 30) as f64)
}

fn yes(b: bool) -> &'static str {
    if b {
        "yes"
    } else {
        "no"
    }
}

fn print_device(d: &DeviceReport, selected: bool) -> Result<(), StdoutError> {
    outln!(
        "{} [{}] {} ({}, vendor 0x{:04x})",
        if selected { "*" } else { " " },
        d.index,
        d.name,
        d.device_type,
        d.vendor_id
    )?;
    let rows: Vec<(&str, String)> = vec![
        ("Vulkan", d.api_version.clone()),
        ("driver", format!("{} ({})", d.driver_name, d.driver_info)),
        (
            "acceleration structure",
            yes(d.acceleration_structure).into(),
        ),
        ("ray query", yes(d.ray_query).into()),
        ("ray tracing pipeline", yes(d.ray_tracing_pipeline).into()),
        (
            "AS limits",
            d.as_properties
                .as_ref()
                .map(|a| {
                    format!(
                        "{} geometries, {} instances, {} primitives, scratch align {}",
                        a.max_geometry_count,
                        a.max_instance_count,
                        a.max_primitive_count,
                        a.min_scratch_offset_alignment
                    )
                })
                .unwrap_or_else(|| "-".into()),
        ),
        ("subgroup size", d.subgroup_size.to_string()),
        (
            "max workgroup invocations",
            d.max_compute_workgroup_invocations.to_string(),
        ),
        (
            "timestamps",
            if d.timestamps.supported {
                format!("yes, {} ns/tick", d.timestamps.period_ns)
            } else {
                "no (per-pass GPU times unavailable)".into()
            },
        ),
        (
            "memory heaps",
            d.memory_heaps
                .iter()
                .map(|h| {
                    format!(
                        "{}{}",
                        gib(h.size_bytes),
                        if h.device_local { " device-local" } else { "" }
                    )
                })
                .collect::<Vec<_>>()
                .join(", "),
        ),
        (
            "largest buffer",
            format!(
                "{} MiB bound (maxStorageBufferRange), {} MiB allocated (maxMemoryAllocationSize)",
                d.max_storage_buffer_range >> 20,
                d.max_memory_allocation_size >> 20
            ),
        ),
        (
            "required features",
            if d.missing_features.is_empty() {
                "all present".into()
            } else {
                format!("MISSING {}", d.missing_features.join(", "))
            },
        ),
        (
            "ray backend",
            format!(
                "{} ({})",
                d.backend.as_deref().unwrap_or("unavailable"),
                d.backend_reason
            ),
        ),
        (
            "visibility pass",
            format!("{} ({})", d.raster, d.raster_reason),
        ),
        ("64-bit buffer atomics", yes(d.buffer_int64_atomics).into()),
        (
            "block-compressed textures",
            match (d.bc7_textures, d.astc_4x4_textures) {
                (true, true) => "BC7, ASTC 4x4 (--texture-format block uploads BC7)".into(),
                (true, false) => "BC7 (--texture-format block uploads BC7)".into(),
                (false, true) => "ASTC 4x4 (--texture-format block uploads ASTC 4x4)".into(),
                (false, false) => "none (KTX2 textures upload as RGBA8)".into(),
            },
        ),
        (
            "KTX2 textures (auto)",
            format!("{} ({})", d.texture_format, d.texture_format_reason),
        ),
        (
            "device UUID",
            format!("{} (--device uuid:GPU-{})", d.device_uuid, d.device_uuid),
        ),
        (
            "PCI bus id",
            d.pci_bus_id
                .clone()
                .unwrap_or_else(|| "- (no VK_EXT_pci_bus_info)".into()),
        ),
    ];
    for (k, v) in rows {
        outln!("    {k:<26} {v}")?;
    }
    Ok(())
}

/// Runs `rqr probe`.
pub fn run(args: &ProbeArgs) -> Result<()> {
    let report = super::probe_report(&args.device, args.backend)?;
    if args.json {
        outln!("{}", serde_json::to_string_pretty(&report)?)?;
    } else {
        for d in &report.devices {
            print_device(d, report.selected == Some(d.index))?;
        }
    }
    Ok(())
}
