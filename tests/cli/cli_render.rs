//! The rendering commands end to end through the real binary.

use crate::support;

use std::path::Path;
use std::process::Command;

fn rqr() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_rqr"));
    c.env("RQR_VALIDATION", "1");
    // `auto` by the feature rule: no timing-dependent choices, no writes to the user cache.
    c.env("RQR_NO_AUTOTUNE", "1");
    c
}

fn tmpdir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("rqr-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn render_writes_png_exr_aovs_and_json() {
    let dir = tmpdir("render");
    let png = dir.join("room.png");
    let j = support::run_json(
        rqr()
            .args([
                "render",
                "--width",
                "40",
                "--height",
                "32",
                "--aov",
                "depth,normal,instance",
                "--json",
                "-o",
            ])
            .arg(&png),
    );
    assert_eq!(j["width"], 40);
    assert_eq!(j["height"], 32);
    assert_eq!(j["mode"], "rt");
    let rays = &j["rays"];
    let sum: u64 = ["primary", "shadow", "reflection", "refraction"]
        .iter()
        .map(|k| rays[k].as_u64().unwrap())
        .sum();
    assert_eq!(sum, j["rays_total"].as_u64().unwrap());
    assert_eq!(rays["primary"], 40 * 32);
    assert!(j["mrays_per_s"].as_f64().unwrap() > 0.0);
    let img = image::open(&png).unwrap();
    assert_eq!((img.width(), img.height()), (40, 32));
    for aov in ["depth", "normal", "instance"] {
        let p = dir.join(format!("room.{aov}.exr"));
        let exr = image::open(&p)
            .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
            .to_rgb32f();
        assert_eq!(exr.dimensions(), (40, 32));
        if aov == "instance" {
            // Exact integer ids (−1 for a miss).
            assert!(exr.pixels().all(|p| p[0] == p[0].round() && p[0] >= -1.0));
        }
    }
    // HDR output keeps values above 1 somewhere (the lamp-lit ceiling) — it is linear.
    let exr = dir.join("room.exr");
    let out = rqr()
        .args(["render", "--width", "40", "--height", "32", "-o"])
        .arg(&exr)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let hdr = image::open(&exr).unwrap().to_rgba32f();
    assert!(
        hdr.pixels().any(|p| p[0] > 1.0),
        "linear EXR should hold HDR values"
    );
}

#[test]
fn hybrid_render_traces_no_primary_rays() {
    let dir = tmpdir("hybrid");
    let mut pixels = Vec::new();
    for gbuffer in ["visibility", "full"] {
        let png = dir.join(format!("h_{gbuffer}.png"));
        let j = support::run_json(
            rqr()
                .args([
                    "render",
                    "--mode",
                    "hybrid",
                    "--gbuffer",
                    gbuffer,
                    "--backend",
                    "bvh",
                    "--width",
                    "32",
                    "--height",
                    "32",
                    "--json",
                    "-o",
                ])
                .arg(&png),
        );
        assert_eq!(j["backend"], "bvh");
        assert_eq!(j["gbuffer"], gbuffer);
        assert_eq!(j["rays"]["primary"], 0);
        assert!(j["gpu_ms"]["gbuffer"].as_f64().unwrap() >= 0.0);
        assert!(j["rays"]["shadow"].as_u64().unwrap() > 0);
        pixels.push(image::open(&png).unwrap().to_rgb8());
    }
    // Both layouts shade the same hits: the images agree (8-bit, small tolerance).
    let differing = pixels[0]
        .pixels()
        .zip(pixels[1].pixels())
        .filter(|(a, b)| a.0.iter().zip(b.0).any(|(x, y)| x.abs_diff(y) > 8))
        .count();
    assert!(differing <= 4, "{differing} of 1024 pixels differ");
}

#[test]
fn compare_writes_every_file_with_a_consistent_report() {
    let dir = tmpdir("compare");
    let out = rqr()
        .args([
            "compare",
            "--width",
            "48",
            "--height",
            "48",
            "--repeat",
            "1",
            "--backends",
            "all",
            "-o",
        ])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for f in [
        "rt.png",
        "hybrid.png",
        "flip.png",
        "side_by_side.png",
        "report.json",
        "report.md",
        "report.html",
    ] {
        assert!(dir.join(f).is_file(), "missing {f}");
    }
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("| backend |")
            && stdout.contains("PSNR")
            && stdout.contains("reflections/refractions"),
        "{stdout}"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap();
    let backends = report["backends"].as_array().unwrap();
    assert!(!backends.is_empty());
    // report.html: one self-contained viewer per backend (scripts/test-report-html.sh checks it
    // in a browser).
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    assert_eq!(
        html.matches("class=\"wipe-slider\"").count(),
        backends.len()
    );
    assert_eq!(
        html.matches("src=\"data:image/png;base64,").count(),
        4 * backends.len(),
        "rt, hybrid, FLIP and the FLIP legend of every backend, embedded"
    );
    for b in backends {
        for path in ["rt", "hybrid"] {
            let p = &b[path];
            let rays = &p["rays"];
            let sum: u64 = ["primary", "shadow", "reflection", "refraction"]
                .iter()
                .map(|k| rays[k].as_u64().unwrap())
                .sum();
            assert_eq!(
                sum,
                p["rays_total"].as_u64().unwrap(),
                "rays by kind add up"
            );
            for (pass, ms) in p["gpu_ms"].as_object().unwrap() {
                let ms = ms.as_f64().unwrap();
                assert!(ms.is_finite() && ms >= 0.0, "{pass}: {ms}");
            }
            assert!(p["total_ms"].as_f64().unwrap().is_finite());
            // Default depth 5: the shading pass's time is split by a depth-1 run.
            let split = &p["shading_split"];
            let shading_pass = if path == "rt" { "rt" } else { "hybrid shading" };
            assert_eq!(split["shading_ms"], p["gpu_ms"][shading_pass]);
            let (direct, secondary) = (
                split["direct_and_shadows_ms"].as_f64().unwrap(),
                split["reflections_refractions_ms"].as_f64().unwrap(),
            );
            assert!(direct > 0.0 && direct.is_finite(), "{split}");
            assert!(secondary >= 0.0 && secondary.is_finite(), "{split}");
        }
        assert_eq!(b["hybrid"]["rays"]["primary"], 0);
        let flip = &b["flip"];
        let mean = flip["flip_mean"].as_f64().unwrap();
        assert!((0.0..=0.05).contains(&mean), "FLIP mean {mean}");
        assert!(flip["flip_p95"].as_f64().unwrap() <= flip["flip_max"].as_f64().unwrap() + 1e-6);
        for f in b["files"].as_object().unwrap().values() {
            assert!(Path::new(f.as_str().unwrap()).is_file());
        }
    }
    // report.md names backends and settings as they are typed on the command line, unquoted.
    let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(
        md.contains("1 spp (center)") && md.contains("hybrid G-buffer: visibility"),
        "{md}"
    );
    if backends.len() > 1 {
        let cross = &report["rt_across_backends"];
        assert!(cross["primary_ids_agree"].as_f64().unwrap() >= 0.999);
        let line = md
            .lines()
            .find(|l| l.starts_with("Ray traced, "))
            .unwrap_or_else(|| panic!("no cross-backend line in {md}"));
        assert!(
            line.starts_with("Ray traced, hw vs bvh: FLIP mean ")
                || line.starts_with("Ray traced, bvh vs hw: FLIP mean "),
            "{line}"
        );
        assert!(!line.contains('"'), "{line}");
    }
    // FLIP of an image against itself is exactly 0.
    let rt = image::open(dir.join("rt.png")).unwrap().to_rgba8();
    let d = rqr::render::image::metrics::compare(rt.width(), rt.height(), rt.as_raw(), rt.as_raw());
    assert_eq!(d.flip_mean, 0.0);
}

#[test]
fn bench_reports_build_and_ray_throughput_per_backend() {
    let j = support::run_json(rqr().args([
        "bench",
        "--all-backends",
        "--all-bvh-builds",
        "--refit",
        "--width",
        "32",
        "--height",
        "24",
        "--repeat",
        "1",
        "--json",
    ]));
    let backends = j["backends"].as_array().unwrap();
    assert!(!backends.is_empty());
    for b in backends {
        let primary = &b["primary"];
        assert_eq!(primary["rays"], 32 * 24, "one primary ray per pixel");
        // One bounce per primary hit.
        assert_eq!(b["incoherent"]["rays"], primary["hits"]);
        for kind in ["primary", "incoherent"] {
            let m = b[kind]["mrays_per_s"].as_f64().unwrap();
            assert!(m.is_finite() && m > 0.0, "{kind}: {m}");
        }
        assert!(b["build"].is_object());
    }
    // --all-bvh-builds: the compute BVH once per builder, with the same hits, an SAH cost
    // each, and GPU phase times and peak scratch for the GPU build.
    let bvh: Vec<_> = backends.iter().filter(|b| b["backend"] == "bvh").collect();
    let builders: Vec<_> = bvh.iter().map(|b| b["build"]["builder"].clone()).collect();
    assert_eq!(builders, ["host", "gpu"]);
    assert_eq!(bvh[0]["primary"]["hits"], bvh[1]["primary"]["hits"]);
    for b in &bvh {
        let sah = b["build"]["sah_cost"].as_f64().unwrap();
        assert!(sah.is_finite() && sah >= 1.0, "SAH {sah}");
    }
    let gpu = &bvh[1]["build"];
    assert!(gpu["gpu_phases"]["sort_ms"].as_f64().unwrap() > 0.0);
    // --refit: refit timings for both builders, top-level rebuilds for the GPU build.
    for b in &bvh {
        let refit = &b["build"]["refit"];
        assert!(refit["refit_gpu_ms"].as_f64().unwrap() > 0.0, "{refit}");
        assert!(refit["levels"].as_u64().unwrap() >= 2, "{refit}");
    }
    assert!(gpu["refit"]["tlas_rebuild_gpu_ms"].as_f64().unwrap() > 0.0);
    assert!(gpu["peak_scratch_bytes"].as_u64().unwrap() > 0);
}

/// A colour PFM as (width, height, RGB rows top to bottom).
fn read_pfm(path: &Path) -> (u32, u32, Vec<f32>) {
    rqr::render::image::output::read_pfm(path).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn pfm_and_exr_outputs_hold_the_same_colour_albedo_normal_and_depth() {
    let dir = tmpdir("pfm");
    let (w, h) = (24u32, 16u32);
    let render = |out: &Path| {
        let o = rqr()
            .args(["render", "--width", "24", "--height", "16"])
            .args(["--aov", "albedo,normal,depth,instance", "-o"])
            .arg(out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    let (pfm, exr) = (dir.join("f.pfm"), dir.join("f.exr"));
    render(&pfm);
    render(&exr);
    let (pw, ph, colour) = read_pfm(&pfm);
    assert_eq!((pw, ph), (w, h));
    let hdr = image::open(&exr).unwrap().to_rgba32f();
    let from_exr: Vec<f32> = hdr.pixels().flat_map(|p| [p[0], p[1], p[2]]).collect();
    assert_eq!(colour, from_exr, "PFM and EXR colour differ");
    assert!(
        colour.iter().any(|&c| c > 1.0),
        "linear HDR keeps values above 1"
    );
    let aov = |name: &str| {
        let (aw, ah, p) = read_pfm(&dir.join(format!("f.{name}.pfm")));
        assert_eq!((aw, ah), (w, h), "{name}");
        let e: Vec<f32> = image::open(dir.join(format!("f.{name}.exr")))
            .unwrap()
            .to_rgb32f()
            .pixels()
            .flat_map(|p| p.0)
            .collect();
        assert_eq!(p, e, "{name}: PFM and EXR differ");
        p
    };
    let (albedo, normal, depth, instance) =
        (aov("albedo"), aov("normal"), aov("depth"), aov("instance"));
    let mut hits = 0;
    for px in 0..(w * h) as usize {
        let at = |v: &[f32]| glam::Vec3::from_slice(&v[px * 3..px * 3 + 3]);
        let id = instance[px * 3];
        assert_eq!(id, id.round(), "integer ids");
        if id < 0.0 {
            assert_eq!(at(&albedo), glam::Vec3::ZERO);
            assert_eq!(at(&normal), glam::Vec3::ZERO);
            assert_eq!(depth[px * 3], 0.0);
            continue;
        }
        hits += 1;
        let a = at(&albedo);
        assert!(
            a.min_element() >= 0.0 && a.max_element() <= 1.0,
            "albedo {a}"
        );
        assert!(
            (at(&normal).length() - 1.0).abs() < 1e-3,
            "normal {}",
            at(&normal)
        );
        assert!(depth[px * 3] > 0.0);
    }
    assert!(hits > (w * h) as usize / 2, "{hits} hits");
    // Some surface of the room is coloured (a wall's base colour is not grey).
    assert!(albedo
        .chunks_exact(3)
        .any(|c| (c[0] - c[1]).abs() > 0.2 || (c[1] - c[2]).abs() > 0.2));
}

#[test]
fn sequences_write_linear_pfm_frames() {
    let dir = tmpdir("pfm-seq");
    let out = dir.join("seq.pfm");
    let o = rqr()
        .args(["render", "--width", "16", "--height", "12", "--frames", "2"])
        .args(["--camera-path", "orbit:5", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let frames: Vec<Vec<f32>> = (0..2)
        .map(|k| {
            let (w, h, rgb) = read_pfm(&dir.join(format!("seq_{k:04}.pfm")));
            assert_eq!((w, h), (16, 12));
            assert!(rgb.iter().all(|v| v.is_finite() && *v >= 0.0));
            rgb
        })
        .collect();
    assert_ne!(frames[0], frames[1], "the camera moved between the frames");
}
