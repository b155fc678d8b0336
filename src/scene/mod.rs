//! glTF 2.0 → a plain [`Scene`], then GPU buffers.
//!
//! [`load`] / [`load_slice`] read `.gltf` / `.glb` files, [`load_default`] the built-in
//! Cornell-style scene; [`auto_camera`] and [`look_at_camera`] make cameras;
//! [`textures::GpuTextures`] uploads a scene's images.

mod accessor;
pub mod animation;
pub mod camera;
mod compression;
mod decoded;
mod default_scene;
pub mod deform;
mod draco;
mod error;
pub mod extensions;
pub mod geometry;
pub mod gpu;
mod image;
pub(crate) mod ktx2;
pub mod layout;
mod loader;
mod material_ext;
pub mod morph;
pub mod pose;
pub mod procedural;
pub mod skin;
pub mod textures;
pub mod types;
mod variants;

pub use animation::{Animation, AnimationSelection};
pub use camera::{auto_camera, default_lights, look_at_camera};
pub use default_scene::{load_default, DEFAULT_SCENE_GLB};
pub use error::SceneError;
pub use extensions::{ExtensionStatus, ExtensionSupport, SUPPORTED_EXTENSIONS};
pub use image::MAX_IMAGE_SIZE;
pub use loader::{
    load, load_slice, load_timed, texture_transform_matrix, LoadOptions, MAX_COORDINATE,
    MAX_INSTANCES, MAX_READ_BYTES, MAX_SCENE_TEXELS, MAX_SCENE_TRIANGLES, MAX_SCENE_VERTICES,
};
pub use textures::TextureFormat;
pub use types::*;
