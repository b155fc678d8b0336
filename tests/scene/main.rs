//! glTF to `Scene`: the loader on the copied Khronos sample models and on crafted files, the
//! built-in scene, the extensions (quantization, meshopt and Draco compression, KTX2 and WebP
//! textures, texture coordinate sets, layered materials, variants), texture upload, and
//! animation playback (interpolation, skinning, morphing).
//!
//! One module per subject: `cargo test --test scene scene_ktx2::` runs one.

#[path = "../support/mod.rs"]
mod support;

mod animation;
mod scene_compression;
mod scene_default;
mod scene_extensions;
mod scene_gltf;
mod scene_ktx2;
mod scene_quantization;
mod scene_textures;
mod scene_variants;
