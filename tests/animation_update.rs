//! Per-frame updates of an animated scene (`render::animated::AnimatedFrames`): GPU skinning
//! into the scene's vertex buffers, BLAS refits and TLAS rebuilds on both backends must give
//! the images of the path that uploads the posed scene and builds everything again, the two
//! backends must agree on the primary hits of updated frames, and static geometry must never
//! be built again (counted).

mod common;

use rqr::accel::bvh::BvhBuild;
use rqr::accel::Backend;
use rqr::render::drivers::animated::{frame_renderer, AnimatedFrames};
use rqr::render::passes::gbuffer;
use rqr::render::{RenderOutput, RenderSettings, Renderer};
use rqr::scene::{AnimationSelection, Camera, LoadOptions, Scene};

const SIZE: u32 = 64;

fn load(rel: &str) -> (Scene, Vec<usize>) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets/gltf")
        .join(rel);
    let s = rqr::scene::load(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let first = s.select_animations(&AnimationSelection::default()).unwrap();
    (s, first)
}

fn settings() -> RenderSettings {
    RenderSettings {
        width: SIZE,
        height: SIZE,
        ..Default::default()
    }
}

/// One camera for every frame of a scene: the automatic camera of its rest bounds, pulled
/// back so that the moving parts stay in view.
fn camera(rest: &Scene) -> Camera {
    let mut bounds = rest.bounds;
    let c = bounds.center();
    let half = (bounds.max - bounds.min) * 0.75;
    bounds.min = c - half;
    bounds.max = c + half;
    rqr::scene::auto_camera(&bounds, 1.0)
}

fn rt(ctx: &rqr::vk::Context, r: &Renderer, cam: &Camera) -> RenderOutput {
    r.render_rt(ctx, &settings(), cam, true).unwrap()
}

/// Share of pixels whose primary hit (instance, primitive) agrees.
fn id_agreement(a: &RenderOutput, b: &RenderOutput) -> f64 {
    let same = a
        .aov
        .iter()
        .zip(&b.aov)
        .filter(|(x, y)| x.instance() == y.instance() && x.primitive() == y.primitive())
        .count();
    same as f64 / a.aov.len() as f64
}

/// Scenes and the times their updates are checked at: skinned (RiggedSimple), morphed
/// (AnimatedMorphCube), node-animated (BoxAnimated).
const CASES: [(&str, [f32; 3]); 3] = [
    ("RiggedSimple/RiggedSimple.glb", [0.4, 0.9, 1.3]),
    ("AnimatedMorphCube/AnimatedMorphCube.glb", [0.5, 1.5, 2.5]),
    ("BoxAnimated/BoxAnimated.glb", [0.6, 1.4, 2.9]),
];

#[test]
fn updated_frames_match_rebuilt_frames_on_both_backends() {
    let ctx = common::gpu();
    assert!(
        ctx.features().ray_query,
        "the hw backend needs ray queries (lavapipe has them)"
    );
    for (rel, times) in CASES {
        let (rest, anims) = load(rel);
        let cam = camera(&rest);
        let mut per_backend = Vec::new();
        for backend in [Backend::Hw, Backend::Bvh] {
            let mut frames =
                AnimatedFrames::new(&ctx, &rest, &anims, 0.0, backend, BvhBuild::Gpu).unwrap();
            let first = rt(&ctx, frames.renderer(), &cam);
            let mut outputs = Vec::new();
            for t in times {
                let (posed, scopes) = frames.update(&ctx, t).unwrap();
                assert!(
                    scopes.iter().any(|(n, _)| n == "tlas build"),
                    "{rel} {backend:?}: the update reports its top-level build ({scopes:?})"
                );
                let updated = rt(&ctx, frames.renderer(), &cam);
                let rebuilt_renderer =
                    frame_renderer(&ctx, &posed, backend, BvhBuild::Gpu).unwrap();
                let rebuilt = rt(&ctx, &rebuilt_renderer, &cam);
                let d = rqr::render::image::compare::compare(
                    SIZE,
                    SIZE,
                    &rebuilt.rgba8,
                    &updated.rgba8,
                );
                eprintln!(
                    "{rel} {backend:?} t={t}: FLIP {:.5}, PSNR {:.1} dB, ids {:.4}",
                    d.flip_mean,
                    d.psnr_db,
                    id_agreement(&rebuilt, &updated)
                );
                assert!(
                    d.flip_mean <= 0.002 && d.psnr_db >= 45.0,
                    "{rel} {backend:?} t={t}: updated vs rebuilt frame FLIP {} PSNR {} dB",
                    d.flip_mean,
                    d.psnr_db
                );
                assert!(
                    id_agreement(&rebuilt, &updated) >= 0.999,
                    "{rel} {backend:?} t={t}: primary hits differ from the rebuilt frame"
                );
                // Raster (hybrid) reads the same updated vertex buffers.
                let draws = gbuffer::draws(&posed);
                let h_updated = frames
                    .renderer()
                    .render_hybrid(&ctx, &draws, &settings(), &cam, false)
                    .unwrap();
                let h_rebuilt = rebuilt_renderer
                    .render_hybrid(&ctx, &draws, &settings(), &cam, false)
                    .unwrap();
                let h = rqr::render::image::compare::compare(
                    SIZE,
                    SIZE,
                    &h_rebuilt.rgba8,
                    &h_updated.rgba8,
                );
                assert!(
                    h.flip_mean <= 0.002,
                    "{rel} {backend:?} t={t}: hybrid updated vs rebuilt FLIP {}",
                    h.flip_mean
                );
                outputs.push(updated);
            }
            // The animation moved something: some frame differs from the first.
            let moved = outputs
                .iter()
                .map(|o| {
                    first
                        .rgba8
                        .chunks(4)
                        .zip(o.rgba8.chunks(4))
                        .filter(|(a, b)| a != b)
                        .count()
                })
                .max()
                .unwrap_or(0);
            assert!(moved > 20, "{rel} {backend:?}: only {moved} pixels changed");
            per_backend.push(outputs);
        }
        // Backends agree on the primary hits of updated frames (BoxAnimated's boxes share
        // faces, where the backends pick different but equally close hits; see backends.rs).
        let required = if rel.starts_with("BoxAnimated") {
            0.8
        } else {
            0.9999
        };
        for (t, (a, b)) in times.iter().zip(per_backend[0].iter().zip(&per_backend[1])) {
            let agree = id_agreement(a, b);
            assert!(
                agree >= required,
                "{rel} t={t}: hw and bvh agree on {:.4} % of primary hits",
                agree * 100.0
            );
        }
    }
    common::assert_validation_clean(&ctx);
}

/// Static geometry is built once; deformed BLASes are refitted (hw) and built again only
/// after the policy's refit count; node-only animation does no skinning.
#[test]
fn updates_refit_deformed_geometry_and_never_rebuild_static_geometry() {
    let ctx = common::gpu();
    // RiggedSimple: one skinned mesh; BoxAnimated: two node-animated meshes, no skin.
    for (rel, deformed, geometries) in [
        ("RiggedSimple/RiggedSimple.glb", 1u64, 1u64),
        ("BoxAnimated/BoxAnimated.glb", 0, 2),
    ] {
        let (rest, anims) = load(rel);
        assert_eq!(rest.geometries.len() as u64, geometries, "{rel}");
        let mut frames =
            AnimatedFrames::new(&ctx, &rest, &anims, 0.0, Backend::Hw, BvhBuild::Gpu).unwrap();
        assert_eq!(frames.deformed_instances() as u64, deformed, "{rel}");
        frames.policy.hw_rebuild_every = 3;
        let updates = 5u64;
        for k in 1..=updates {
            frames.update(&ctx, k as f32 * 0.2).unwrap();
        }
        let c = frames.counters();
        let statics = geometries - deformed;
        assert_eq!(
            c.hw.static_blas_builds, statics,
            "{rel}: static BLAS built once"
        );
        // Built at creation, refitted 3 times, built again, refitted once more.
        assert_eq!(c.hw.deformed_blas_builds, 2 * deformed, "{rel}: {c:?}");
        assert_eq!(c.hw.blas_refits, (updates - 1) * deformed, "{rel}: {c:?}");
        assert_eq!(c.hw.tlas_builds, updates + 1, "{rel}: TLAS every frame");
        assert_eq!(c.skin_dispatches, updates * deformed, "{rel}: {c:?}");
        assert_eq!(c.full_builds, 1, "{rel}: one upload");

        // bvh: every update refits and rebuilds the top level while the refitted bottom
        // levels stay within the SAH threshold (here: any growth), ...
        let mut bvh =
            AnimatedFrames::new(&ctx, &rest, &anims, 0.0, Backend::Bvh, BvhBuild::Gpu).unwrap();
        bvh.policy.bvh_max_sah_growth = f64::INFINITY;
        for k in 1..=updates {
            bvh.update(&ctx, k as f32 * 0.2).unwrap();
        }
        let c = bvh.counters();
        assert_eq!(c.bvh_refits, updates, "{rel}: {c:?}");
        assert_eq!(c.bvh_tlas_rebuilds, updates, "{rel}: {c:?}");
        assert_eq!(c.bvh_full_rebuilds, 0, "{rel}: {c:?}");
        assert_eq!(c.full_builds, 1, "{rel}: one upload");
        if deformed > 0 {
            assert!(
                c.bvh_max_sah_growth_seen > 0.0,
                "{rel}: a deforming mesh makes the refitted tree costlier ({c:?})"
            );
        }
        // ... and builds the BVH again once the growth passes it.
        bvh.policy.bvh_max_sah_growth = -1.0;
        bvh.update(&ctx, 0.3).unwrap();
        let c = bvh.counters();
        assert_eq!(
            (c.bvh_full_rebuilds, c.bvh_tlas_rebuilds),
            (1, updates),
            "{rel}"
        );
    }
    common::assert_validation_clean(&ctx);
}
