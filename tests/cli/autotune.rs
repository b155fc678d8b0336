//! `auto` for `--backend`, `--raster`, `--bvh-build` and `--texture-format` by measurement,
//! tested without timing: measured numbers are injected (directly, or as a cache file in an
//! isolated `XDG_CACHE_HOME`).
use crate::support;

use std::path::PathBuf;
use std::time::Duration;

use rqr::accel::bvh::BvhBuild;
use rqr::accel::Backend;
use rqr::device_select::autotune::{self, CacheError, Measurement};
use rqr::render::passes::raster_compute::RasterMode;
use rqr::scene::TextureFormat;
use rqr::vk::{DeviceInfo, DeviceSelector};

fn lavapipe() -> DeviceInfo {
    let list = rqr::vk::describe_devices(&DeviceSelector::Auto).expect(support::INSTALL_HINT);
    list.devices[list.selected].clone()
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
        texture_block_ms: Some(80.0),
        texture_rgba8_ms: 1.5,
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
        texture_block_ms: Some(1.0),
        texture_rgba8_ms: 1.1,
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
        texture_block_ms: Some(3.0),
        texture_rgba8_ms: 3.0,
    };
    let d = autotune::decide(&tie, &device);
    assert_eq!((d.backend, d.raster), (Backend::Hw, RasterMode::Graphics));
    assert_eq!(d.bvh_build, BvhBuild::Host);
    // A device without ray queries never gets hw, whatever a cache says.
    let mut no_rq = device.clone();
    no_rq.ray_query = false;
    assert_eq!(autotune::decide(&m, &no_rq).backend, Backend::Bvh);
    // The feature rule: a CPU device gets the compute BVH even with ray queries, a GPU
    // with them gets hw.
    let r = autotune::rule(&device, "test");
    assert_eq!((r.backend, r.raster), (Backend::Bvh, RasterMode::Graphics));
    assert!(
        r.backend_reason.contains("CPU device"),
        "{}",
        r.backend_reason
    );
    assert!(r.measured.is_none());
    let gpu_rule = autotune::rule(&discrete_gpu(&device), "test");
    assert_eq!(gpu_rule.backend, Backend::Hw, "{}", gpu_rule.backend_reason);
    // Without a measurement lavapipe (a CPU device) keeps the host build.
    assert_eq!(r.bvh_build, BvhBuild::Host, "{}", r.bvh_build_reason);
}

/// The device as a discrete GPU that samples BC7 (what the rules and decisions see of it).
fn discrete_gpu(device: &DeviceInfo) -> DeviceInfo {
    let mut gpu = device.clone();
    gpu.device_type = "discrete".into();
    gpu.bc7_textures = true;
    gpu
}

#[test]
fn texture_format_follows_the_measured_sampling_times() {
    let device = lavapipe();
    assert!(device.bc7_textures, "lavapipe samples BC7");
    let with = |block: Option<f64>, rgba8: f64| Measurement {
        texture_block_ms: block,
        texture_rgba8_ms: rgba8,
        ..bvh_and_compute_win()
    };
    for dev in [device.clone(), discrete_gpu(&device)] {
        // BC7 faster: the block format.
        let d = autotune::decide(&with(Some(1.0), 2.0), &dev);
        assert_eq!(
            d.texture_format,
            TextureFormat::Block,
            "{}",
            d.texture_format_reason
        );
        assert!(
            d.texture_format_reason
                .contains("sampling 1.000 ms BC7 vs 2.000 ms RGBA8"),
            "{}",
            d.texture_format_reason
        );
        // RGBA8 faster (lavapipe's real ordering, ~60x): RGBA8.
        let d = autotune::decide(&with(Some(86.5), 1.3), &dev);
        assert_eq!(
            d.texture_format,
            TextureFormat::Rgba8,
            "{}",
            d.texture_format_reason
        );
        assert!(d.texture_format_reason.contains("auto (measured)"));
        // RGBA8 faster, but within the margin: the block format keeps its memory saving.
        let close = 1.0 * autotune::TEXTURE_RGBA8_MARGIN * 0.99;
        let d = autotune::decide(&with(Some(close), 1.0), &dev);
        assert_eq!(d.texture_format, TextureFormat::Block);
        let d = autotune::decide(
            &with(Some(autotune::TEXTURE_RGBA8_MARGIN * 1.01), 1.0),
            &dev,
        );
        assert_eq!(d.texture_format, TextureFormat::Rgba8);
        // A tie: the block format.
        let d = autotune::decide(&with(Some(3.0), 3.0), &dev);
        assert_eq!(d.texture_format, TextureFormat::Block);
    }
    // A device that samples no block format gets RGBA8 whatever a cache says.
    let mut no_blocks = discrete_gpu(&device);
    no_blocks.bc7_textures = false;
    no_blocks.astc_4x4_textures = false;
    let d = autotune::decide(&with(Some(1.0), 50.0), &no_blocks);
    assert_eq!(d.texture_format, TextureFormat::Rgba8);
    assert!(d.texture_format_reason.contains("samples no block format"));
    // No block number for a device that samples one: the device-type rule.
    let d = autotune::decide(&with(None, 1.0), &device);
    assert_eq!(
        d.texture_format,
        TextureFormat::Rgba8,
        "lavapipe is a CPU device"
    );
    assert!(d.texture_format_reason.contains("not measured"));
    let d = autotune::decide(&with(None, 1.0), &discrete_gpu(&device));
    assert_eq!(d.texture_format, TextureFormat::Block);
    // The rule alone: RGBA8 on CPU devices (software block decode), the block format on GPUs.
    let r = autotune::rule(&device, "test");
    assert_eq!(
        r.texture_format,
        TextureFormat::Rgba8,
        "{}",
        r.texture_format_reason
    );
    assert!(r.texture_format_reason.contains("CPU device decodes BC7"));
    let r = autotune::rule(&discrete_gpu(&device), "test");
    assert_eq!(
        r.texture_format,
        TextureFormat::Block,
        "{}",
        r.texture_format_reason
    );
    assert_eq!(
        autotune::rule(&no_blocks, "test").texture_format,
        TextureFormat::Rgba8
    );
}

/// Rewrites the cache file at `path` with `edit` applied to the entry of `key`.
fn edit_entry(path: &std::path::Path, key: &str, edit: impl Fn(&mut serde_json::Value)) {
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    edit(&mut doc["devices"][key]);
    std::fs::write(path, serde_json::to_string_pretty(&doc).unwrap()).unwrap();
}

#[test]
fn cache_entries_with_bad_texture_times_are_rejected() {
    let dir = tmp_dir("texture-cache");
    let path = dir.join("rqr").join("autotune.json");
    let key = autotune::cache_key(&lavapipe());
    let m = bvh_and_compute_win();
    autotune::store(&path, &key, &m).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(
        text.contains("\"texture_block_ms\": 80.0") && text.contains("\"texture_rgba8_ms\": 1.5"),
        "{text}"
    );
    assert_eq!(autotune::load(&path, &key).unwrap(), Some(m.clone()));
    // Where the device samples no block format, the block time is null.
    let no_block = Measurement {
        texture_block_ms: None,
        ..m.clone()
    };
    autotune::store(&path, &key, &no_block).unwrap();
    assert_eq!(autotune::load(&path, &key).unwrap(), Some(no_block));
    // An entry without the RGBA8 time (written by hand, or truncated): unusable, and named.
    autotune::store(&path, &key, &m).unwrap();
    edit_entry(&path, &key, |e| {
        e.as_object_mut().unwrap().remove("texture_rgba8_ms");
    });
    let err = autotune::load(&path, &key).unwrap_err();
    assert!(matches!(err, CacheError::Invalid { .. }), "{err}");
    assert!(err.to_string().contains("texture_rgba8_ms"), "{err}");
    // A time that is not a number.
    autotune::store(&path, &key, &m).unwrap();
    edit_entry(&path, &key, |e| e["texture_block_ms"] = "fast".into());
    let err = autotune::load(&path, &key).unwrap_err();
    assert!(matches!(err, CacheError::Invalid { .. }), "{err}");
    // A cache of the format before the texture times: refused as such, then rewritten.
    autotune::store(&path, &key, &m).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let this_format = format!("\"format\": {}", autotune::CACHE_FORMAT);
    let previous = text.replace(
        &this_format,
        &format!("\"format\": {}", autotune::CACHE_FORMAT - 1),
    );
    std::fs::write(&path, previous).unwrap();
    let err = autotune::load(&path, &key).unwrap_err();
    assert!(
        err.to_string().contains(&format!(
            "cache format {} (this rqr reads {})",
            autotune::CACHE_FORMAT - 1,
            autotune::CACHE_FORMAT
        )),
        "{err}"
    );
    autotune::store(&path, &key, &m).unwrap();
    assert_eq!(autotune::load(&path, &key).unwrap(), Some(m));
    std::fs::remove_dir_all(&dir).ok();
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

    let (out, _) = support::run_rqr(&["probe", "--json"], &env, Duration::from_secs(60));
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
    // The texture format and the numbers behind it.
    assert_eq!(d["texture_format"], "rgba8", "{d}");
    assert!(
        d["texture_format_reason"]
            .as_str()
            .unwrap()
            .contains("sampling 80.000 ms BC7 vs 1.500 ms RGBA8"),
        "{d}"
    );
    assert_eq!(d["autotune"]["texture_block_ms"], 80.0);
    assert_eq!(d["autotune"]["texture_rgba8_ms"], 1.5);
    let (out, _) = support::run_rqr(&["probe"], &env, Duration::from_secs(60));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("KTX2 textures (auto)       rgba8 (auto (measured): sampling 80.000 ms BC7"),
        "{text}"
    );

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
        let (out, _) = support::run_rqr(&args, &env, Duration::from_secs(300));
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
    let (out, _) = support::run_rqr(
        &["probe", "--json"],
        &[("XDG_CACHE_HOME", cache), ("RQR_NO_AUTOTUNE", "1")],
        Duration::from_secs(60),
    );
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let d = &doc["devices"][doc["selected"].as_u64().unwrap() as usize];
    assert_eq!(d["backend"], "bvh", "the rule on a CPU device: {d}");
    assert_eq!(d["raster"], "graphics");
    assert_eq!(
        d["texture_format"], "rgba8",
        "the rule on a CPU device: {d}"
    );
    assert!(d["autotune"].is_null());

    // A corrupt cache: a warning, the rule, success.
    std::fs::write(&path, "garbage").unwrap();
    let (out, _) = support::run_rqr(&["probe", "--json"], &env, Duration::from_secs(60));
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

/// The texture-sampling measurement runs on the device, validation clean: both formats timed
/// where the device samples a block format (lavapipe: BC7), finite and positive. (Which is
/// faster is the device's business: no timing is asserted.)
#[test]
fn texture_sampling_measures_both_formats() {
    use rqr::render::passes::texture_sampling;
    let ctx = support::gpu();
    let t = texture_sampling::measure(&ctx, 1).unwrap();
    let (name, block_ms) = t.block.expect("lavapipe samples BC7");
    assert_eq!(name, "BC7");
    for ms in [block_ms, t.rgba8_ms] {
        assert!(ms.is_finite() && ms > 0.0, "{t:?}");
    }
    eprintln!(
        "texture sampling: {block_ms:.3} ms BC7, {:.3} ms RGBA8",
        t.rgba8_ms
    );
    support::assert_validation_clean(&ctx);
}
