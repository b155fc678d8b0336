//! `rqr batch` end to end on tiny renders: outputs and results, failure isolation, resume
//! (missing output, stale temporary file), `--force`, and shards whose union is the
//! single-process run, byte for byte. Also the library API it is built on.

use crate::support;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

use serde_json::Value;

const LIMIT: Duration = Duration::from_secs(600);

fn assets() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/gltf")
}

fn work_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("rqr-batch-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A manifest in `dir` (scenes relative to it, copied in) with good and bad lines.
fn write_manifest(dir: &Path) -> PathBuf {
    for model in ["Box", "BoxTextured"] {
        std::fs::copy(
            assets().join(model).join(format!("{model}.glb")),
            dir.join(format!("{model}.glb")),
        )
        .unwrap();
    }
    let c2w = "[[1,0,0,0],[0,1,0,0],[0,0,1,3],[0,0,0,1]]";
    let lines = [
        r#"{"defaults": {"width": 20, "height": 16, "cameras": {"orbit": {"n": 2, "elevation_deg": [0, 30], "seed": 3}}}}"#.to_string(),
        r#"{"id": "box", "scene": "Box.glb", "aovs": ["depth"]}"#.to_string(),
        format!(r#"{{"id": "textured", "scene": "BoxTextured.glb", "cameras": [{{"c2w": {c2w}}}, {{"look_from": [2, 1, 2], "look_at": [0, 0, 0]}}], "format": "exr"}}"#),
        "this is not json".to_string(),
        r#"{"id": "missing", "scene": "nowhere.glb"}"#.to_string(),
        r#"{"id": "typo", "scene": "Box.glb", "widht": 4}"#.to_string(),
        r#"{"id": "box", "scene": "Box.glb"}"#.to_string(),
        r#"{"id": "skewed", "scene": "Box.glb", "cameras": [{"c2w": [[1,0.5,0,0],[0,1,0,0],[0,0,1,3],[0,0,0,1]]}]}"#.to_string(),
        r#"{"id": "hybrid", "scene": "Box.glb", "mode": "hybrid", "spp": 4}"#.to_string(),
    ];
    let path = dir.join("manifest.jsonl");
    std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    path
}

fn batch(args: &[&str]) -> std::process::Output {
    let mut full = vec!["batch"];
    full.extend_from_slice(args);
    support::run_rqr(&full, &[], LIMIT).0
}

/// Every file under `dir` except results files, with its bytes.
fn outputs(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut files = BTreeMap::new();
    for job in std::fs::read_dir(dir).unwrap().flatten() {
        if job.path().is_dir() {
            for f in std::fs::read_dir(job.path()).unwrap().flatten() {
                let rel = f.path().strip_prefix(dir).unwrap().to_path_buf();
                files.insert(rel, std::fs::read(f.path()).unwrap());
            }
        }
    }
    files
}

fn results(path: &Path) -> Vec<Value> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

fn by_line(results: &[Value], line: u64) -> &Value {
    results
        .iter()
        .find(|r| r["line"] == line)
        .unwrap_or_else(|| panic!("no result for line {line}: {results:?}"))
}

#[test]
fn bad_jobs_fail_alone_and_a_rerun_resumes_to_identical_outputs() {
    let dir = work_dir("resume");
    let manifest = write_manifest(&dir);
    let out = dir.join("out");
    let (m, o) = (manifest.to_str().unwrap(), out.to_str().unwrap());
    let first = batch(&[m, "--out", o]);
    let stderr = String::from_utf8_lossy(&first.stderr);
    assert_eq!(first.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    let r = results(&out.join("results-0-of-1.jsonl"));
    assert_eq!(r.len(), 8, "{r:?}");
    for (line, status) in [(2, "ok"), (3, "ok"), (9, "ok")] {
        assert_eq!(by_line(&r, line)["status"], status, "{r:?}");
    }
    let failures: [(u64, &str); 5] = [
        (4, "manifest.jsonl:4: not JSON"),
        (5, "nowhere.glb"),
        (6, "manifest.jsonl:6: field `widht`: unknown field `widht`"),
        (
            7,
            "manifest.jsonl:7: field `id`: duplicate id 'box' (first used on line 2)",
        ),
        (
            8,
            "manifest.jsonl:8: field `cameras[0].c2w`: rotation columns are not orthogonal",
        ),
    ];
    for (line, needle) in failures {
        let e = &by_line(&r, line);
        assert_eq!(e["status"], "failed");
        let msg = e["error"].as_str().unwrap();
        assert!(msg.contains(needle), "line {line}: {msg}");
    }
    let ok = by_line(&r, 2);
    assert_eq!(ok["views"], 2);
    let t = &ok["times"];
    for stage in [
        "load_ms",
        "upload_ms",
        "accel_build_ms",
        "render_gpu_ms",
        "readback_ms",
        "encode_ms",
    ] {
        assert!(t[stage].as_f64().unwrap() >= 0.0, "{stage}: {t}");
    }
    assert!(t["render_gpu_ms"].as_f64().unwrap() > 0.0, "{t}");
    // Results carry every view's camera; an explicit one comes back as given.
    assert_eq!(ok["cameras"].as_array().unwrap().len(), 2);
    let textured = &by_line(&r, 3)["cameras"][0];
    assert_eq!(
        textured["c2w"],
        serde_json::json!([
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 3.0],
            [0.0, 0.0, 0.0, 1.0]
        ])
    );
    assert!((textured["fov_y_deg"].as_f64().unwrap() - 40.0).abs() < 1e-4);
    let stdout = String::from_utf8_lossy(&first.stdout);
    assert!(
        stdout.contains("8 jobs (3 rendered, 0 skipped, 5 failed), 6 views"),
        "{stdout}"
    );
    let files = outputs(&out);
    let names: Vec<String> = files.keys().map(|p| p.display().to_string()).collect();
    assert_eq!(
        names,
        [
            "box/000.depth.exr",
            "box/000.png",
            "box/001.depth.exr",
            "box/001.png",
            "hybrid/000.png",
            "hybrid/001.png",
            "textured/000.exr",
            "textured/001.exr",
        ]
    );
    // The two orbit views differ (a real orbit, not one image twice).
    assert_ne!(
        files[Path::new("box/000.png")],
        files[Path::new("box/001.png")]
    );

    // A killed run: one output missing, a half-written temporary file left behind.
    std::fs::remove_file(out.join("box/001.png")).unwrap();
    let stale = out.join("box/.001.png.rqr-tmp-99999");
    std::fs::write(&stale, b"half a png").unwrap();
    let second = batch(&[m, "--out", o]);
    assert_eq!(second.status.code(), Some(1));
    let r = results(&out.join("results-0-of-1.jsonl"));
    assert_eq!(by_line(&r, 2)["status"], "ok", "{r:?}");
    assert_eq!(by_line(&r, 3)["status"], "skipped");
    assert_eq!(by_line(&r, 9)["status"], "skipped");
    assert!(!stale.exists(), "the stale temporary file was not removed");
    assert_eq!(
        outputs(&out),
        files,
        "a resumed run must give identical outputs"
    );

    // --force renders everything again, to the same bytes.
    let forced = batch(&[m, "--out", o, "--force"]);
    assert_eq!(forced.status.code(), Some(1));
    let r = results(&out.join("results-0-of-1.jsonl"));
    assert!(
        [2, 3, 9].iter().all(|&l| by_line(&r, l)["status"] == "ok"),
        "{r:?}"
    );
    assert_eq!(outputs(&out), files);

    // Shards: their union is the single-process run, byte for byte; each writes its results.
    let sharded = dir.join("sharded");
    for i in 0..3 {
        let s = format!("{i}/3");
        let run = batch(&[m, "--out", sharded.to_str().unwrap(), "--shard", &s]);
        assert!(run.status.code().is_some(), "shard {s}");
        let r = results(&sharded.join(format!("results-{i}-of-3.jsonl")));
        assert!(
            r.iter().all(|x| (x["line"].as_u64().unwrap() - 1) % 3 == i),
            "{r:?}"
        );
    }
    assert_eq!(outputs(&sharded), files);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn shard_and_output_errors_are_clear() {
    let dir = work_dir("errors");
    let manifest = write_manifest(&dir);
    let m = manifest.to_str().unwrap();
    let out = batch(&[
        m,
        "--out",
        dir.join("o").to_str().unwrap(),
        "--shard",
        "3/3",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("the index must be below the count"), "{err}");
    // A directory under a regular file cannot be created, whoever runs the test.
    let blocker = dir.join("file");
    std::fs::write(&blocker, b"").unwrap();
    let under = blocker.join("out");
    let out = batch(&[m, "--out", under.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("output directory") && err.contains("is not writable"),
        "{err}"
    );
    let out = batch(&[
        dir.join("none.jsonl").to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("cannot read the manifest") && err.contains("none.jsonl"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_library_renders_many_cameras_from_one_upload() {
    use rqr::batch::{BatchDevice, DeviceOptions, ViewOptions};
    let device = BatchDevice::open(&DeviceOptions {
        autotune: false,
        validation: Some(true),
        ..Default::default()
    })
    .expect("device");
    let scene = device
        .load_scene(&assets().join("Box/Box.glb"))
        .expect("scene");
    let cameras = scene.orbit(3, [10.0, 10.0], 40.0, 1, 1.0);
    let options = ViewOptions {
        width: 16,
        height: 12,
        aovs: true,
        ..Default::default()
    };
    let views = scene.render_views(&device, &cameras, &options).unwrap();
    assert_eq!(views.len(), 3);
    for v in &views {
        assert_eq!(v.rgba8.len(), 16 * 12 * 4);
        assert_eq!(v.aov.len(), 16 * 12);
        // The box is in view: some pixels hit it, some see the background.
        assert!(v.aov.iter().any(|a| a.instance() >= 0));
        assert!(v.aov.iter().any(|a| a.instance() < 0));
        assert!(v.gpu_ms > 0.0);
    }
    assert_ne!(views[0].rgba8, views[1].rgba8);
    support::assert_validation_clean(device.context());
}

#[test]
fn visible_devices_without_nvidia_gpus_warn_once_and_fall_back() {
    let dir = work_dir("visible");
    std::fs::copy(assets().join("Box/Box.glb"), dir.join("Box.glb")).unwrap();
    let manifest = dir.join("m.jsonl");
    std::fs::write(
        &manifest,
        r#"{"id": "a", "scene": "Box.glb", "width": 8, "height": 8, "cameras": {"orbit": {"n": 1}}}"#,
    )
    .unwrap();
    let out = dir.join("out");
    let args = [
        "batch",
        manifest.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    let (run, _) = support::run_rqr(&args, &[("CUDA_VISIBLE_DEVICES", "3")], LIMIT);
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{err}");
    assert_eq!(
        err.matches("no NVIDIA Vulkan device is present").count(),
        1,
        "{err}"
    );
    assert!(out.join("a/000.png").is_file());
    let (probe, _) = support::run_rqr(&["probe"], &[], LIMIT);
    let text = String::from_utf8_lossy(&probe.stdout);
    assert!(
        text.contains("PCI bus id") && text.contains("device UUID"),
        "{text}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_job_past_its_time_limit_fails_alone_and_the_next_one_renders() {
    let dir = work_dir("timeout");
    std::fs::copy(assets().join("Box/Box.glb"), dir.join("Box.glb")).unwrap();
    let manifest = dir.join("m.jsonl");
    // About 12 s per view on lavapipe (bvh), against a 5 s limit; the light job takes
    // milliseconds to render, but after the timeout the device restarts and its pipelines
    // compile again inside its limit (1.5 s was too short for that on a loaded machine).
    // No environment: preparing the built-in sky alone takes 0.5-2 s on lavapipe.
    std::fs::write(
        &manifest,
        concat!(
            r#"{"id": "heavy", "scene": "Box.glb", "width": 2048, "height": 2048, "spp": 32, "cameras": {"orbit": {"n": 2}}, "environment": "none"}"#,
            "\n",
            r#"{"id": "light", "scene": "Box.glb", "width": 16, "height": 16, "cameras": {"orbit": {"n": 2}}, "environment": "none"}"#,
            "\n"
        ),
    )
    .unwrap();
    let out = dir.join("out");
    let (m, o) = (manifest.to_str().unwrap(), out.to_str().unwrap());
    let run = batch(&[m, "--out", o, "--job-timeout", "5"]);
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{err}");
    let r = results(&out.join("results-0-of-1.jsonl"));
    assert_eq!(r[0]["status"], "failed", "{r:?}");
    let e = r[0]["error"].as_str().unwrap();
    assert!(e.contains("job time limit of 5.0 s (--job-timeout)"), "{e}");
    assert_eq!(r[1]["status"], "ok", "{r:?}");
    assert!(out.join("light/001.png").is_file());
    assert!(!out.join("heavy/001.png").exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn jobs_render_under_their_environment_and_a_missing_map_fails_alone() {
    let dir = work_dir("environment");
    std::fs::copy(assets().join("Box/Box.glb"), dir.join("Box.glb")).unwrap();
    let map = rqr::environment::EnvironmentMap::from_fn(32, |d| [0.2 + d.y.max(0.0), 0.3, 0.5]);
    std::fs::write(dir.join("sky.hdr"), rqr::environment::map::encode_hdr(&map)).unwrap();
    let lines = [
        r#"{"defaults": {"width": 16, "height": 16, "cameras": {"orbit": {"n": 1}}}}"#,
        r#"{"id": "lit", "scene": "Box.glb", "environment": "sky.hdr"}"#,
        r#"{"id": "plain", "scene": "Box.glb"}"#,
        r#"{"id": "nomap", "scene": "Box.glb", "environment": "missing.hdr"}"#,
    ];
    let manifest = dir.join("manifest.jsonl");
    std::fs::write(&manifest, lines.join("\n") + "\n").unwrap();
    let out = dir.join("out");
    let run = support::run_rqr(
        &[
            "batch",
            manifest.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        &[("RQR_CACHE_DIR", dir.join("cache").to_str().unwrap())],
        LIMIT,
    )
    .0;
    assert_eq!(
        run.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let r = results(&out.join("results-0-of-1.jsonl"));
    assert_eq!(by_line(&r, 2)["status"], "ok", "{r:?}");
    assert_eq!(by_line(&r, 3)["status"], "ok", "{r:?}");
    let e = by_line(&r, 4);
    assert_eq!(e["status"], "failed");
    assert!(e["error"].as_str().unwrap().contains("missing.hdr"), "{e}");
    let lit = std::fs::read(out.join("lit/000.png")).unwrap();
    let plain = std::fs::read(out.join("plain/000.png")).unwrap();
    assert_ne!(lit, plain, "the environment changes the image");
}

#[test]
fn a_kept_environment_renders_the_same_bytes_as_a_fresh_one() {
    let dir = work_dir("kept-environment");
    std::fs::copy(assets().join("Box/Box.glb"), dir.join("Box.glb")).unwrap();
    let map = rqr::environment::EnvironmentMap::from_fn(32, |d| [0.2 + d.y.max(0.0), 0.3, 0.5]);
    std::fs::write(dir.join("sky.hdr"), rqr::environment::map::encode_hdr(&map)).unwrap();
    let defaults = r#"{"defaults": {"width": 16, "height": 16, "cameras": {"orbit": {"n": 1}}}}"#;
    // The built-in sky twice (the second job reuses it), a file, a job without any (which
    // leaves the file's kept), the file again, the sky again (prepared anew).
    let jobs = [
        r#"{"id": "sky1", "scene": "Box.glb"}"#,
        r#"{"id": "sky2", "scene": "Box.glb"}"#,
        r#"{"id": "file1", "scene": "Box.glb", "environment": "sky.hdr"}"#,
        r#"{"id": "none", "scene": "Box.glb", "environment": "none"}"#,
        r#"{"id": "file2", "scene": "Box.glb", "environment": "sky.hdr"}"#,
        r#"{"id": "sky3", "scene": "Box.glb"}"#,
    ];
    let cache = dir.join("cache");
    let run = |lines: &[&str], out: &Path| {
        let manifest = out.with_extension("jsonl");
        std::fs::write(&manifest, lines.join("\n") + "\n").unwrap();
        let args = [
            "batch",
            manifest.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        let run = support::run_rqr(&args, &[("RQR_CACHE_DIR", cache.to_str().unwrap())], LIMIT).0;
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
    };
    let together = dir.join("together");
    run(&[&[defaults][..], &jobs[..]].concat(), &together);
    let png = |out: &Path, id: &str| std::fs::read(out.join(id).join("000.png")).unwrap();
    for (k, job) in jobs.iter().enumerate() {
        let alone = dir.join(format!("alone{k}"));
        run(&[defaults, job], &alone);
        let id = serde_json::from_str::<Value>(job).unwrap()["id"].to_string();
        let id = id.trim_matches('"');
        assert!(png(&together, id) == png(&alone, id), "job {id} differs");
    }
    assert_ne!(png(&together, "sky1"), png(&together, "file1"));
    assert_ne!(png(&together, "sky1"), png(&together, "none"));
    std::fs::remove_dir_all(&dir).ok();
}
