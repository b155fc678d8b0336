//! Per-frame updates of an animated scene (`render::animated::AnimatedFrames`): GPU skinning
//! into the scene's vertex buffers, BLAS refits and TLAS rebuilds on both backends must give
//! the images of the path that uploads the posed scene and builds everything again, the two
//! backends must agree on the primary hits of updated frames, and static geometry must never
//! be built again (counted).

use crate::support;

use glam::{Mat4, Vec2, Vec3};
use rqr::accel::bvh::BvhBuild;
use rqr::accel::Backend;
use rqr::interface::GBUFFER_BARY;
use rqr::render::drivers::animated::{frame_renderer, AnimatedFrames};
use rqr::render::passes::draw_list;
use rqr::render::passes::gbuffer::GbufferLayout;
use rqr::render::{FrameTargets, RenderOutput, RenderPath, RenderSettings, Renderer};
use rqr::scene::{Camera, Instance, Scene};

use support::animated::{camera, load};

const SIZE: u32 = 64;

fn settings() -> RenderSettings {
    RenderSettings {
        width: SIZE,
        height: SIZE,
        ..Default::default()
    }
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
    let ctx = support::gpu();
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
                let d = rqr::render::image::metrics::compare(
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
                let draws = draw_list::draws(&posed);
                let h_updated = frames
                    .renderer()
                    .render_hybrid(&ctx, &draws, &settings(), &cam, false)
                    .unwrap();
                let h_rebuilt = rebuilt_renderer
                    .render_hybrid(&ctx, &draws, &settings(), &cam, false)
                    .unwrap();
                let h = rqr::render::image::metrics::compare(
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
    support::assert_validation_clean(&ctx);
}

/// Static geometry is built once; deformed BLASes are refitted (hw) and built again only
/// after the policy's refit count; node-only animation does no skinning.
#[test]
fn updates_refit_deformed_geometry_and_never_rebuild_static_geometry() {
    let ctx = support::gpu();
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

        // bvh: every update refits the deformed bottom levels (none for node animation) and
        // rebuilds the top level while the refitted bottom levels stay within the SAH
        // threshold (here: any growth), ...
        let mut bvh =
            AnimatedFrames::new(&ctx, &rest, &anims, 0.0, Backend::Bvh, BvhBuild::Gpu).unwrap();
        bvh.policy.bvh_max_sah_growth = f64::INFINITY;
        for k in 1..=updates {
            bvh.update(&ctx, k as f32 * 0.2).unwrap();
        }
        let c = bvh.counters();
        assert_eq!(c.bvh_refits, updates * deformed, "{rel}: {c:?}");
        assert_eq!(c.bvh_tlas_rebuilds, updates, "{rel}: {c:?}");
        assert_eq!(c.bvh_full_rebuilds, 0, "{rel}: {c:?}");
        assert_eq!(c.bvh_static_blas_builds, statics, "{rel}: {c:?}");
        assert_eq!(c.bvh_deformed_blas_builds, deformed, "{rel}: {c:?}");
        assert_eq!(c.full_builds, 1, "{rel}: one upload");
        if deformed > 0 {
            assert!(
                c.bvh_max_sah_growth_seen > 0.0,
                "{rel}: a deforming mesh makes the refitted tree costlier ({c:?})"
            );
        }
        // ... and builds the deformed bottom levels (only) again once the growth passes it.
        bvh.policy.bvh_max_sah_growth = -1.0;
        bvh.update(&ctx, 0.3).unwrap();
        let c = bvh.counters();
        assert_eq!(c.bvh_deformed_blas_builds, 2 * deformed, "{rel}: {c:?}");
        assert_eq!(c.bvh_static_blas_builds, statics, "{rel}: {c:?}");
        assert_eq!(
            (c.bvh_full_rebuilds, c.bvh_tlas_rebuilds),
            (0, updates + 1),
            "{rel}: {c:?}"
        );
    }
    support::assert_validation_clean(&ctx);
}

/// RiggedSimple (one skinned mesh) plus an unskinned copy of its mesh beside it, placed by a
/// root node that no animation moves: one deformed and one static geometry.
fn skinned_and_static() -> (Scene, Vec<usize>) {
    let (mut s, anims) = load("RiggedSimple/RiggedSimple.glb");
    let mut copy = s.geometries[0].clone();
    copy.joints.clear();
    copy.weights.clear();
    copy.morph_targets.clear();
    let (lo, hi) = copy.positions.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    s.geometries.push(copy);
    let animated: Vec<usize> = s
        .rig
        .animations
        .iter()
        .flat_map(|a| a.channels.iter().map(|c| c.node))
        .collect();
    let node = (0..s.rig.nodes.len())
        .find(|&n| s.rig.nodes[n].parent.is_none() && !animated.contains(&n))
        .expect("RiggedSimple has a root node no animation moves");
    let side = Mat4::from_translation(Vec3::X * (hi - lo).max_element() * 1.2);
    let local = s.rig.instance_local[0];
    s.rig.instance_local.push(side * local);
    s.instances.push(Instance {
        geometry: (s.geometries.len() - 1) as u32,
        transform: side * local,
        node,
    });
    s.bounds = s.posed(&anims, 0.0).bounds;
    (s, anims)
}

/// The bvh backend builds the bottom level of deformed geometry again when the policy says
/// so and never the static one; the spliced BVH renders as a BVH built from scratch.
#[test]
fn bvh_rebuilds_only_the_deformed_bottom_levels() {
    let ctx = support::gpu();
    let (rest, anims) = skinned_and_static();
    let cam = camera(&rest);
    for build in [BvhBuild::Host, BvhBuild::Gpu] {
        let mut frames =
            AnimatedFrames::new(&ctx, &rest, &anims, 0.0, Backend::Bvh, build).unwrap();
        assert_eq!(frames.deformed_instances(), 1, "{build:?}");
        // Every update builds the deformed bottom level again.
        frames.policy.bvh_max_sah_growth = -1.0;
        let updates = 3u64;
        let check = |frames: &mut AnimatedFrames, t: f32, rebuilt_blas: bool| {
            let (posed, scopes) = frames.update(&ctx, t).unwrap();
            assert_eq!(
                scopes.iter().any(|(n, _)| n == "blas build"),
                rebuilt_blas,
                "{build:?} t={t}: {scopes:?}"
            );
            let updated = rt(&ctx, frames.renderer(), &cam);
            let fresh = frame_renderer(&ctx, &posed, Backend::Bvh, build).unwrap();
            let rebuilt = rt(&ctx, &fresh, &cam);
            let d =
                rqr::render::image::metrics::compare(SIZE, SIZE, &rebuilt.rgba8, &updated.rgba8);
            let ids = id_agreement(&rebuilt, &updated);
            eprintln!(
                "{build:?} t={t}: FLIP {:.5}, PSNR {:.1} dB, ids {ids:.4}",
                d.flip_mean, d.psnr_db
            );
            assert!(
                d.flip_mean <= 0.002 && ids >= 0.999,
                "{build:?} t={t}: updated vs rebuilt FLIP {} ids {ids}",
                d.flip_mean
            );
        };
        for k in 1..=updates {
            check(&mut frames, k as f32 * 0.3, true);
        }
        let c = frames.counters();
        assert_eq!(c.bvh_static_blas_builds, 1, "{build:?}: {c:?}");
        assert_eq!(c.bvh_deformed_blas_builds, 1 + updates, "{build:?}: {c:?}");
        assert_eq!(c.bvh_refits, updates, "{build:?}: {c:?}");
        assert_eq!(c.bvh_tlas_rebuilds, updates, "{build:?}: {c:?}");
        assert_eq!(c.bvh_full_rebuilds, 0, "{build:?}: {c:?}");
        // Refits go on from the spliced BVH.
        frames.policy.bvh_max_sah_growth = f64::INFINITY;
        check(&mut frames, 1.7, false);
        let c = frames.counters();
        assert_eq!(
            (
                c.bvh_static_blas_builds,
                c.bvh_deformed_blas_builds,
                c.bvh_refits
            ),
            (1, 1 + updates, updates + 1),
            "{build:?}: {c:?}"
        );
    }
    support::assert_validation_clean(&ctx);
}

/// World position of barycentrics `b` on triangle `prim` of instance `inst` of a posed scene.
fn world_point(s: &Scene, inst: usize, prim: usize, b: Vec2) -> Vec3 {
    let i = s.instances[inst];
    let g = &s.geometries[i.geometry as usize];
    let w = [1.0 - b.x - b.y, b.x, b.y];
    let p: Vec3 = (0..3)
        .map(|k| w[k] * g.positions[g.indices[3 * prim + k] as usize])
        .sum();
    i.transform.transform_point3(p)
}

/// The hybrid G-buffer's motion vectors include object motion: with a static camera, the
/// motion at a pixel of a moving object is the projected displacement, computed on the CPU
/// from the scene posed at both times, of the point the pixel sees (skinning and node
/// animation); static geometry has none beyond the camera path's rounding.
#[test]
fn gbuffer_motion_vectors_follow_moving_objects() {
    let ctx = support::gpu();
    let cases = [
        ("skinned + static", skinned_and_static(), [0.1, 0.9]),
        (
            "BoxAnimated",
            load("BoxAnimated/BoxAnimated.glb"),
            [0.3, 0.9],
        ),
    ];
    let settings = RenderSettings {
        gbuffer: GbufferLayout::Full,
        ..settings()
    };
    for (name, (rest, anims), [t0, t1]) in cases {
        let mut frames =
            AnimatedFrames::new(&ctx, &rest, &anims, t0, Backend::Hw, BvhBuild::Gpu).unwrap();
        let (posed1, _) = frames.update(&ctx, t1).unwrap();
        let posed0 = rest.posed(&anims, t0);
        // A camera that sees the scene at both times.
        let mut both = posed1.clone();
        both.bounds.grow(posed0.bounds.min);
        both.bounds.grow(posed0.bounds.max);
        let cam = camera(&both);
        let draws = draw_list::draws(&posed1);
        let mut targets = FrameTargets::new(
            &ctx,
            frames.renderer(),
            RenderPath::Hybrid,
            &settings,
            &draws,
            true,
        )
        .unwrap();
        let out = targets.render(&ctx, &cam).unwrap();
        let motion = targets
            .hybrid_gbuffer(&ctx, GBUFFER_BARY)
            .unwrap()
            .expect("the full G-buffer has barycentrics and motion");
        let view_proj = Mat4::from_cols_array(&targets.gpu_frame(&cam).view_proj);
        let size = Vec2::splat(SIZE as f32);
        let pixel = |w: Vec3| {
            let c = view_proj * w.extend(1.0);
            (Vec2::new(c.x, c.y) / c.w * 0.5 + 0.5) * size
        };
        let (mut moving, mut still, mut worst) = (0, 0, 0.0f32);
        for (p, (a, m)) in out.aov.iter().zip(&motion).enumerate() {
            if a.instance() < 0 {
                continue;
            }
            let (inst, prim) = (a.instance() as usize, a.primitive() as usize);
            let b = Vec2::from(a.bary);
            let now = world_point(&posed1, inst, prim, b);
            let seen = a.world_position();
            assert!(
                (now - seen).length() <= 1e-4 * rest.bounds.diagonal(),
                "{name} pixel {p}: the G-buffer point {seen} is not the posed scene's {now}"
            );
            let before = world_point(&posed0, inst, prim, b);
            let expected = pixel(before) - pixel(now);
            let got = Vec2::new(m[2], m[3]);
            worst = worst.max((got - expected).length());
            if before == now {
                still += 1;
                // What is left is the camera-only path's rounding (projecting the f32 hit
                // point vs the fragment's film position), a few thousandths of a pixel.
                assert!(
                    got.length() <= 0.01,
                    "{name} pixel {p}: static geometry has motion {got}"
                );
            } else if expected.length() > 0.5 {
                moving += 1;
            }
        }
        eprintln!(
            "{name}: {moving} moving pixels, {still} static, worst motion error {worst:.5} px"
        );
        assert!(
            worst <= 0.05,
            "{name}: motion vectors off by up to {worst} px"
        );
        assert!(
            moving > 20,
            "{name}: only {moving} pixels moved by over half a pixel"
        );
        if name.starts_with("skinned") {
            assert!(still > 20, "{name}: only {still} static pixels");
        }
    }
    support::assert_validation_clean(&ctx);
}

/// `GpuBvh::refit_device` reads the skinned vertices on the GPU: positions it did not move
/// keep the built tree's SAH cost, and a non-finite vertex written there is refused with an
/// error instead of a tree with NaN boxes.
#[test]
fn device_refit_reads_gpu_vertices_and_refuses_non_finite_ones() {
    use rqr::accel::bvh::refit::DeviceVertices;
    use rqr::accel::bvh::{BvhBuildOptions, GpuBvh};
    let ctx = support::gpu();
    let (rest, anims) = load("RiggedSimple/RiggedSimple.glb");
    let posed = rest.posed(&anims, 0.5);
    let gpu = rqr::scene::gpu::GpuScene::upload(&ctx, &posed, 0).unwrap();
    let opts = BvhBuildOptions::default();
    let mut bvh = GpuBvh::build_with(&ctx, &posed, &opts, BvhBuild::Gpu).unwrap();
    let vertices = DeviceVertices::of_scene(&gpu, vec![0]);
    let report = bvh.refit_device(&ctx, &posed, &vertices).unwrap();
    let growth = report.blas_sah_after / report.blas_sah_before - 1.0;
    assert!(
        growth.abs() < 1e-3,
        "unmoved vertices changed the SAH by {growth}"
    );
    bvh.rebuild_tlas_deformed(&ctx, &posed, &opts).unwrap();

    let g = &posed.geometries[0];
    let mut bad: Vec<[f32; 3]> = g.positions.iter().map(|p| p.to_array()).collect();
    bad[g.indices[0] as usize] = [f32::NAN, 0.0, 0.0];
    let first = gpu.geometry_records[0].first_vertex as usize;
    assert_eq!(first, 0, "one geometry: its vertices start the buffer");
    gpu.positions
        .upload(&ctx, bytemuck::cast_slice(&bad))
        .unwrap();
    let err = bvh
        .refit_device(&ctx, &posed, &vertices)
        .unwrap_err()
        .to_string();
    assert!(err.contains("not finite"), "{err}");
    support::assert_validation_clean(&ctx);
}
