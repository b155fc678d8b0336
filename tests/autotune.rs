//! `auto` for `--backend` and `--raster` by measurement, tested without timing: measured
//! numbers are injected (directly, or as a cache file in an isolated `XDG_CACHE_HOME`).
mod common;

use std::path::PathBuf;
use std::time::Duration;

use rqr::accel::bvh::BvhBuild;
use rqr::accel::{Backend, BackendChoice};
use rqr::autotune::{self, CacheError, Measurement};
use rqr::render::passes::raster_compute::RasterMode;
use rqr::vk::{DeviceInfo, DeviceSelector};

fn lavapipe() -> DeviceInfo {
    let report = rqr::vk::probe_devices(&DeviceSelector::Auto, BackendChoice::Auto)
        .expect(common::INSTALL_HINT);
    report.devices[report.selected.unwrap()].clone()
}

fn tmp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("rqr-autotune-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// bvh faster than hw, compute faster than graphics (lavapipe's real ordering for the
/// backends; the visibility numbers are made up).
fn bvh_and_compute_win() -> Measurement {
    Measurement {
        rt_hw_ms: Some(30.0),
        rt_bvh_ms: 10.0,
        visibility_graphics_ms: 4.0,
        visibility_compute_ms: 3.0,
        bvh_host_build_ms: 40.0,
        bvh_gpu_build_ms: 120.0,
    }
}

#[test]
fn decisions_follow_the_measured_numbers() {
    let device = lavapipe();
    assert!(device.ray_query);
    let d = autotune::decide(&bvh_and_compute_win(), &device);
    assert_eq!(d.backend, Backend::Bvh);
    assert_eq!(d.raster, RasterMode::Compute);
    assert!(d
        .backend_reason
        .contains("30.000 ms on hw vs 10.000 ms on bvh"));
    assert!(d
        .raster_reason
        .contains("4.000 ms graphics vs 3.000 ms compute"));
    let m = Measurement {
        rt_hw_ms: Some(5.0),
        rt_bvh_ms: 10.0,
        visibility_graphics_ms: 1.0,
        visibility_compute_ms: 3.0,
        bvh_host_build_ms: 40.0,
        bvh_gpu_build_ms: 2.0,
    };
    let d = autotune::decide(&m, &device);
    assert_eq!((d.backend, d.raster), (Backend::Hw, RasterMode::Graphics));
    // The BVH build: the GPU only where it measured faster.
    assert_eq!(d.bvh_build, BvhBuild::Gpu, "{}", d.bvh_build_reason);
    assert!(
        d.bvh_build_reason
            .contains("40.0 ms on the host vs 2.0 ms on the GPU"),
        "{}",
        d.bvh_build_reason
    );
    let slow_gpu = autotune::decide(&bvh_and_compute_win(), &device);
    assert_eq!(slow_gpu.bvh_build, BvhBuild::Host);
    // Ties go to hw, graphics and the host build (today's choices).
    let tie = Measurement {
        rt_hw_ms: Some(1.0),
        rt_bvh_ms: 1.0,
        visibility_graphics_ms: 2.0,
        visibility_compute_ms: 2.0,
        bvh_host_build_ms: 7.0,
        bvh_gpu_build_ms: 7.0,
    };
    let d = autotune::decide(&tie, &device);
    assert_eq!((d.backend, d.raster), (Backend::Hw, RasterMode::Graphics));
    assert_eq!(d.bvh_build, BvhBuild::Host);
    // A device without ray queries never gets hw, whatever a cache says.
    let mut no_rq = device.clone();
    no_rq.ray_query = false;
    assert_eq!(autotune::decide(&m, &no_rq).backend, Backend::Bvh);
    // The feature rule: today's choice.
    let r = autotune::rule(&device, "test");
    assert_eq!((r.backend, r.raster), (Backend::Hw, RasterMode::Graphics));
    assert!(r.measured.is_none());
    // Without a measurement lavapipe (a CPU device) keeps the host build.
    assert_eq!(r.bvh_build, BvhBuild::Host, "{}", r.bvh_build_reason);
}

#[test]
fn cache_round_trips_and_rejects_bad_files() {
    let dir = tmp_dir("cache");
    let path = dir.join("rqr").join("autotune.json");
    let device = lavapipe();
    let key = autotune::cache_key(&device);
    // Portable across identical GPUs: the name and driver, not the device's UUID.
    assert!(key.contains(&device.name) && !key.contains(&device.device_uuid));
    assert_eq!(autotune::load(&path, &key).unwrap(), None, "missing file");
    autotune::store(&path, &key, &bvh_and_compute_win()).unwrap();
    autotune::store(&path, "other-device", &bvh_and_compute_win()).unwrap();
    assert_eq!(
        autotune::load(&path, &key).unwrap(),
        Some(bvh_and_compute_win())
    );
    assert!(autotune::load(&path, "other-device").unwrap().is_some());
    assert_eq!(autotune::load(&path, "unknown").unwrap(), None);

    std::fs::write(&path, "{ not json").unwrap();
    assert!(matches!(
        autotune::load(&path, &key),
        Err(CacheError::Invalid { .. })
    ));
    // A corrupt file is replaced by the next store.
    autotune::store(&path, &key, &bvh_and_compute_win()).unwrap();
    assert!(autotune::load(&path, &key).unwrap().is_some());

    let text = std::fs::read_to_string(&path).unwrap();
    let this_format = format!("\"format\": {}", autotune::CACHE_FORMAT);
    let other_format = text.replace(&this_format, "\"format\": 99");
    assert_ne!(text, other_format);
    std::fs::write(&path, other_format).unwrap();
    let err = autotune::load(&path, &key).unwrap_err();
    assert!(err.to_string().contains("cache format 99"), "{err}");

    // Unwritable: the cache directory is a file.
    let blocked = dir.join("blocker");
    std::fs::write(&blocked, "").unwrap();
    let err = autotune::store(
        &blocked.join("rqr").join("autotune.json"),
        &key,
        &bvh_and_compute_win(),
    )
    .unwrap_err();
    assert!(matches!(err, CacheError::Io { .. }), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// `rqr probe` and `rqr render` decide `auto` from an injected cache in an isolated
/// `XDG_CACHE_HOME`, without measuring; `--backend`/`--raster` still force.
#[test]
fn cli_auto_uses_the_cached_measurement_and_flags_still_force() {
    let dir = tmp_dir("cli");
    let device = lavapipe();
    let path = dir.join("rqr").join("autotune.json");
    autotune::store(&path, &autotune::cache_key(&device), &bvh_and_compute_win()).unwrap();
    let cache = dir.to_str().unwrap();
    let env = [("XDG_CACHE_HOME", cache), ("RQR_NO_AUTOTUNE", "0")];

    let (out, _) = common::run_rqr(&["probe", "--json"], &env, Duration::from_secs(60));
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(doc["schema"], 1);
    let d = &doc["devices"][doc["selected"].as_u64().unwrap() as usize];
    assert_eq!(d["backend"], "bvh", "{d}");
    assert_eq!(d["raster"], "compute", "{d}");
    assert!(d["backend_reason"]
        .as_str()
        .unwrap()
        .contains("auto (measured)"));
    assert!(d["raster_reason"]
        .as_str()
        .unwrap()
        .contains("3.000 ms compute"));
    assert_eq!(d["autotune"]["rt_bvh_ms"], 10.0);

    let png = dir.join("out.png");
    let render = |extra: &[&str]| {
        let mut args = vec![
            "render",
            "--mode",
            "hybrid",
            "--width",
            "32",
            "--height",
            "32",
            "--max-depth",
            "1",
            "--json",
            "-o",
            png.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let (out, _) = common::run_rqr(&args, &env, Duration::from_secs(300));
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let j = render(&[]);
    assert_eq!(j["backend"], "bvh", "{j}");
    assert_eq!(j["raster"], "compute", "{j}");
    assert!(j["raster_reason"]
        .as_str()
        .unwrap()
        .contains("auto (measured)"));
    let j = render(&["--backend", "hw", "--raster", "graphics"]);
    assert_eq!(j["backend"], "hw");
    assert_eq!(j["raster"], "graphics");
    assert_eq!(j["raster_reason"], "forced by --raster graphics");

    // RQR_NO_AUTOTUNE=1: today's feature rule, cache ignored.
    let (out, _) = common::run_rqr(
        &["probe", "--json"],
        &[("XDG_CACHE_HOME", cache), ("RQR_NO_AUTOTUNE", "1")],
        Duration::from_secs(60),
    );
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let d = &doc["devices"][doc["selected"].as_u64().unwrap() as usize];
    assert_eq!(d["backend"], "hw");
    assert_eq!(d["raster"], "graphics");
    assert!(d["autotune"].is_null());

    // A corrupt cache: a warning, the rule, success.
    std::fs::write(&path, "garbage").unwrap();
    let (out, _) = common::run_rqr(&["probe", "--json"], &env, Duration::from_secs(60));
    assert!(out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("autotune cache unusable"), "{stderr}");
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let d = &doc["devices"][doc["selected"].as_u64().unwrap() as usize];
    assert!(d["backend_reason"]
        .as_str()
        .unwrap()
        .contains("feature rule"));
    std::fs::remove_dir_all(&dir).ok();
}
