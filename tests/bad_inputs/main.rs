//! The bad-input corpus (`corpus.rs`, plus the fuzzer's finds in `regressions/`) through the
//! library and through the real binary: every case fails with a one-line error naming the
//! file and the element (exit code 1), or loads with the documented warning and then renders
//! with every backend; never a panic, a hang or a validation error.
//!
//! Beside the corpus: the loader's `SceneError`s on crafted broken files (`scene_errors`);
//! broken compressed meshes (`compression`) and KTX2 textures (`ktx2`); bad layer factors and
//! variants (`extensions`), animation choices (`animation`), images beyond the device
//! (`images`); bad command lines, `rqr info` on broken files, unmatched or missing devices,
//! resolutions beyond the device and GPU timeouts through the binary (`cli_errors`); broken
//! environment maps (`environment`) and batch manifests (`manifest`); and error messages that
//! never repeat their cause (`error_chains`).

#[path = "../support/mod.rs"]
mod support;

mod animation;
mod cli_errors;
mod compression;
mod corpus;
mod environment;
mod error_chains;
mod extensions;
mod images;
mod ktx2;
mod manifest;
mod scene_errors;

use std::path::{Path, PathBuf};
use std::process::Output;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use corpus::{Case, Expect};
use rqr::scene::{self, LoadOptions};

/// Longest a load may take in the library (a hang fails the test rather than blocking it).
const LOAD_LIMIT: Duration = Duration::from_secs(60);
/// Longest `rqr info` may take.
const INFO_LIMIT: Duration = Duration::from_secs(60);
/// Longest a 32×32 `rqr render` may take (lavapipe compiles pipelines on first use).
const RENDER_LIMIT: Duration = Duration::from_secs(300);

fn work_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("rqr-bad-inputs-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes the case's files into `dir/name/`; returns the scene path.
fn write_case(dir: &Path, case: &Case) -> PathBuf {
    let d = dir.join(&case.name);
    std::fs::create_dir_all(&d).unwrap();
    for (rel, data) in &case.files {
        std::fs::write(d.join(rel), data).unwrap();
    }
    d.join(&case.files[0].0)
}

/// Runs `rqr args` with validation on, killing it after `limit`.
fn rqr(args: &[&str], limit: Duration) -> (Output, Duration) {
    support::run_rqr(args, &[("RQR_VALIDATION", "1")], limit)
}

/// Loads in a thread with a deadline: `Ok(scene stats)` or `Err(message)`, the message with
/// its whole chain of causes as `rqr: error:` prints it.
fn load_bounded(path: &Path) -> Result<usize, String> {
    let (tx, rx) = mpsc::channel();
    let p = path.to_path_buf();
    std::thread::spawn(move || {
        let r = scene::load(&p, &LoadOptions::default())
            .map(|s| s.triangle_count())
            .map_err(|e| rqr::error_chain(&e));
        tx.send(r).ok();
    });
    rx.recv_timeout(LOAD_LIMIT)
        .unwrap_or_else(|_| panic!("loading {} took over {LOAD_LIMIT:?}", path.display()))
}

fn no_panic_or_validation(what: &str, out: &Output) {
    let err = String::from_utf8_lossy(&out.stderr);
    for bad in [
        "panicked",
        "RUST_BACKTRACE",
        "Validation Error",
        "SIGSEGV",
        "stack overflow",
    ] {
        assert!(!err.contains(bad), "{what}: {err}");
    }
}

/// Checks one case through the library and `rqr info` (and `rqr render` when it loads).
fn check(dir: &Path, case: &Case, render: bool) {
    let path = write_case(dir, case);
    let shown = path.display().to_string();
    let what = format!("case {}", case.name);
    let lib = load_bounded(&path);
    let (info, took) = rqr(&["info", &shown], INFO_LIMIT);
    no_panic_or_validation(&what, &info);
    let stderr = String::from_utf8_lossy(&info.stderr).into_owned();
    match &case.expect {
        Expect::Fails(_) | Expect::FailsAny => {
            let e = lib
                .err()
                .unwrap_or_else(|| panic!("{what}: the library loaded it"));
            assert!(e.starts_with(&format!("{shown}: ")), "{what}: {e}");
            assert!(!e.contains('\n'), "{what}: not one line: {e}");
            if let Expect::Fails(needles) = &case.expect {
                for n in needles {
                    assert!(e.contains(n), "{what}: '{n}' not in '{e}'");
                }
            }
            assert_eq!(info.status.code(), Some(1), "{what}: {stderr}");
            let lines: Vec<&str> = stderr.lines().filter(|l| !l.contains(" WARN ")).collect();
            assert_eq!(lines, [format!("rqr: error: {e}")], "{what}");
            assert!(info.stdout.is_empty(), "{what}");
        }
        Expect::Loads { warning, render: r } => {
            if let Err(e) = lib {
                panic!("{what}: {e}");
            }
            assert!(info.status.success(), "{what}: {stderr}");
            if let Some(w) = warning {
                assert!(
                    stderr.contains(w),
                    "{what}: warning '{w}' not in '{stderr}'"
                );
            }
            if *r && render {
                for backend in ["hw", "bvh"] {
                    let png = dir.join(format!("{}-{backend}.png", case.name));
                    let args = [
                        "render",
                        &shown,
                        "--width",
                        "32",
                        "--height",
                        "32",
                        "--backend",
                        backend,
                        "-o",
                        png.to_str().unwrap(),
                    ];
                    let (out, _) = rqr(&args, RENDER_LIMIT);
                    no_panic_or_validation(&what, &out);
                    assert!(
                        out.status.success(),
                        "{what}: render --backend {backend}: {}",
                        String::from_utf8_lossy(&out.stderr)
                    );
                    let img = image::open(&png).unwrap().to_rgba8();
                    assert_eq!(img.dimensions(), (32, 32), "{what}");
                }
            }
        }
    }
    assert!(took < INFO_LIMIT, "{what}: rqr info took {took:?}");
    std::fs::remove_dir_all(path.parent().unwrap()).ok();
}

#[test]
fn named_cases_fail_cleanly_or_render() {
    let dir = work_dir("named");
    let mut cases = corpus::cases();
    assert!(cases.len() >= 60, "{} cases", cases.len());
    // RQR_BAD_INPUT=substring runs only the matching cases (debugging).
    if let Ok(only) = std::env::var("RQR_BAD_INPUT") {
        cases.retain(|c| c.name.contains(&only));
    }
    for case in &cases {
        let start = Instant::now();
        check(&dir, case, true);
        eprintln!("{:<45} {:>6.2} s", case.name, start.elapsed().as_secs_f64());
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_million_nodes_side_by_side_render() {
    let dir = work_dir("flat");
    check(&dir, &corpus::heavy_case("nodes_million_flat"), true);
}

#[test]
fn a_million_nodes_deep_render() {
    let dir = work_dir("deep");
    check(&dir, &corpus::heavy_case("nodes_million_deep"), true);
}

#[test]
fn a_16k_by_16k_texture_renders() {
    let dir = work_dir("16k");
    check(&dir, &corpus::heavy_case("image_16k_by_16k"), true);
}

#[test]
fn every_cut_point_of_a_glb_fails_cleanly() {
    let dir = work_dir("cuts");
    let cases = corpus::truncations();
    assert!(cases.len() > 500, "{} cut points", cases.len());
    for case in &cases {
        check(&dir, case, false);
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn fuzzer_regressions_fail_cleanly() {
    let dir = work_dir("regressions");
    for case in &corpus::regressions() {
        check(&dir, case, false);
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Every animation, skin and morph case of the corpus is also a fuzz seed
/// (`fuzz/seeds/<case>.<ext>`, byte for byte), so the fuzzer starts from each of these
/// failure modes. `RQR_WRITE_SEEDS=1` (re)writes the seeds after the corpus changed.
#[test]
fn animation_cases_are_fuzz_seeds() {
    let seeds = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds");
    let write = std::env::var_os("RQR_WRITE_SEEDS").is_some();
    let mut cases = Vec::new();
    animation::cases(&mut cases);
    assert!(cases.len() >= 9, "{} animation cases", cases.len());
    let mut missing = Vec::new();
    for case in &cases {
        assert_eq!(
            case.files.len(),
            1,
            "{}: a seed is one self-contained file",
            case.name
        );
        let (rel, data) = &case.files[0];
        let ext = Path::new(rel)
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("gltf");
        let seed = seeds.join(format!("{}.{ext}", case.name));
        if write {
            std::fs::write(&seed, data).unwrap();
        }
        if std::fs::read(&seed).ok().as_ref() != Some(data) {
            missing.push(seed.display().to_string());
        }
    }
    assert!(
        missing.is_empty(),
        "fuzz seeds missing or stale (RQR_WRITE_SEEDS=1 rewrites them): {missing:?}"
    );
}
