//! Foundation: device probing, backend choice, compute round trip, timestamps, fence timeouts.

use crate::support;

use std::process::Command;
use std::time::Duration;

use rqr::accel::{Backend, BackendChoice};
use rqr::device_select::report::probe_devices;
use rqr::shaders;
use rqr::vk::{
    self, Binding, Buffer, ComputePipeline, DeviceSelector, GpuProfiler, MemoryLocation, VkError,
};
use support::{assert_validation_clean, gpu};

fn rqr_bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_rqr"));
    // `auto` by the feature rule: no timing-dependent choices, no writes to the user cache.
    c.env("RQR_NO_AUTOTUNE", "1");
    c
}

#[test]
fn probe_finds_lavapipe_with_ray_query_and_picks_hw() {
    let report =
        probe_devices(&DeviceSelector::Auto, BackendChoice::Auto).expect(support::INSTALL_HINT);
    let lvp = report
        .devices
        .iter()
        .find(|d| d.driver_name.contains("llvmpipe") || d.name.contains("llvmpipe"))
        .unwrap_or_else(|| {
            panic!(
                "no lavapipe device among {:?}\n{}",
                report.devices.iter().map(|d| &d.name).collect::<Vec<_>>(),
                support::INSTALL_HINT
            )
        });
    assert_eq!(lvp.device_type, "cpu");
    assert!(
        lvp.acceleration_structure,
        "lavapipe without acceleration structures: Mesa too old?"
    );
    assert!(lvp.ray_query, "lavapipe without ray query: Mesa too old?");
    assert_eq!(lvp.backend.as_deref(), Some("hw"), "{}", lvp.backend_reason);
    assert!(
        lvp.missing_features.is_empty(),
        "{:?}",
        lvp.missing_features
    );
    let asp = lvp.as_properties.as_ref().expect("AS properties");
    assert!(asp.max_primitive_count >= 1 << 20);
    assert!(asp.min_scratch_offset_alignment.is_power_of_two());
    assert!(lvp.timestamps.supported && lvp.timestamps.period_ns > 0.0);
    assert!(!lvp.memory_heaps.is_empty());
}

#[test]
fn probe_json_has_schema_and_honours_backend_bvh() {
    let doc = support::run_json(rqr_bin().args(["probe", "--json", "--backend", "bvh"]));
    assert_eq!(doc["schema"], 1);
    assert!(doc["selected"].is_u64());
    let devices = doc["devices"].as_array().unwrap();
    assert!(!devices.is_empty());
    for d in devices {
        assert_eq!(d["backend"], "bvh");
        assert_eq!(d["backend_reason"], "forced by --backend bvh");
        for key in [
            "index",
            "name",
            "vendor_id",
            "device_type",
            "api_version",
            "driver_name",
            "driver_info",
            "ray_query",
            "acceleration_structure",
            "ray_tracing_pipeline",
            "as_properties",
            "subgroup_size",
            "max_compute_workgroup_invocations",
            "timestamps",
            "memory_heaps",
        ] {
            assert!(d.get(key).is_some(), "probe JSON lacks '{key}'");
        }
    }
    let human = rqr_bin().arg("probe").output().unwrap();
    assert!(human.status.success());
    assert!(String::from_utf8_lossy(&human.stdout).contains("ray backend"));
}

/// The probe and `Context::new` read one requirements table (`vk::requirements`): the device
/// the probe selects and approves opens, reporting the same (empty) missing list. The refusal
/// side is tested with injected feature sets in `vk::requirements`' unit tests.
#[test]
fn the_device_the_probe_approves_opens() {
    let report =
        probe_devices(&DeviceSelector::Auto, BackendChoice::Auto).expect(support::INSTALL_HINT);
    let probed = &report.devices[report.selected.expect("a selected device")];
    assert!(
        probed.missing_features.is_empty(),
        "{:?}",
        probed.missing_features
    );
    assert!(vk::requirements::check(&probed.name, &probed.missing_features).is_ok());
    let ctx = gpu();
    assert_eq!(ctx.info().name, probed.name);
    assert_eq!(ctx.info().missing_features, probed.missing_features);
    assert_validation_clean(&ctx);
}

#[test]
fn backend_choice_resolves_per_device() {
    let ctx = gpu();
    let info = ctx.info();
    assert_eq!(BackendChoice::Bvh.resolve(info).unwrap().0, Backend::Bvh);
    let auto = BackendChoice::Auto.resolve(info).unwrap().0;
    if ctx.features().ray_query {
        assert_eq!(auto, Backend::Hw);
        assert_eq!(BackendChoice::Hw.resolve(info).unwrap().0, Backend::Hw);
    } else {
        assert_eq!(auto, Backend::Bvh);
        assert!(BackendChoice::Hw.resolve(info).is_err());
    }
    // A device without ray queries must refuse `hw` and fall back under `auto`.
    let mut no_rq = info.clone();
    no_rq.ray_query = false;
    assert_eq!(BackendChoice::Auto.resolve(&no_rq).unwrap().0, Backend::Bvh);
    let err = BackendChoice::Hw.resolve(&no_rq).unwrap_err().to_string();
    assert!(err.contains("VK_KHR_ray_query"), "{err}");
}

#[test]
fn compute_roundtrip_returns_exact_values() {
    let ctx = gpu();
    let n = 10_000u32;
    let input: Vec<u32> = (0..n).map(|i| i.wrapping_mul(2_654_435_761)).collect();
    let src = Buffer::from_slice(
        &ctx,
        "roundtrip in",
        &input,
        vk::vk::BufferUsageFlags::empty(),
    )
    .unwrap();
    let dst = Buffer::new(
        &ctx,
        "roundtrip out",
        u64::from(n) * 4,
        vk::vk::BufferUsageFlags::empty(),
        MemoryLocation::GpuOnly,
    )
    .unwrap();
    let pipeline = ComputePipeline::new(
        &ctx,
        "roundtrip",
        shaders::ROUNDTRIP_COMP,
        &[Binding::StorageBuffer, Binding::StorageBuffer],
        4,
    )
    .unwrap();
    let set = pipeline.allocate_set().unwrap();
    set.buffer(0, &src, Binding::StorageBuffer)
        .buffer(1, &dst, Binding::StorageBuffer);
    ctx.run("roundtrip", |cmd| {
        pipeline.dispatch(cmd, Some(&set), &n.to_le_bytes(), [n.div_ceil(64), 1, 1]);
        Ok(())
    })
    .unwrap();
    let out: Vec<u32> = dst.read(&ctx).unwrap();
    let expected: Vec<u32> = input
        .iter()
        .enumerate()
        .map(|(i, v)| v.wrapping_mul(3).wrapping_add(i as u32))
        .collect();
    assert_eq!(out, expected);
    assert_validation_clean(&ctx);
}

fn busy_pipeline(ctx: &vk::Context) -> (ComputePipeline, vk::DescriptorSet, Buffer) {
    let sink = Buffer::new(
        ctx,
        "busy sink",
        4096,
        vk::vk::BufferUsageFlags::empty(),
        MemoryLocation::GpuOnly,
    )
    .unwrap();
    let pipeline = ComputePipeline::new(
        ctx,
        "busy",
        shaders::BUSY_COMP,
        &[Binding::StorageBuffer],
        4,
    )
    .unwrap();
    let set = pipeline.allocate_set().unwrap();
    set.buffer(0, &sink, Binding::StorageBuffer);
    (pipeline, set, sink)
}

#[test]
fn timestamps_give_nonnegative_durations() {
    let ctx = gpu();
    let (pipeline, set, _sink) = busy_pipeline(&ctx);
    let mut profiler = GpuProfiler::new(&ctx, 4).expect("timestamps");
    ctx.run("profiled", |cmd| {
        profiler.reset(cmd);
        profiler.begin(cmd, "empty");
        profiler.end(cmd);
        profiler.begin(cmd, "busy");
        pipeline.dispatch(cmd, Some(&set), &2000u32.to_le_bytes(), [256, 1, 1]);
        profiler.end(cmd);
        Ok(())
    })
    .unwrap();
    let results = profiler.results().unwrap();
    assert_eq!(
        results.iter().map(|r| r.0.as_str()).collect::<Vec<_>>(),
        ["empty", "busy"]
    );
    for (name, ms) in &results {
        assert!(ms.is_finite() && *ms >= 0.0, "{name}: {ms}");
    }
    assert!(results[1].1 > 0.0, "a 32M-iteration dispatch took no time?");
    assert_validation_clean(&ctx);
}

#[test]
fn fence_timeout_returns_error_naming_the_pass() {
    let mut ctx = gpu();
    let (pipeline, set, _sink) = busy_pipeline(&ctx);
    ctx.set_fence_timeout(Duration::from_millis(1));
    let err = ctx
        .run("deliberately slow pass", |cmd| {
            pipeline.dispatch(cmd, Some(&set), &200_000u32.to_le_bytes(), [128, 1, 1]);
            Ok(())
        })
        .unwrap_err();
    match &err {
        VkError::Timeout { pass, timeout_ms } => {
            assert_eq!(pass, "deliberately slow pass");
            assert_eq!(*timeout_ms, 1);
        }
        other => panic!("expected a timeout, got {other}"),
    }
    assert!(err.to_string().contains("deliberately slow pass"));
    // The device stays usable once the abandoned work drains.
    ctx.wait_idle().unwrap();
    ctx.set_fence_timeout(Duration::from_secs(60));
    ctx.run("after timeout", |_| Ok(())).unwrap();
    assert_validation_clean(&ctx);
}

#[test]
fn sync_validation_reports_a_missing_barrier() {
    // A transfer clear and a compute write to the same buffer with no barrier between them:
    // a hazard only synchronization validation sees (RQR_SYNC_VALIDATION=1 in .ci/run).
    let clear_then_dispatch = |ctx: &vk::Context, barrier: bool| {
        let (pipeline, set, sink) = busy_pipeline(ctx);
        ctx.run("hazard", |cmd| {
            // SAFETY: recording command buffer; the buffer is alive for the submission.
            unsafe {
                ctx.device()
                    .cmd_fill_buffer(cmd, sink.raw(), 0, vk::vk::WHOLE_SIZE, 0)
            };
            if barrier {
                vk::memory_barrier(ctx.device(), cmd);
            }
            pipeline.dispatch(cmd, Some(&set), &1u32.to_le_bytes(), [1, 1, 1]);
            Ok(())
        })
        .unwrap();
    };
    let ctx = gpu_with_sync();
    clear_then_dispatch(&ctx, false);
    let errors = ctx.validation_errors();
    assert!(
        errors
            .iter()
            .any(|e| e.contains("SYNC-HAZARD-WRITE-AFTER-WRITE")),
        "synchronization validation missed the hazard: {errors:?}"
    );
    // With the barrier rqr's passes use, the same work is clean.
    let clean = gpu_with_sync();
    clear_then_dispatch(&clean, true);
    assert_validation_clean(&clean);
}

fn gpu_with_sync() -> vk::Context {
    let ctx = vk::Context::new(&vk::ContextOptions {
        validation: Some(true),
        sync_validation: Some(true),
        ..Default::default()
    })
    .expect(support::INSTALL_HINT);
    assert!(ctx.validation_enabled(), "{}", support::INSTALL_HINT);
    ctx
}
