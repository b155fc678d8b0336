//! Shared test helpers: a validated Vulkan context and the checks every GPU test ends with.
#![allow(dead_code)]

use rqr::vk::{Context, ContextOptions, VkError};

pub const INSTALL_HINT: &str =
    "Vulkan is required for the test suite: run `scripts/setup-vulkan.sh` (Debian 12: Mesa lavapipe from bookworm-backports, validation layers, shaderc), then export VK_DRIVER_FILES=/usr/share/vulkan/icd.d/lvp_icd.json";

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
