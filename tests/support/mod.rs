//! Shared test helpers: a validated Vulkan context and the checks every GPU test ends with.
#![allow(dead_code)]

use rqr::vk::{Context, ContextOptions, VkError};

pub mod animated;
pub mod optics;
pub mod render_alike;
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
