//! The built-in scene rendered when no file is given (see `examples/make_default_scene.rs`).

use super::error::SceneError;
use super::loader::{load_slice, LoadOptions};
use super::types::Scene;

/// `assets/default_scene.glb`, embedded in the binary.
pub const DEFAULT_SCENE_GLB: &[u8] = include_bytes!("../../assets/default_scene.glb");

/// Loads the built-in Cornell-style room: a checker-textured floor, red and green side walls,
/// a diffuse box, a mirror sphere, a glass sphere and a glass cube (transmission 1, ior 1.5,
/// KHR_materials_volume), a point light and a spot light, and a camera looking into the room.
/// [`Scene::source`] is `built-in`.
pub fn load_default() -> Result<Scene, SceneError> {
    load_slice(DEFAULT_SCENE_GLB, None, "built-in", &LoadOptions::default())
}
