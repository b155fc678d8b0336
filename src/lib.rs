//! rqr: a glTF 2.0 renderer on raw Vulkan (`ash`) with a pure ray-traced (Whitted) path and a
//! hybrid raster + ray-traced path. Rays go through hardware acceleration structures with
//! `VK_KHR_ray_query` where the device has them, otherwise through rqr's own BVH traversed in
//! compute shaders.
//!
//! Modules: [`vk`] (Vulkan plumbing), [`interface`] (the host/shader interface, one source for
//! Rust and GLSL), [`accel`] (ray backends), [`scene`] (glTF loading and texture upload),
//! [`render`] (passes and drivers), [`shaders`] (embedded SPIR-V), [`device_select`] (which device, and what `auto`
//! picks, measured), [`batch`] (many assets in one process: `rqr batch` and its library API).

pub mod accel;
pub mod batch;
pub mod cache;
pub mod device_select;
pub mod environment;
pub mod interface;
pub mod render;
pub mod scene;
pub mod vk;

/// SPIR-V compiled by `build.rs`, one constant per shader (and per ray backend variant).
pub mod shaders {
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
    include!(concat!(env!("OUT_DIR"), "/interface_glsl.rs"));
}

/// Library-level error.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A Vulkan failure.
    #[error(transparent)]
    Vk(#[from] vk::VkError),
    /// Invalid output.
    #[error(transparent)]
    Output(#[from] render::image::output::OutputError),
    /// The requested ray backend is unavailable.
    #[error(transparent)]
    Backend(#[from] accel::BackendUnavailable),
    /// A scene file could not be loaded.
    #[error(transparent)]
    Scene(#[from] scene::SceneError),
    /// Building or uploading the compute BVH failed.
    #[error(transparent)]
    Bvh(#[from] accel::bvh::BvhError),
    /// An environment map could not be loaded.
    #[error(transparent)]
    Environment(#[from] environment::EnvironmentError),
    /// A setting that cannot work (a usage mistake, named by its flag).
    #[error(transparent)]
    Settings(#[from] SettingsError),
}

pub use render::settings::SettingsError;

/// `error` and its [`source`](std::error::Error::source)s joined with `": "`, outermost first:
/// the one-line message `rqr: error:` prints (anyhow's `{:#}`). rqr's errors leave their
/// sources out of their own messages, so each clause appears once; printing only `{error}`
/// drops the causes.
pub fn error_chain(error: &(dyn std::error::Error + 'static)) -> String {
    let mut out = error.to_string();
    let mut cause = error.source();
    while let Some(c) = cause {
        out.push_str(": ");
        out.push_str(&c.to_string());
        cause = c.source();
    }
    out
}

/// Result alias for the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;
