//! Bad command lines, missing or unmatched devices and GPU faults through the real binary:
//! every one fails with exit code ≠ 0 and a one-line message saying what is wrong, fast,
//! without a panic or a hang, and without Vulkan validation errors.

use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::Duration;

use crate::support;

use support::run_rqr as rqr;

/// Environment in which any Vulkan use fails with "no Vulkan device" (exit code 2).
const NO_VULKAN: &[(&str, &str)] = &[
    ("VK_DRIVER_FILES", "/nonexistent/icd.json"),
    ("VK_ICD_FILENAMES", "/nonexistent/icd.json"),
];

/// Validation on, so that the binary reports any validation error on stderr.
const VALIDATED: &[(&str, &str)] = &[("RQR_VALIDATION", "1")];

fn tmp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("rqr-cli-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The error line: `rqr: error: ...` (the last line of stderr).
fn error_line(out: &Output) -> String {
    stderr(out)
        .lines()
        .rfind(|l| !l.trim().is_empty())
        .unwrap_or("")
        .to_string()
}

fn assert_clean_failure(args: &[&str], out: &Output, code: i32, needle: &str) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(code), "rqr {args:?}: {err}");
    assert!(
        err.contains(needle),
        "rqr {args:?}: '{needle}' not in: {err}"
    );
    for bad in ["panicked", "RUST_BACKTRACE", "Validation Error"] {
        assert!(!err.contains(bad), "rqr {args:?}: {err}");
    }
}

#[test]
fn bad_settings_fail_before_any_gpu_work() {
    let dir = tmp_dir("settings");
    let out_png = dir.join("out.png");
    let out_png = out_png.to_str().unwrap();
    let a_dir = dir.join("dir.png");
    std::fs::create_dir_all(&a_dir).unwrap();
    let missing_scene = dir.join("missing.glb");
    // (extra args, expected exit code, text the error must contain)
    let cases: Vec<(Vec<&str>, i32, &str)> = vec![
        (
            vec!["--width", "0"],
            2,
            "--width 0: resolution 0x512 must be at least 1x1",
        ),
        (
            vec!["--width", "100000"],
            2,
            "--width 100000: resolution 100000x512 exceeds the limit of 16384 pixels per side",
        ),
        (vec!["--spp", "0"], 2, "--spp 0 must be in 1..=4096"),
        (vec!["--spp", "5000"], 2, "--spp 5000 must be in 1..=4096"),
        (
            vec!["--max-depth", "1000"],
            2,
            "--max-depth 1000 must be in 1..=16",
        ),
        (
            vec!["--sampler", "grid", "--spp", "3"],
            2,
            "needs a square --spp",
        ),
        (
            vec!["--exposure", "NaN"],
            2,
            "--exposure NaN must be finite",
        ),
        (
            vec!["--min-weight", "2"],
            2,
            "--min-weight 2 must be in [0, 1)",
        ),
        (vec!["--fov", "0"], 2, "--fov 0 must be in (0, 180) degrees"),
        (
            vec!["--camera", "7"],
            2,
            "--camera 7: the scene has 1 camera(s)",
        ),
        (
            vec!["--aov", "albedo,emission"],
            2,
            "unknown AOV 'emission' (known: depth, normal, geometric_normal, albedo,",
        ),
        (
            vec!["-o", "/nonexistent-rqr-dir/out.png"],
            1,
            "output directory '/nonexistent-rqr-dir' does not exist",
        ),
        (
            vec!["-o", "/proc/rqr-cannot-write-here.png"],
            1,
            "cannot write '/proc/rqr-cannot-write-here.png'",
        ),
        (vec!["-o", a_dir.to_str().unwrap()], 1, "is a directory"),
        (
            vec!["-o", "out.txt"],
            2,
            "output 'out.txt' must end in .png (tonemapped sRGB), .exr or .pfm (linear HDR)",
        ),
        (
            vec!["-o", "out.tiff", "--aov", "albedo"],
            2,
            "output 'out.tiff' must end in .png (tonemapped sRGB), .exr or .pfm",
        ),
        (
            vec![missing_scene.to_str().unwrap()],
            1,
            "missing.glb: cannot read",
        ),
        // Usage errors found by clap exit with code 2 too (like "no Vulkan", with another message).
        (
            vec!["--backend", "warp"],
            2,
            "invalid value 'warp' for '--backend",
        ),
        (
            vec!["--raster", "tiles"],
            2,
            "invalid value 'tiles' for '--raster",
        ),
        (
            vec!["--timeout-ms", "0"],
            2,
            "invalid value '0' for '--timeout-ms",
        ),
        (vec!["--width", "-5"], 2, "unexpected argument '-5'"),
        (
            vec!["--light-radius=-0.5"],
            2,
            "-0.5 must be a finite number >= 0",
        ),
        (
            vec!["--light-radius", "NaN"],
            2,
            "NaN must be a finite number >= 0",
        ),
        (
            vec!["--sun-angle", "inf"],
            2,
            "inf must be a finite number >= 0",
        ),
        (vec!["--sun-angle", "95"], 2, "95 degrees must be below 90"),
        (vec!["--light-radius", "big"], 2, "'big' is not a number"),
        (
            vec!["--shading", "distributed", "--sampler", "adaptive"],
            2,
            "--sampler adaptive subdivides where samples differ",
        ),
        (
            vec!["--diffuse-bounces", "2"],
            2,
            "--diffuse-bounces needs --shading distributed",
        ),
        (
            vec!["--shading", "distributed", "--diffuse-bounces", "99"],
            2,
            "--diffuse-bounces 99 must be at most 16",
        ),
        (
            vec!["--shading", "cook"],
            2,
            "invalid value 'cook' for '--shading",
        ),
        (vec!["--ambient", "1,2"], 2, "expected x,y,z"),
        // Sequence flags: reuse between frames caches one centred sample per pixel.
        (
            vec!["--frames", "4", "--reproject", "--spp", "4"],
            2,
            "--reproject, --frameless and --adaptive-subsample cache one sample per pixel: use --spp 1",
        ),
        (
            vec!["--frames", "4", "--frameless", "200"],
            2,
            "--frameless 200 must be a percentage in (0, 100]",
        ),
        (vec!["--frames", "0"], 2, "--frames must be at least 1"),
    ];
    for (extra, code, needle) in cases {
        let mut args = vec!["render"];
        if !extra.contains(&"-o") {
            args.extend(["-o", out_png]);
        }
        args.extend(extra);
        let (out, took) = rqr(&args, NO_VULKAN, Duration::from_secs(30));
        assert_clean_failure(&args, &out, code, needle);
        // Had any Vulkan work started, the error would be "no Vulkan device found".
        assert!(
            !stderr(&out).contains("no Vulkan device"),
            "rqr {args:?} touched Vulkan first: {}",
            stderr(&out)
        );
        // rqr's own errors (not clap's) are one line; a usage mistake says which settings.
        if stderr(&out).contains("rqr: error: ") {
            assert_eq!(stderr(&out).lines().count(), 1, "{}", stderr(&out));
            let line = error_line(&out);
            assert!(line.starts_with("rqr: error: "), "{line}");
            assert_eq!(
                code == 2,
                line.starts_with("rqr: error: invalid settings: "),
                "{line}"
            );
        }
        assert!(took < Duration::from_secs(10), "rqr {args:?} took {took:?}");
        assert!(!Path::new(out_png).exists(), "rqr {args:?} wrote an image");
    }
    // `compare` shares the checks.
    for (extra, needle) in [
        (vec!["--width", "0"], "must be at least 1x1"),
        (vec!["--max-depth", "1000"], "--max-depth 1000"),
    ] {
        let out_dir = dir.join("cmp");
        let mut args = vec!["compare", "-o", out_dir.to_str().unwrap()];
        args.extend(extra);
        let (out, _) = rqr(&args, NO_VULKAN, Duration::from_secs(30));
        assert_clean_failure(&args, &out, 2, needle);
    }
    // The same environment does reach Vulkan when the settings are fine: the checks above
    // really ran first.
    let args = ["render", "--width", "8", "--height", "8", "-o", out_png];
    let (out, _) = rqr(&args, NO_VULKAN, Duration::from_secs(30));
    assert_clean_failure(&args, &out, 2, "no Vulkan device");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bench_has_no_raster_flag() {
    // `rqr bench` traces rays without rasterizing: a --raster there would do nothing, so clap
    // rejects it; render and compare keep it.
    let args = ["bench", "--raster", "compute"];
    let (out, _) = rqr(&args, NO_VULKAN, Duration::from_secs(30));
    assert_clean_failure(&args, &out, 2, "unexpected argument '--raster'");
    let (help, _) = rqr(&["bench", "--help"], NO_VULKAN, Duration::from_secs(30));
    assert!(help.status.success());
    assert!(!String::from_utf8_lossy(&help.stdout).contains("--raster"));
    for command in ["render", "compare"] {
        let (help, _) = rqr(&[command, "--help"], NO_VULKAN, Duration::from_secs(30));
        assert!(
            String::from_utf8_lossy(&help.stdout).contains("--raster <RASTER>"),
            "{command}"
        );
    }
}

/// `rqr probe --json` of the device the tests run on.
fn device() -> serde_json::Value {
    let (out, _) = rqr(&["probe", "--json"], &[], Duration::from_secs(60));
    assert!(out.status.success(), "{}", stderr(&out));
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let selected = doc["selected"].as_u64().expect("a selected device") as usize;
    doc["devices"][selected].clone()
}

#[test]
fn resolutions_beyond_the_device_fail_before_rendering() {
    let dev = device();
    let dir = tmp_dir("limits");
    let out_png = dir.join("out.png");
    let out_png = out_png.to_str().unwrap();

    // A square image whose per-pixel AOV buffer (80 bytes, allocated only for --aov) exceeds
    // maxStorageBufferRange.
    let range = dev["max_storage_buffer_range"].as_u64().unwrap();
    let aov_bytes = std::mem::size_of::<rqr::interface::Aov>() as u64;
    let side = ((range / aov_bytes) as f64).sqrt() as u64 + 2;
    assert!(
        side <= 16384,
        "maxStorageBufferRange {range} fits any image"
    );
    let side = side.to_string();
    let args = [
        "render", "--width", &side, "--height", &side, "--aov", "depth", "-o", out_png,
    ];
    let (out, took) = rqr(&args, VALIDATED, Duration::from_secs(120));
    assert_clean_failure(&args, &out, 1, "maxStorageBufferRange");
    assert!(error_line(&out).contains(&format!("resolution {side}x{side} with AOVs")));
    assert!(error_line(&out).contains("render without AOVs (--aov)"));
    assert!(took < Duration::from_secs(60), "took {took:?}");

    // Hybrid keeps one G-buffer per sample (the full layout: ~116 bytes per pixel with depth):
    // enough samples exceed the heap.
    let heap = dev["memory_heaps"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|h| h["device_local"] == true)
        .map(|h| h["size_bytes"].as_u64().unwrap())
        .max()
        .unwrap();
    let spp = (heap / (100 << 20) + 1).to_string();
    let args = [
        "render",
        "--mode",
        "hybrid",
        "--gbuffer",
        "full",
        "--width",
        "1024",
        "--height",
        "1024",
        "--spp",
        &spp,
        "-o",
        out_png,
    ];
    let (out, took) = rqr(&args, VALIDATED, Duration::from_secs(120));
    assert_clean_failure(&args, &out, 1, "of device memory");
    assert!(error_line(&out).contains("--spp"), "{}", error_line(&out));
    assert!(took < Duration::from_secs(60), "took {took:?}");
    assert!(!Path::new(out_png).exists());

    // A flag combination found wrong only once the device is open is still a usage mistake
    // (exit code 2), unlike the device limits above (1).
    let args = [
        "render",
        "--mode",
        "hybrid",
        "--raster",
        "compute",
        "--gbuffer",
        "full",
        "--width",
        "8",
        "--height",
        "8",
        "-o",
        out_png,
    ];
    let (out, _) = rqr(&args, VALIDATED, Duration::from_secs(120));
    assert_clean_failure(
        &args,
        &out,
        2,
        "invalid settings: --raster compute writes the visibility buffer only",
    );
    assert!(!Path::new(out_png).exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn gpu_timeout_is_a_clean_error_naming_the_pass() {
    let dir = tmp_dir("timeout");
    let out_png = dir.join("out.png");
    // Far more work than 1 ms on any device: every pass from the first upload on times out.
    for mode in ["rt", "hybrid"] {
        let args = [
            "render",
            "--mode",
            mode,
            "--timeout-ms",
            "1",
            "--width",
            "256",
            "--height",
            "256",
            "--spp",
            "16",
            "-o",
            out_png.to_str().unwrap(),
        ];
        // The binary waits up to ABANDONED_WORK_GRACE (10 s) for the abandoned work.
        let (out, _) = rqr(&args, VALIDATED, Duration::from_secs(120));
        assert_clean_failure(&args, &out, 1, "GPU timeout: pass '");
        let line = error_line(&out);
        assert!(
            line.starts_with("rqr: error: GPU timeout: pass '")
                && line.contains("did not finish within 1 ms"),
            "{line}"
        );
        assert!(!out_png.exists());
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// `rqr info | head -1`: once stdout's reader is gone, a command stops quietly with the
/// status a shell gives a command killed by SIGPIPE (141), instead of `println!` panicking.
#[cfg(unix)]
#[test]
fn closed_stdout_ends_commands_quietly() {
    let dir = tmp_dir("epipe");
    let out_png = dir.join("out.png");
    let out_png_arg = out_png.to_str().unwrap();
    let cases: [&[&str]; 5] = [
        &["info"],
        &["info", "--json"],
        &["probe"],
        &["probe", "--json"],
        &["render", "--width", "8", "--height", "8", "-o", out_png_arg],
    ];
    for args in cases {
        let (out, _) = support::run_rqr_stdout_closed(args, VALIDATED, Duration::from_secs(120));
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(141), "rqr {args:?}: {err}");
        for bad in ["panicked", "Broken pipe", "rqr: error", "Validation Error"] {
            assert!(!err.contains(bad), "rqr {args:?}: {err}");
        }
    }
    // The render's work was done: only its summary line found nobody to read it.
    assert!(out_png.exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn info_fails_cleanly_on_bad_input() {
    let dir = std::env::temp_dir().join(format!("rqr-info-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let broken = dir.join("broken.glb");
    std::fs::write(&broken, b"glTF\x02\0\0\0\xff\0\0\0JSON").unwrap();
    let missing = dir.join("missing.gltf");
    let sparse = support::scene_files::asset("SimpleSparseAccessor/SimpleSparseAccessor.gltf");
    // Exit 1: the file is missing, broken or lacks the scene; exit 2: a usage mistake (the
    // built-in scene has one scene whatever the file system holds).
    for (args, needle, code) in [
        (vec!["info", missing.to_str().unwrap()], "missing.gltf", 1),
        (vec!["info", broken.to_str().unwrap()], "truncated GLB", 1),
        (
            vec!["info", sparse.to_str().unwrap(), "--scene", "3"],
            "scene 3",
            1,
        ),
        (vec!["info", "--scene", "1"], "built-in", 2),
    ] {
        let (out, _) = rqr(&args, &[], Duration::from_secs(60));
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(code), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: '{needle}' not in {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert!(out.stdout.is_empty());
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn device_selector_errors_name_the_available_devices() {
    let (out, _) = rqr(
        &["probe", "--device", "no-such-gpu-xyz"],
        &[],
        Duration::from_secs(60),
    );
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no-such-gpu-xyz") && err.contains("0: "),
        "{err}"
    );
}

#[test]
fn missing_vulkan_driver_exits_2_with_install_hint() {
    let (out, _) = rqr(&["probe"], NO_VULKAN, Duration::from_secs(30));
    assert_eq!(
        out.status.code(),
        Some(2),
        "stderr: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("scripts/setup-vulkan.sh"));
}

/// `rqr render --frames` options that cannot work (a camera path the scene lacks, a frame
/// range past the sequence or empty, reuse with several samples per pixel, ...) are refused
/// naming the option.
#[test]
fn sequence_options_that_cannot_work_are_refused() {
    let dir = tmp_dir("sequence");
    let out = dir.join("seq.png");
    let out_s = out.to_str().unwrap();
    for (args, message) in [
        (
            vec!["--frames", "2", "--camera-path", "gltf"],
            "has no camera animation",
        ),
        (
            vec!["--frames", "2", "--frame-range", "1..3"],
            "goes past --frames",
        ),
        (vec!["--frame-range", "3..3"], "empty frame range"),
        (
            vec!["--frames", "2", "--frameless", "0"],
            "must be a percentage",
        ),
        (
            vec!["--frames", "2", "--reproject", "--max-age", "1024"],
            "--max-age 1024 must be at most 1023",
        ),
        (
            vec![
                "--frames",
                "2",
                "--reproject",
                "--spp",
                "4",
                "--sampler",
                "grid",
            ],
            "--spp 1",
        ),
        (vec!["--camera-path", "spin:2"], "unknown camera path"),
        (vec!["--camera-path", "orbit:1"], "needs --frames"),
    ] {
        let mut full = vec!["render", "--width", "16", "--height", "16", "-o", out_s];
        full.extend(args.iter().copied());
        let (o, _) = rqr(&full, &[], Duration::from_secs(60));
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(stderr.contains(message), "{args:?}: {stderr}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
