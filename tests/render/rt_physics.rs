//! Closed-form checks of the ray-traced path on procedural scenes (no glTF, no goldens).

use crate::support;

use glam::{Mat4, Vec3};
use rqr::accel::BackendChoice;
use rqr::render::{RenderSettings, Renderer};
use rqr::scene::procedural::{assemble, look_at, quad};
use rqr::scene::{Instance, Light, LightKind, Material};

/// A white Lambert plane (20 m) under one point light.
fn lit_plane(intensity: f32, height: f32) -> rqr::scene::Scene {
    let white = Material {
        base_color: glam::Vec4::ONE,
        metallic: 0.0,
        roughness: 1.0,
        ..Default::default()
    };
    assemble(
        vec![quad(0)],
        vec![Instance {
            geometry: 0,
            transform: Mat4::from_scale(Vec3::splat(20.0)),
            node: 0,
        }],
        vec![white],
        vec![Light {
            kind: LightKind::Point,
            color: Vec3::ONE,
            intensity,
            range: f32::INFINITY,
            position: Vec3::new(0.3, height, -0.2),
            direction: -Vec3::Y,
            size: 0.0,
        }],
        vec![look_at(Vec3::new(0.0, 6.0, 4.0), Vec3::ZERO, 50.0)],
    )
}

#[test]
fn lambert_plane_matches_inverse_square_cosine_law() {
    let ctx = support::gpu();
    let (intensity, height) = (25.0f32, 2.0f32);
    let scene = lit_plane(intensity, height);
    let backend = BackendChoice::Auto.resolve(ctx.info()).unwrap().0;
    let renderer = Renderer::new(&ctx, &scene, backend).unwrap();
    let settings = RenderSettings {
        width: 64,
        height: 64,
        max_depth: 1,
        ambient: Vec3::ZERO,
        background: Vec3::ZERO,
        no_specular: true,
        ..Default::default()
    };
    let out = renderer
        .render_rt(&ctx, &settings, &scene.cameras[0], true)
        .unwrap();
    let light = scene.lights[0].position;
    let mut checked = 0;
    for (c, a) in out.color.iter().zip(&out.aov) {
        if a.instance() < 0 {
            continue;
        }
        let p = a.world_position();
        let d = light - p;
        let r2 = d.length_squared();
        let cos = d.normalize().y;
        let expected = intensity * cos / r2 / std::f32::consts::PI;
        for ch in &c[..3] {
            assert!(
                (ch - expected).abs() <= 0.01 * expected,
                "at {p}: {ch} vs E·albedo/π = {expected}"
            );
        }
        checked += 1;
    }
    assert!(checked > 2000, "only {checked} pixels hit the plane");
    support::assert_validation_clean(&ctx);
}
