//! The compute rasterizer (`--raster compute`) against the graphics pipeline: the same
//! instance and primitive on ≥ 99.9 % of pixels, on both depth-test paths (64-bit atomics and
//! the 32-bit fallback), and the hybrid ↔ ray-traced invariant with compute visibility.
use crate::support;
use crate::support::scene_files::load_asset;

use rqr::accel::Backend;
use rqr::render::image::metrics;
use rqr::render::passes::draw_list;
use rqr::render::passes::gbuffer;
use rqr::render::passes::raster_compute::RasterMode;
use rqr::render::{RenderOutput, RenderSettings, Renderer, SamplerKind};
use rqr::scene::{Camera, Scene};

fn default_camera(scene: &Scene) -> Camera {
    scene
        .cameras
        .first()
        .copied()
        .unwrap_or_else(|| rqr::scene::auto_camera(&scene.bounds, 1.0))
}

fn ids(out: &RenderOutput) -> Vec<(i32, i32)> {
    out.aov
        .iter()
        .map(|a| (a.instance(), a.primitive()))
        .collect()
}

/// Renders `scene` with the hybrid path per raster mode (4 jittered samples, so the jitter is
/// exercised; the AOVs hold the first sample's ids) and asserts ids agree with the graphics
/// pass on ≥ 99.9 % of pixels. Returns the fraction of pixels the graphics pass covered.
fn assert_compute_matches_graphics(name: &str, scene: &Scene, camera: &Camera, size: u32) -> f64 {
    let ctx = support::gpu();
    assert!(
        ctx.features().buffer_int64_atomics,
        "lavapipe exposes shaderBufferInt64Atomics; the 64-bit path must be tested"
    );
    let draws = draw_list::draws(scene);
    let renderer = Renderer::new(&ctx, scene, Backend::Bvh).unwrap();
    let render = |raster: RasterMode, spp: u32| {
        let s = RenderSettings {
            width: size,
            height: size,
            spp,
            sampler: if spp == 1 {
                SamplerKind::Center
            } else {
                SamplerKind::Halton
            },
            max_depth: 1,
            raster,
            ..Default::default()
        };
        renderer
            .render_hybrid(&ctx, &draws, &s, camera, true)
            .unwrap()
    };
    let mut coverage = 0.0;
    for spp in [1, 2] {
        let reference = ids(&render(RasterMode::Graphics, spp));
        let hits = reference.iter().filter(|(i, _)| *i >= 0).count();
        coverage = hits as f64 / reference.len() as f64;
        for raster in [RasterMode::Compute, RasterMode::ComputeAtomic32] {
            let got = ids(&render(raster, spp));
            let same = reference.iter().zip(&got).filter(|(a, b)| a == b).count();
            let got_hits = got.iter().filter(|(i, _)| *i >= 0).count();
            assert!(
                same as f64 >= 0.999 * reference.len() as f64,
                "{name} {raster:?} spp {spp}: ids agree on {same} of {} pixels (graphics hits {hits}, compute {got_hits})",
                reference.len()
            );
        }
    }
    support::assert_validation_clean(&ctx);
    coverage
}

#[test]
fn compute_visibility_matches_graphics_on_the_builtin_scene() {
    let scene = rqr::scene::load_default().unwrap();
    let covered = assert_compute_matches_graphics("built-in", &scene, &default_camera(&scene), 128);
    assert!(covered > 0.5, "built-in scene covers {covered}");
}

/// Tile lists too small for the scene: the (triangle, tile) pairs that do not fit are
/// rasterized by the binning invocation itself, and the image must not change.
#[test]
fn compute_visibility_survives_full_tile_bins() {
    // The capacity is read from the environment: set in a process of its own, never changed
    // under the other tests of this binary (or the `rqr` processes they start).
    let capacity = (rqr::render::passes::raster_compute::BIN_CAPACITY_ENV, "1");
    if !support::in_own_process(
        module_path!(),
        "compute_visibility_survives_full_tile_bins",
        &[capacity],
    ) {
        return;
    }
    let scene = rqr::scene::load_default().unwrap();
    let camera = default_camera(&scene);
    assert_compute_matches_graphics("built-in, 1 bin entry", &scene, &camera, 96);
}

/// Camera inside the room looking into a corner: walls, floor and ceiling run behind the
/// camera, so their triangles cross the near plane and must be clipped; every pixel sees a
/// surface.
#[test]
fn compute_visibility_clips_triangles_crossing_the_near_plane() {
    let scene = rqr::scene::load_default().unwrap();
    let b = scene.bounds;
    let center = (b.min + b.max) * 0.5;
    let corner = glam::Vec3::new(b.min.x, b.min.y, b.min.z);
    let camera = rqr::scene::look_at_camera(center, corner, glam::Vec3::Y, 1.2);
    let covered = assert_compute_matches_graphics("inside the room", &scene, &camera, 96);
    assert!(
        covered > 0.99,
        "the camera is inside the room, yet only {covered} of the pixels see a surface"
    );
}

#[test]
fn compute_visibility_matches_graphics_on_gltf_samples() {
    for (name, rel) in [
        ("BoxTextured", "BoxTextured/BoxTextured.glb"),
        // Alpha MASK materials tested against their textures.
        (
            "AlphaBlendModeTest",
            "AlphaBlendModeTest/AlphaBlendModeTest.glb",
        ),
        // Mirrored instances: clockwise front faces.
        (
            "NormalTangentMirrorTest",
            "NormalTangentMirrorTest/NormalTangentMirrorTest.glb",
        ),
        ("SimpleInstancing", "SimpleInstancing/SimpleInstancing.glb"),
    ] {
        let scene = load_asset(rel);
        let covered = assert_compute_matches_graphics(name, &scene, &default_camera(&scene), 96);
        assert!(covered > 0.05, "{name} covers only {covered}");
    }
}

/// The hybrid ↔ ray-traced invariant of tests/render/paths.rs with compute visibility: PSNR ≥ 40 dB,
/// FLIP mean ≤ 0.02, ids on ≥ 99.9 % of pixels.
#[test]
fn hybrid_with_compute_visibility_matches_ray_traced() {
    let ctx = support::gpu();
    let scene = rqr::scene::load_default().unwrap();
    let draws = draw_list::draws(&scene);
    let camera = default_camera(&scene);
    let mut backends = vec![Backend::Bvh];
    if ctx.features().ray_query {
        backends.push(Backend::Hw);
    }
    for backend in backends {
        let renderer = Renderer::new(&ctx, &scene, backend).unwrap();
        for (spp, sampler) in [(1, SamplerKind::Center), (4, SamplerKind::Grid)] {
            let s = RenderSettings {
                width: 128,
                height: 128,
                spp,
                sampler,
                raster: RasterMode::Compute,
                ..Default::default()
            };
            let rt = renderer.render_rt(&ctx, &s, &camera, true).unwrap();
            let hy = renderer
                .render_hybrid(&ctx, &draws, &s, &camera, true)
                .unwrap();
            let d = metrics::compare(rt.width, rt.height, &rt.rgba8, &hy.rgba8);
            assert!(
                d.psnr_db >= 40.0 && d.flip_mean <= 0.02,
                "{backend:?} spp {spp}: PSNR {:.1} dB, FLIP mean {:.4}",
                d.psnr_db,
                d.flip_mean
            );
            let same = ids(&rt)
                .iter()
                .zip(&ids(&hy))
                .filter(|(a, b)| a == b)
                .count();
            assert!(
                same as f64 >= 0.999 * rt.aov.len() as f64,
                "{backend:?} spp {spp}: {same} of {} ids agree",
                rt.aov.len()
            );
        }
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn compute_raster_rejects_the_full_gbuffer() {
    let ctx = support::gpu();
    let scene = rqr::scene::load_default().unwrap();
    let renderer = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    let s = RenderSettings {
        width: 32,
        height: 32,
        gbuffer: gbuffer::GbufferLayout::Full,
        raster: RasterMode::Compute,
        ..Default::default()
    };
    let err = renderer
        .render_hybrid(
            &ctx,
            &draw_list::draws(&scene),
            &s,
            &default_camera(&scene),
            false,
        )
        .err()
        .expect("compute raster with the full G-buffer must fail");
    assert!(err.to_string().contains("--gbuffer visibility"), "{err}");
}
