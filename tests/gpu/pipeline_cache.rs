//! The on-disk pipeline cache: written when a context closes, loaded by the next one for the
//! same device, and a corrupt file gives one warning and a rebuilt cache, never a failure.

use crate::support;

use std::path::{Path, PathBuf};
use std::time::Duration;

use rqr::batch::{BatchDevice, DeviceOptions, ViewOptions};
use rqr::vk::{pipeline_cache, Context, ContextOptions};

fn tmp(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("rqr-pipeline-cache-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn box_glb() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/gltf/Box/Box.glb")
}

/// Renders one tiny view with the cache in `dir`, then closes the device (which saves it).
fn render_once(dir: &Path) {
    let device = BatchDevice::open(&DeviceOptions {
        pipeline_cache_dir: Some(dir.to_path_buf()),
        autotune: false,
        ..Default::default()
    })
    .expect(support::INSTALL_HINT);
    let scene = device.load_scene(&box_glb()).unwrap();
    let cameras = scene.orbit(1, [10.0, 10.0], 40.0, 0, 1.0);
    let options = ViewOptions {
        width: 8,
        height: 8,
        ..Default::default()
    };
    scene.render_views(&device, &cameras, &options).unwrap();
}

/// Whether a fresh context finds a usable cache in `dir`.
fn loads(dir: &Path) -> bool {
    let mut ctx = Context::new(&ContextOptions::default()).unwrap();
    let loaded = ctx.use_pipeline_cache_dir(dir).unwrap();
    // Close without writing over what the test inspects.
    drop(ctx);
    loaded
}

#[test]
fn the_cache_is_saved_reloaded_and_rebuilt_when_corrupt() {
    let dir = tmp("cycle");
    render_once(&dir);
    let files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .collect();
    assert_eq!(files.len(), 1, "{files:?}");
    let file = &files[0];
    let name = file.file_name().unwrap().to_string_lossy().into_owned();
    assert!(
        name.starts_with("pipelines-") && name.ends_with(".bin"),
        "{name}"
    );
    let ctx = Context::new(&ContextOptions::default()).unwrap();
    assert_eq!(pipeline_cache::cache_file(&dir, ctx.info()), *file);
    let bytes = std::fs::read(file).unwrap();
    assert!(pipeline_cache::decode(&bytes, ctx.info()).is_ok());
    drop(ctx);
    assert!(loads(&dir), "a valid cache must load");

    // Corrupt it: the next context starts empty (with a warning) and writes a good one.
    let mut bad = bytes.clone();
    let last = bad.len() - 1;
    bad[last] ^= 0x5a;
    std::fs::write(file, &bad).unwrap();
    assert!(!loads(&dir), "a corrupt cache must not load");
    std::fs::write(file, &bad).unwrap();
    render_once(&dir);
    assert!(loads(&dir), "the rebuilt cache must load");
    // No temporary file is left behind.
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_corrupt_cache_warns_once_through_the_binary() {
    let dir = tmp("binary");
    let scene_dir = tmp("binary-scene");
    std::fs::copy(box_glb(), scene_dir.join("Box.glb")).unwrap();
    let manifest = scene_dir.join("m.jsonl");
    std::fs::write(&manifest, r#"{"id": "a", "scene": "Box.glb", "width": 8, "height": 8, "cameras": {"orbit": {"n": 2}}}"#).unwrap();
    let out = scene_dir.join("out");
    let args = [
        "batch",
        manifest.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--force",
    ];
    let env = [("RQR_CACHE_DIR", dir.to_str().unwrap())];
    let limit = Duration::from_secs(600);
    let (first, _) = support::run_rqr(&args, &env, limit);
    assert!(
        first.status.success(),
        "{}",
        String::from_utf8_lossy(&first.stderr)
    );
    let file = std::fs::read_dir(&dir)
        .unwrap()
        .flatten()
        .find(|e| e.file_name().to_string_lossy().starts_with("pipelines-"))
        .expect("a pipeline cache in RQR_CACHE_DIR")
        .path();
    std::fs::write(&file, b"RQRPIPE1 not really").unwrap();
    let (second, _) = support::run_rqr(&args, &env, limit);
    let err = String::from_utf8_lossy(&second.stderr);
    assert!(second.status.success(), "{err}");
    assert_eq!(err.matches("is unusable").count(), 1, "{err}");
    assert!(err.contains("rebuilding it"), "{err}");
    let (third, _) = support::run_rqr(&args, &env, limit);
    let err = String::from_utf8_lossy(&third.stderr);
    assert!(
        !err.contains("unusable"),
        "the rebuilt cache must be valid: {err}"
    );
    std::fs::remove_dir_all(&dir).ok();
    std::fs::remove_dir_all(&scene_dir).ok();
}
