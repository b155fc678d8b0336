//! Cross-checks of the two rendering paths and of the Whitted controls on the procedural
//! Cornell room (independent of the glTF loader): hybrid == ray-traced where it should be,
//! recursion depth and the weight cut-off behave as the seed says.

use crate::support;
use crate::support::scene_files::load_asset;

use glam::{Mat4, Vec3};
use rqr::accel::{Backend, BackendChoice};
use rqr::render::image::metrics;
use rqr::render::passes::draw_list;
use rqr::render::passes::gbuffer::GbufferLayout;
use rqr::render::{RenderOutput, RenderSettings, Renderer, SamplerKind};
use rqr::scene::procedural::{assemble, cornell, look_at, quad};
use rqr::scene::{Instance, Material, Projection, Scene};

fn settings(size: u32) -> RenderSettings {
    RenderSettings {
        width: size,
        height: size,
        ..Default::default()
    }
}

/// Every backend the device runs (lavapipe: both).
fn backends(ctx: &rqr::vk::Context) -> Vec<Backend> {
    let mut b = vec![Backend::Bvh];
    if ctx.features().ray_query {
        b.insert(0, Backend::Hw);
    }
    b
}

fn diff(a: &RenderOutput, b: &RenderOutput) -> metrics::ImageDiff {
    metrics::compare(a.width, a.height, &a.rgba8, &b.rgba8)
}

/// The invariant of the two paths on one scene: same camera, spp and sampler → PSNR ≥ 40 dB,
/// FLIP mean ≤ 0.02, primary ids on ≥ 99.9 % of pixels, the same secondary rays (± silhouettes),
/// with both G-buffer layouts.
fn assert_hybrid_matches_rt(name: &str, scene: &Scene, size: u32) {
    let ctx = support::gpu();
    let draws = draw_list::draws(scene);
    let camera = scene
        .cameras
        .first()
        .copied()
        .unwrap_or_else(|| rqr::scene::auto_camera(&scene.bounds, 1.0));
    for backend in backends(&ctx) {
        let renderer = Renderer::new(&ctx, scene, backend).unwrap();
        for (spp, sampler, gbuffer) in [
            (1, SamplerKind::Center, GbufferLayout::Visibility),
            (1, SamplerKind::Center, GbufferLayout::Full),
            (4, SamplerKind::Grid, GbufferLayout::Visibility),
            (4, SamplerKind::Grid, GbufferLayout::Full),
        ] {
            let s = RenderSettings {
                spp,
                sampler,
                gbuffer,
                ..settings(size)
            };
            let rt = renderer.render_rt(&ctx, &s, &camera, true).unwrap();
            let hy = renderer
                .render_hybrid(&ctx, &draws, &s, &camera, true)
                .unwrap();
            let d = diff(&rt, &hy);
            assert!(
                d.psnr_db >= 40.0 && d.flip_mean <= 0.02,
                "{name} {backend:?} spp {spp} {gbuffer:?}: PSNR {:.1} dB, FLIP mean {:.4}",
                d.psnr_db,
                d.flip_mean
            );
            let same_ids = rt
                .aov
                .iter()
                .zip(&hy.aov)
                .filter(|(a, b)| a.instance() == b.instance() && a.primitive() == b.primitive())
                .count();
            assert!(
                same_ids as f64 >= 0.999 * rt.aov.len() as f64,
                "{name} {backend:?}: {same_ids} of {} ids agree",
                rt.aov.len()
            );
            assert_eq!(hy.rays.primary, 0, "hybrid traces no primary rays");
            assert!(rt.rays.primary >= u64::from(size * size * spp));
            let rel = |a: u64, b: u64| (a as f64 - b as f64).abs() / (a.max(1) as f64);
            assert!(
                rel(rt.rays.shadow, hy.rays.shadow) < 0.01,
                "{name}: {:?} vs {:?}",
                rt.rays,
                hy.rays
            );
        }
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn hybrid_matches_ray_traced_on_the_cornell_room() {
    assert_hybrid_matches_rt("procedural Cornell", &cornell(), 160);
}

/// The built-in room, glass and mirror included: reflection and refraction rays start from
/// hybrid hit points that equal the ray-traced ones to float noise, so the strict invariant
/// holds through every bounce. (Until the glass block was lifted 2 mm off the floor, rays
/// inside it met two coplanar faces and picked one at random, and this scene only agreed to
/// PSNR ≈ 34 dB.)
#[test]
fn hybrid_matches_ray_traced_on_the_builtin_scene() {
    let scene = rqr::scene::load_default().unwrap();
    assert!(scene.materials.iter().any(|m| m.transmission > 0.0));
    assert_hybrid_matches_rt("built-in", &scene, 160);
}

#[test]
fn hybrid_matches_ray_traced_on_textured_and_normal_mapped_models() {
    assert_hybrid_matches_rt(
        "BoxTextured",
        &load_asset("BoxTextured/BoxTextured.glb"),
        128,
    );
    assert_hybrid_matches_rt(
        "NormalTangentMirrorTest",
        &load_asset("NormalTangentMirrorTest/NormalTangentMirrorTest.glb"),
        128,
    );
}

#[test]
fn gbuffer_reports_depth_and_normal_of_a_known_plane() {
    let ctx = support::gpu();
    let floor = Material {
        metallic: 0.0,
        ..Default::default()
    };
    let height = 3.0;
    let mut camera = look_at(Vec3::new(0.0, height, 0.0), Vec3::ZERO, 60.0);
    // Straight down: look_at needs an up vector that is not parallel to the view.
    camera.camera_to_world =
        rqr::scene::procedural::camera_to_world(Vec3::new(0.0, height, 0.0), Vec3::ZERO, Vec3::Z);
    let scene = assemble(
        vec![quad(0)],
        vec![Instance {
            geometry: 0,
            transform: Mat4::from_scale(Vec3::splat(50.0)),
            node: 0,
        }],
        vec![floor],
        vec![],
        vec![camera],
    );
    let Projection::Perspective { yfov, .. } = camera.projection else {
        unreachable!()
    };
    let renderer = Renderer::new(
        &ctx,
        &scene,
        BackendChoice::Auto.resolve(ctx.info()).unwrap().0,
    )
    .unwrap();
    let n = 32u32;
    for gbuffer in [GbufferLayout::Visibility, GbufferLayout::Full] {
        let out = renderer
            .render_hybrid(
                &ctx,
                &draw_list::draws(&scene),
                &RenderSettings {
                    gbuffer,
                    ..settings(n)
                },
                &scene.cameras[0],
                true,
            )
            .unwrap();
        let tan = (yfov * 0.5).tan();
        for y in 0..n {
            for x in 0..n {
                let a = out.aov[(y * n + x) as usize];
                assert_eq!(a.instance(), 0);
                // The ray through pixel centre (x+0.5, y+0.5) has direction (u, -1, v) in camera terms.
                let u = ((x as f32 + 0.5) / n as f32 * 2.0 - 1.0) * tan;
                let v = ((y as f32 + 0.5) / n as f32 * 2.0 - 1.0) * tan;
                let expected = height * (1.0 + u * u + v * v).sqrt();
                assert!(
                    (a.depth() - expected).abs() < 1e-4 * expected,
                    "{gbuffer:?} pixel {x},{y}: depth {} vs {expected}",
                    a.depth()
                );
                let normal = a.geometric_normal();
                assert!(
                    (normal - Vec3::Y).length() < 1e-5,
                    "{gbuffer:?} normal {normal}"
                );
            }
        }
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn recursion_depth_changes_only_specular_pixels() {
    let ctx = support::gpu();
    let scene = cornell();
    let renderer = Renderer::new(
        &ctx,
        &scene,
        BackendChoice::Auto.resolve(ctx.info()).unwrap().0,
    )
    .unwrap();
    let render = |depth| {
        let s = RenderSettings {
            max_depth: depth,
            ..settings(96)
        };
        renderer
            .render_rt(&ctx, &s, &scene.cameras[0], true)
            .unwrap()
    };
    let (d1, d2, d3) = (render(1), render(2), render(3));
    assert_eq!(
        d1.rays.reflection + d1.rays.refraction,
        0,
        "depth 1 spawns no secondary rays"
    );
    assert!(d2.rays.reflection > 0 && d2.rays.refraction > 0);
    assert!(d3.rays.reflection + d3.rays.refraction > d2.rays.reflection + d2.rays.refraction);
    // Instances 5 (mirror sphere), 6 (glass sphere) and 7 (box, roughness 0.6: its Fresnel
    // reflection passes the weight cut-off at grazing angles) may change; 0-4 are rough walls.
    let specular = |i: i32| (5..=7).contains(&i);
    for (a, b) in [(&d1, &d2), (&d2, &d3)] {
        let mut changed_specular = 0;
        for (i, aov) in a.aov.iter().enumerate() {
            let (ca, cb) = (&a.rgba8[i * 4..i * 4 + 3], &b.rgba8[i * 4..i * 4 + 3]);
            let changed = ca.iter().zip(cb).any(|(x, y)| x.abs_diff(*y) > 2);
            if specular(aov.instance()) {
                changed_specular += usize::from(changed);
            } else {
                assert!(
                    !changed,
                    "diffuse pixel {i} (instance {}) changed with depth",
                    aov.instance()
                );
            }
        }
        assert!(
            changed_specular > 50,
            "only {changed_specular} specular pixels changed"
        );
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn weight_cutoff_saves_rays_without_visible_change() {
    let ctx = support::gpu();
    let scene = cornell();
    let renderer = Renderer::new(
        &ctx,
        &scene,
        BackendChoice::Auto.resolve(ctx.info()).unwrap().0,
    )
    .unwrap();
    let render = |min_weight| {
        let s = RenderSettings {
            min_weight,
            ..settings(128)
        };
        renderer
            .render_rt(&ctx, &s, &scene.cameras[0], false)
            .unwrap()
    };
    let (full, cut) = (render(0.0), render(0.05));
    let secondary = |o: &RenderOutput| o.rays.reflection + o.rays.refraction + o.rays.shadow;
    assert!(
        (secondary(&cut) as f64) < 0.9 * secondary(&full) as f64,
        "cut-off traced {} vs {} rays",
        secondary(&cut),
        secondary(&full)
    );
    let d = diff(&full, &cut);
    assert!(d.flip_mean <= 0.01, "FLIP mean {}", d.flip_mean);
    support::assert_validation_clean(&ctx);
}

#[test]
fn adaptive_sampling_refines_edges_only() {
    let ctx = support::gpu();
    let scene = cornell();
    let renderer = Renderer::new(
        &ctx,
        &scene,
        BackendChoice::Auto.resolve(ctx.info()).unwrap().0,
    )
    .unwrap();
    let s = RenderSettings {
        sampler: SamplerKind::Adaptive,
        adaptive_depth: 3,
        ..settings(96)
    };
    let out = renderer
        .render_rt(&ctx, &s, &scene.cameras[0], true)
        .unwrap();
    // Corners are shared: (w+1)(h+1) + w·h base samples ≈ 2 per pixel, plus refinement.
    let spp = out.mean_spp();
    assert!(spp > 2.0 && spp < 6.0, "mean samples per pixel {spp}");
    let extra: Vec<f32> = out.aov.iter().map(|a| a.samples()).collect();
    let refined = extra.iter().filter(|&&n| n > 1.0).count();
    assert!(
        refined > 0 && refined < extra.len() / 2,
        "{refined} of {} pixels refined",
        extra.len()
    );
    // Versus 16 grid samples per pixel the adaptive image is close.
    let reference = renderer
        .render_rt(
            &ctx,
            &RenderSettings {
                spp: 16,
                sampler: SamplerKind::Grid,
                ..settings(96)
            },
            &scene.cameras[0],
            false,
        )
        .unwrap();
    let d = diff(&reference, &out);
    assert!(
        d.flip_mean < 0.03,
        "adaptive vs 16 spp grid: FLIP {}",
        d.flip_mean
    );
    support::assert_validation_clean(&ctx);
}

/// Alpha MASK (tested at mip 0 by the same alpha_accepts() in traversal and raster) and BLEND
/// (a hit plus a straight continuation ray in both paths).
#[test]
fn hybrid_matches_ray_traced_with_alpha_mask_and_blend() {
    assert_hybrid_matches_rt(
        "AlphaBlendModeTest",
        &load_asset("AlphaBlendModeTest/AlphaBlendModeTest.glb"),
        128,
    );
}

/// Hybrid ≡ ray-traced on an animated frame (CesiumMan skinned mid-stride).
#[test]
fn hybrid_matches_ray_traced_on_an_animated_frame() {
    let rest = load_asset("CesiumMan/CesiumMan.glb");
    let all = rest
        .select_animations(&rqr::scene::AnimationSelection::All)
        .unwrap();
    let posed = rest.posed(&all, 0.7);
    assert_hybrid_matches_rt("CesiumMan t=0.7", &posed, 96);
}
