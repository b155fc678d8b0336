//! Helpers of the animated-scene tests (`temporal::animation_update`,
//! `temporal::reproject_animated`).

use rqr::scene::{AnimationSelection, Camera, LoadOptions, Scene};

/// Loads `assets/gltf/<rel>` in its rest pose, with the indices of its first animation.
pub fn load(rel: &str) -> (Scene, Vec<usize>) {
    let path = super::scene_files::asset(rel);
    let s = rqr::scene::load(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let first = s.select_animations(&AnimationSelection::default()).unwrap();
    (s, first)
}

/// One camera for every frame of a scene: the automatic camera of its rest bounds, pulled
/// back so that the moving parts stay in view.
pub fn camera(rest: &Scene) -> Camera {
    let mut bounds = rest.bounds;
    let c = bounds.center();
    let half = (bounds.max - bounds.min) * 0.75;
    bounds.min = c - half;
    bounds.max = c + half;
    rqr::scene::auto_camera(&bounds, 1.0)
}
