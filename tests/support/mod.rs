//! What the integration-test binaries share (each includes this tree as its `support`
//! module): a validated Vulkan context and the checks every GPU test ends with, running the
//! `rqr` binary with a time limit, running a test in a process of its own, and the helpers of
//! the submodules (crafted glTF files, KTX2 encoding, texture readback, ray tracing through
//! the test shader, closed-form optics, animated scenes, image cross-checks).
// Every binary uses a different part of it.
#![allow(dead_code)]

use rqr::vk::{Context, ContextOptions, VkError};

pub mod animated;
pub mod ktx2;
pub mod optics;
pub mod readback;
pub mod render_alike;
pub mod scene_files;
pub mod trace;

pub const INSTALL_HINT: &str =
    "Vulkan is required for the test suite: run `scripts/setup-vulkan.sh` (Debian 12: Mesa lavapipe from bookworm-backports, validation layers, glslc), then export VK_DRIVER_FILES=/usr/share/vulkan/icd.d/lvp_icd.json";

/// Opens the default device with the validation layer on. Panics with install instructions
/// when Vulkan or the layer is missing: GPU tests are never skipped silently.
pub fn gpu() -> Context {
    let opts = ContextOptions {
        validation: Some(true),
        // lavapipe JIT-compiles a pipeline inside its first dispatch; with a cold shader cache
        // and every test thread compiling at once that can take minutes on 2 cores.
        fence_timeout: std::time::Duration::from_secs(600),
        ..Default::default()
    };
    let ctx = match Context::new(&opts) {
        Ok(c) => c,
        Err(e @ (VkError::Loader(_) | VkError::NoDevice)) => panic!("{e}\n{INSTALL_HINT}"),
        Err(e) => panic!("cannot open a Vulkan device: {e}\n{INSTALL_HINT}"),
    };
    assert!(
        ctx.validation_enabled(),
        "VK_LAYER_KHRONOS_validation is not installed; the suite must run validated.\n{INSTALL_HINT}"
    );
    ctx
}

/// Asserts that the validation layer reported no error on `ctx` so far.
pub fn assert_validation_clean(ctx: &Context) {
    let errors = ctx.validation_errors();
    assert!(
        errors.is_empty(),
        "{} validation error(s):\n{}",
        errors.len(),
        errors.join("\n---\n")
    );
}

/// Runs the `rqr` binary with `args` and extra `env`, killing it after `limit` (a hang fails
/// the test instead of blocking the suite). Returns its output and how long it ran.
pub fn run_rqr(
    args: &[&str],
    env: &[(&str, &str)],
    limit: std::time::Duration,
) -> (std::process::Output, std::time::Duration) {
    run_rqr_to(args, env, limit, std::process::Stdio::piped())
}

/// [`run_rqr`] with stdout on a pipe whose reader has already exited, as `rqr … | head -1`
/// leaves it once `head` is done: every write to stdout fails with `EPIPE`, deterministically
/// (no race with a reader that closes "soon"). The returned output's stdout is empty.
#[cfg(unix)]
pub fn run_rqr_stdout_closed(
    args: &[&str],
    env: &[(&str, &str)],
    limit: std::time::Duration,
) -> (std::process::Output, std::time::Duration) {
    use std::process::{Command, Stdio};
    // The write end of `true`'s stdin: once `true` has exited, nothing holds the read end.
    let mut reader = Command::new("true")
        .stdin(Stdio::piped())
        .spawn()
        .expect("running true");
    let write_end = reader.stdin.take().unwrap();
    reader.wait().expect("waiting for true");
    run_rqr_to(args, env, limit, Stdio::from(write_end))
}

/// [`run_rqr`] with `stdout` as the child's stdout (captured when it is `Stdio::piped()`).
fn run_rqr_to(
    args: &[&str],
    env: &[(&str, &str)],
    limit: std::time::Duration,
    stdout: std::process::Stdio,
) -> (std::process::Output, std::time::Duration) {
    use std::io::Read;
    use std::process::{Command, Stdio};
    let start = std::time::Instant::now();
    let mut child = Command::new(env!("CARGO_BIN_EXE_rqr"))
        .args(args)
        // `auto` by the feature rule unless a test sets its own cache (env below overrides).
        .env("RQR_NO_AUTOTUNE", "1")
        .envs(env.iter().copied())
        .stdout(stdout)
        .stderr(Stdio::piped())
        .spawn()
        .expect("running rqr");
    // Drain the pipes while waiting: a chatty child must not block on a full pipe.
    let drain = |mut r: Box<dyn Read + Send>| {
        std::thread::spawn(move || {
            let mut v = Vec::new();
            r.read_to_end(&mut v).ok();
            v
        })
    };
    let stdout = child.stdout.take().map(|r| drain(Box::new(r)));
    let stderr = drain(Box::new(child.stderr.take().unwrap()));
    let status = loop {
        if let Some(s) = child.try_wait().expect("waiting for rqr") {
            break s;
        }
        if start.elapsed() > limit {
            child.kill().ok();
            child.wait().ok();
            panic!(
                "rqr {args:?} still running after {limit:?} (killed); stderr: {}",
                String::from_utf8_lossy(&stderr.join().unwrap())
            );
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    };
    let output = std::process::Output {
        status,
        stdout: stdout.map(|t| t.join().unwrap()).unwrap_or_default(),
        stderr: stderr.join().unwrap(),
    };
    (output, start.elapsed())
}

/// Runs `cmd` (an `rqr … --json` invocation), asserts it succeeded (printing its stderr
/// otherwise) and parses its stdout as one JSON document.
pub fn run_json(cmd: &mut std::process::Command) -> serde_json::Value {
    let out = cmd.output().expect("rqr runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON document on stdout")
}

/// Set in the process [`in_own_process`] starts: the name of the test it runs there.
const OWN_PROCESS_ENV: &str = "RQR_TEST_IN_OWN_PROCESS";

/// For the tests that need a process to themselves (resident memory, the process
/// environment): the other tests of a binary run in threads beside them. Called first in such
/// a test with `module_path!()`, the test's function name and the environment it needs;
/// returns `true` in the process it starts, where the caller then runs the test's body.
/// Elsewhere it runs this test binary again on that one test (with `env` added), asserts that
/// it ran and passed (printing its output), and returns `false`: the caller returns.
pub fn in_own_process(module: &str, test: &str, env: &[(&str, &str)]) -> bool {
    // libtest names a test by its path without the crate: `batch_soak::memory_stays_flat…`.
    let name = match module.split_once("::") {
        Some((_crate, path)) => format!("{path}::{test}"),
        None => test.to_string(),
    };
    if std::env::var(OWN_PROCESS_ENV).is_ok_and(|v| v == name) {
        return true;
    }
    let exe = std::env::current_exe().expect("the test binary's path");
    let out = std::process::Command::new(exe)
        .args([name.as_str(), "--exact", "--nocapture", "--test-threads=1"])
        .env(OWN_PROCESS_ENV, &name)
        .envs(env.iter().copied())
        .output()
        .expect("running the test binary");
    let stdout = String::from_utf8_lossy(&out.stdout);
    eprintln!("{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "{name} failed in its own process");
    assert!(
        stdout.contains("test result: ok. 1 passed"),
        "{name} did not run in its own process"
    );
    false
}
