//! Hardware ray queries vs rqr's compute BVH on real scenes: the primary hits (instance,
//! primitive, depth) must agree pixel for pixel from several camera views.

use crate::support;
use crate::support::scene_files::load_asset;

use glam::{Mat4, Vec3};
use rqr::accel::Backend;
use rqr::render::{RenderSettings, Renderer};
use rqr::scene::{Camera, Scene};

/// The automatic camera, and the same camera orbited about the scene centre by ±35° and raised.
fn views(scene: &Scene) -> Vec<Camera> {
    let base = rqr::scene::auto_camera(&scene.bounds, 1.0);
    let centre = scene.bounds.center();
    let orbit = |deg: f32, lift: f32| {
        let mut c = base;
        let pivot = Mat4::from_translation(centre)
            * Mat4::from_rotation_y(deg.to_radians())
            * Mat4::from_translation(-centre);
        c.camera_to_world = Mat4::from_translation(Vec3::Y * lift * scene.bounds.diagonal())
            * pivot
            * c.camera_to_world;
        c
    };
    let mut v = vec![base, orbit(35.0, 0.1), orbit(-35.0, 0.2)];
    v.extend(scene.cameras.first().copied());
    v
}

fn cross_check(name: &str, scene: &Scene) {
    let ctx = support::gpu();
    assert!(
        ctx.features().ray_query,
        "the cross-check needs a device with ray queries (lavapipe has them)"
    );
    let hw = Renderer::new(&ctx, scene, Backend::Hw).unwrap();
    let bvh = Renderer::new(&ctx, scene, Backend::Bvh).unwrap();
    let settings = RenderSettings {
        width: 128,
        height: 128,
        max_depth: 1,
        ..Default::default()
    };
    for (v, camera) in views(scene).iter().enumerate() {
        let a = hw.render_rt(&ctx, &settings, camera, true).unwrap();
        let b = bvh.render_rt(&ctx, &settings, camera, true).unwrap();
        let pixels = a.aov.len();
        let mut id_mismatch = 0;
        let mut hits = 0;
        for (x, y) in a.aov.iter().zip(&b.aov) {
            if x.instance() != y.instance() || x.primitive() != y.primitive() {
                id_mismatch += 1;
                continue;
            }
            if x.instance() >= 0 {
                hits += 1;
                let rel = (x.depth() - y.depth()).abs() / x.depth().max(1e-6);
                assert!(
                    rel <= 1e-5,
                    "{name} view {v}: depth {} vs {} (rel {rel:e})",
                    x.depth(),
                    y.depth()
                );
            }
        }
        assert!(
            hits > pixels / 20,
            "{name} view {v}: only {hits} pixels hit anything"
        );
        let agree = 1.0 - id_mismatch as f64 / pixels as f64;
        assert!(
            agree >= 0.9999,
            "{name} view {v}: instance+primitive agree on {:.4} % ({id_mismatch} pixels differ)",
            agree * 100.0
        );
        // Same hits → same shadow rays (trace_any) and the same secondary ray counts.
        assert_eq!(a.rays.shadow, b.rays.shadow, "{name} view {v}: shadow rays");
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn builtin_scene_backends_agree() {
    cross_check("built-in", &rqr::scene::load_default().unwrap());
}

#[test]
fn instanced_scene_backends_agree() {
    cross_check(
        "SimpleInstancing",
        &load_asset("SimpleInstancing/SimpleInstancing.glb"),
    );
}

#[test]
fn alpha_mask_scene_backends_agree() {
    cross_check(
        "AlphaBlendModeTest",
        &load_asset("AlphaBlendModeTest/AlphaBlendModeTest.glb"),
    );
}

#[test]
fn many_triangle_scene_backends_agree() {
    cross_check(
        "TransmissionRoughnessTest (78k triangles)",
        &load_asset("TransmissionRoughnessTest/TransmissionRoughnessTest.glb"),
    );
}

/// An animated frame: the posed scene (skinned, node-animated or morphed) must give the same
/// primary hits on both backends. (BoxAnimated is not used: its boxes share faces, so the
/// backends already disagree on 15 % of its rest-pose pixels, animation or not.)
#[test]
fn animated_frame_backends_agree() {
    for (rel, time) in [
        ("CesiumMan/CesiumMan.glb", 0.7),
        ("InterpolationTest/InterpolationTest.glb", 0.6),
        ("AnimatedMorphCube/AnimatedMorphCube.glb", 1.0),
    ] {
        let rest = load_asset(rel);
        let all = rest
            .select_animations(&rqr::scene::AnimationSelection::All)
            .unwrap();
        let posed = rest.posed(&all, time);
        assert_ne!(
            posed.bounds, rest.bounds,
            "{rel}: the animation moves something at t={time}"
        );
        cross_check(&format!("{rel} t={time}"), &posed);
    }
}
