//! The frame loop: frames recorded back to back in bursts give the same images
//! and statistics as frames submitted one by one, the statistics add up in every frame, and a
//! loop of 100 frames allocates no device memory after its first frame.

use crate::support;

use rqr::accel::Backend;
use rqr::render::drivers::burst;
use rqr::render::drivers::sequence::{CameraPath, Sequence, SequenceFrame, SequenceOptions};
use rqr::render::passes::draw_list;
use rqr::render::readback::RingContents;
use rqr::render::temporal::{PixelSource, PrimaryRayCheck, ReuseOptions};
use rqr::render::RenderPath;
use rqr::render::{FrameTargets, RenderSettings, Renderer};
use rqr::scene::procedural::cornell;
use rqr::scene::Scene;
use rqr::vk::Context;

fn settings(size: u32) -> RenderSettings {
    RenderSettings {
        width: size,
        height: size,
        ..Default::default()
    }
}

fn orbit(scene: &Scene) -> CameraPath {
    CameraPath::Orbit {
        degrees_per_frame: 2.0,
        pivot: scene.bounds.center(),
    }
}

fn sequence(
    ctx: &Context,
    r: &Renderer,
    scene: &Scene,
    path: RenderPath,
    reuse: ReuseOptions,
    reference: bool,
) -> Sequence {
    Sequence::new(
        ctx,
        r,
        scene,
        &settings(48),
        scene.cameras[0],
        orbit(scene),
        SequenceOptions {
            path,
            reuse,
            reference,
        },
    )
    .unwrap()
}

fn assert_stats_add_up(f: &SequenceFrame) {
    let s = f.stats;
    assert_eq!(
        s.reused + s.traced + s.interpolated,
        s.pixels,
        "frame {}: {s:?}",
        f.index
    );
    if !f.sources.is_empty() {
        let count = |k: PixelSource| f.sources.iter().filter(|&&x| x == k).count() as u64;
        assert_eq!(count(PixelSource::Reused), s.reused, "frame {}", f.index);
        assert_eq!(count(PixelSource::Traced), s.traced, "frame {}", f.index);
        assert_eq!(
            count(PixelSource::Interpolated),
            s.interpolated,
            "frame {}",
            f.index
        );
    }
}

/// The reuse settings the burst test covers: plain reprojection (with edge and full
/// visibility checks), adaptive sub-sampling, frameless rendering, and none.
fn reuse_cases() -> Vec<(&'static str, RenderPath, ReuseOptions)> {
    let reproject = ReuseOptions {
        reproject: true,
        ..Default::default()
    };
    vec![
        ("none", RenderPath::RayTraced, ReuseOptions::default()),
        ("reproject", RenderPath::RayTraced, reproject),
        (
            "reproject, full visibility",
            RenderPath::RayTraced,
            ReuseOptions {
                rt_visibility: PrimaryRayCheck::Full,
                ..reproject
            },
        ),
        (
            "adaptive",
            RenderPath::RayTraced,
            ReuseOptions {
                adaptive_subsample: true,
                subsample_threshold: 0.2,
                ..reproject
            },
        ),
        (
            "frameless 20",
            RenderPath::RayTraced,
            ReuseOptions {
                frameless_percent: Some(20.0),
                ..reproject
            },
        ),
        ("hybrid reproject", RenderPath::Hybrid, reproject),
        (
            "hybrid adaptive",
            RenderPath::Hybrid,
            ReuseOptions {
                adaptive_subsample: true,
                subsample_threshold: 0.2,
                ..reproject
            },
        ),
    ]
}

#[test]
fn bursts_give_the_images_and_statistics_of_single_frames() {
    let ctx = support::gpu();
    let scene = cornell();
    let r = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    let frames = 5;
    for (name, path, reuse) in reuse_cases() {
        let mut one_by_one = sequence(&ctx, &r, &scene, path, reuse, true);
        let single: Vec<SequenceFrame> = (0..frames)
            .map(|k| one_by_one.render_frame(&ctx, k).unwrap())
            .collect();
        let mut bursts = sequence(&ctx, &r, &scene, path, reuse, true);
        let contents = RingContents {
            rgba8: true,
            color: true,
            aov: false,
            states: true,
        };
        // Bursts of 3 and 2: state carried within a submission and across submissions.
        assert_eq!(
            bursts.prepare_bursts(&ctx, 3, contents, 1 << 30).unwrap(),
            3
        );
        let mut burst = bursts.render_burst(&ctx, 0..3).unwrap();
        burst.extend(bursts.render_burst(&ctx, 3..frames).unwrap());
        assert_eq!(burst.len(), single.len());
        for (a, b) in single.iter().zip(&burst) {
            assert_eq!(a.index, b.index);
            assert!(
                a.output.rgba8 == b.output.rgba8,
                "{name}: frame {} differs between single frames and bursts",
                a.index
            );
            assert!(
                a.output.color == b.output.color,
                "{name}: frame {}",
                a.index
            );
            assert_eq!(a.stats, b.stats, "{name}: frame {}", a.index);
            assert_eq!(a.output.rays, b.output.rays, "{name}: frame {}", a.index);
            assert_eq!(a.sources, b.sources, "{name}: frame {}", a.index);
            let (ra, rb) = (a.reference.as_ref().unwrap(), b.reference.as_ref().unwrap());
            assert_eq!(ra.rays, rb.rays, "{name}: frame {}", a.index);
            assert_eq!(
                ra.diff.flip_mean, rb.diff.flip_mean,
                "{name}: frame {}",
                a.index
            );
            assert_stats_add_up(a);
            assert_stats_add_up(b);
            // Every frame is timed, as a whole and by pass.
            assert!(b.frame_gpu_ms > 0.0, "{name}: frame {}", b.index);
            assert!(!b.output.gpu_ms.is_empty(), "{name}: frame {}", b.index);
        }
        // Reuse really happened (the test would pass trivially otherwise).
        if reuse.reuses() {
            assert!(
                burst[frames as usize - 1].stats.reused > 0,
                "{name}: nothing reused"
            );
            assert!(burst[frames as usize - 1].reused_history);
        }
        assert!(!burst[0].reused_history);
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn one_pass_and_two_pass_scatter_give_the_same_frames() {
    let ctx = support::gpu();
    assert!(
        ctx.features().buffer_int64_atomics,
        "the test device (lavapipe) has 64-bit buffer atomics, so both scatters are compared"
    );
    let scene = cornell();
    let r = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    let reuse = ReuseOptions {
        reproject: true,
        adaptive_subsample: true,
        subsample_threshold: 0.2,
        ..Default::default()
    };
    for path in [RenderPath::RayTraced, RenderPath::Hybrid] {
        let mut one = sequence(&ctx, &r, &scene, path, reuse, false);
        let mut two = sequence(&ctx, &r, &scene, path, reuse, false);
        two.use_two_pass_scatter();
        for k in 0..4 {
            let (a, b) = (
                one.render_frame(&ctx, k).unwrap(),
                two.render_frame(&ctx, k).unwrap(),
            );
            assert!(a.output.rgba8 == b.output.rgba8, "{path:?} frame {k}");
            assert_eq!(a.stats, b.stats, "{path:?} frame {k}");
            assert_eq!(a.sources, b.sources, "{path:?} frame {k}");
            if k > 0 {
                assert!(a.stats.reused > 0, "{path:?} frame {k}: nothing reused");
            }
        }
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn a_burst_longer_than_prepared_is_refused() {
    let ctx = support::gpu();
    let scene = cornell();
    let r = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    let mut seq = sequence(
        &ctx,
        &r,
        &scene,
        RenderPath::RayTraced,
        ReuseOptions::default(),
        false,
    );
    let err = seq
        .render_burst(&ctx, 0..2)
        .err()
        .expect("2 frames > 1 slot");
    assert!(err.to_string().contains("prepare_bursts"), "{err}");
    support::assert_validation_clean(&ctx);
}

#[test]
fn a_hundred_frames_allocate_no_memory_after_the_first() {
    let ctx = support::gpu();
    let scene = cornell();
    let r = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    let reproject = ReuseOptions {
        reproject: true,
        adaptive_subsample: true,
        ..Default::default()
    };
    for (path, reuse) in [
        (RenderPath::RayTraced, reproject),
        (RenderPath::Hybrid, reproject),
        (RenderPath::RayTraced, ReuseOptions::default()),
    ] {
        let mut seq = Sequence::new(
            &ctx,
            &r,
            &scene,
            &settings(16),
            scene.cameras[0],
            orbit(&scene),
            SequenceOptions {
                path,
                reuse,
                reference: true,
            },
        )
        .unwrap();
        seq.render_frame(&ctx, 0).unwrap();
        let after_first = ctx.allocation_count();
        for k in 1..100 {
            let f = seq.render_frame(&ctx, k).unwrap();
            assert_stats_add_up(&f);
        }
        assert_eq!(
            ctx.allocation_count(),
            after_first,
            "{path:?} {reuse:?}: frames 2-100 allocated device memory"
        );
    }
    // Single frames of both paths through reused targets, and timed bursts.
    let draws = draw_list::draws(&scene);
    let camera = scene.cameras[0];
    for path in [RenderPath::RayTraced, RenderPath::Hybrid] {
        let s = RenderSettings {
            spp: 4,
            sampler: rqr::render::SamplerKind::Grid,
            ..settings(16)
        };
        let mut targets = FrameTargets::new(&ctx, &r, path, &s, &draws, true).unwrap();
        let first = targets.render(&ctx, &camera).unwrap();
        let after_first = ctx.allocation_count();
        for _ in 1..100 {
            let out = targets.render(&ctx, &camera).unwrap();
            assert_eq!(out.rgba8, first.rgba8, "{path:?}: same camera, same image");
        }
        let timed = burst::time_alternating(&ctx, &[&targets], &camera, 5, 10_000.0).unwrap();
        assert_eq!(timed.frames[0].len(), 5);
        assert_eq!(timed.outputs[0].rgba8, first.rgba8);
        assert_eq!(
            ctx.allocation_count(),
            after_first,
            "{path:?}: repeated frames allocated device memory"
        );
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn time_alternating_times_every_frame_of_every_target() {
    let ctx = support::gpu();
    let scene = cornell();
    let r = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    let draws = draw_list::draws(&scene);
    let s = settings(32);
    let rt = FrameTargets::new(&ctx, &r, RenderPath::RayTraced, &s, &draws, false).unwrap();
    let hybrid = FrameTargets::new(&ctx, &r, RenderPath::Hybrid, &s, &draws, false).unwrap();
    // A tiny submission budget forces one submission per round: the split path is covered.
    let timed = burst::time_alternating(&ctx, &[&rt, &hybrid], &scene.cameras[0], 4, 1e-6).unwrap();
    assert_eq!(timed.report.submissions, 4);
    assert!(timed.report.warm_up_bursts >= 2 || !timed.report.warm_up_settled);
    for (frames, name) in timed.frames.iter().zip(["rt", "hybrid shading"]) {
        assert_eq!(frames.len(), 4);
        for f in frames {
            assert!(f.total_ms > 0.0);
            let pass: f64 = f.passes.iter().filter(|p| p.0 == name).map(|p| p.1).sum();
            assert!(pass > 0.0 && pass <= f.total_ms, "{name}: {f:?}");
        }
    }
    // The images are those of single renders.
    let single_rt = r.render_rt(&ctx, &s, &scene.cameras[0], false).unwrap();
    assert_eq!(timed.outputs[0].rgba8, single_rt.rgba8);
    let single_hybrid = r
        .render_hybrid(&ctx, &draws, &s, &scene.cameras[0], false)
        .unwrap();
    assert_eq!(timed.outputs[1].rgba8, single_hybrid.rgba8);
    support::assert_validation_clean(&ctx);
}
