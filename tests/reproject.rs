//! Temporal reprojection, frameless rendering and adaptive sub-sampling (issue #7) on small
//! images of the procedural Cornell room (lavapipe is slow: ≤ 96×96, few frames).

mod common;

use glam::Vec3;
use rqr::accel::BackendChoice;
use rqr::render::reproject::{PixelSource, RenderPath, ReuseOptions, RtVisibility};
use rqr::render::sequence::{CameraPath, Sequence, SequenceFrame, SequenceOptions};
use rqr::render::{RenderOutput, RenderSettings, Renderer};
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

fn renderer(ctx: &Context, scene: &Scene) -> Renderer {
    Renderer::new(
        ctx,
        scene,
        BackendChoice::Auto.resolve(ctx.info()).unwrap().0,
    )
    .unwrap()
}

fn reproject() -> ReuseOptions {
    ReuseOptions {
        reproject: true,
        ..Default::default()
    }
}

/// Largest per-channel difference of two linear images.
fn max_diff(a: &RenderOutput, b: &RenderOutput) -> f32 {
    a.color
        .iter()
        .zip(&b.color)
        .flat_map(|(x, y)| (0..3).map(move |c| (x[c] - y[c]).abs()))
        .fold(0.0, f32::max)
}

fn count(frame: &SequenceFrame, source: PixelSource) -> usize {
    frame.sources.iter().filter(|&&s| s == source).count()
}

fn assert_stats_add_up(frame: &SequenceFrame) {
    let s = frame.stats;
    assert_eq!(
        s.reused + s.traced + s.interpolated,
        s.pixels,
        "frame {}: {s:?}",
        frame.index
    );
    assert_eq!(s.pixels as usize, frame.sources.len());
    assert_eq!(count(frame, PixelSource::Reused) as u64, s.reused);
    assert_eq!(count(frame, PixelSource::Traced) as u64, s.traced);
    assert_eq!(
        count(frame, PixelSource::Interpolated) as u64,
        s.interpolated
    );
}

#[test]
fn static_camera_reprojection_equals_full_renders() {
    let ctx = common::gpu();
    let scene = cornell();
    let r = renderer(&ctx, &scene);
    let s = settings(64);
    for (path, visibility) in [
        (RenderPath::Rt, RtVisibility::Edges),
        (RenderPath::Rt, RtVisibility::Full),
        (RenderPath::Hybrid, RtVisibility::Edges),
    ] {
        let options = SequenceOptions {
            path,
            reuse: ReuseOptions {
                rt_visibility: visibility,
                ..reproject()
            },
            reference: true,
        };
        let mut seq = Sequence::new(
            &ctx,
            &r,
            &scene,
            &s,
            scene.cameras[0],
            CameraPath::Static,
            options,
        )
        .unwrap();
        for k in 0..3 {
            let f = seq.render_frame(&ctx, k).unwrap();
            assert_stats_add_up(&f);
            let full = f.reference_output.as_ref().unwrap();
            let d = max_diff(full, &f.output);
            assert!(
                d < 2e-3,
                "{path:?} {visibility:?} frame {k}: max difference {d}"
            );
            if k == 0 {
                assert_eq!(f.stats.traced, f.stats.pixels, "the first frame is full");
                assert_eq!(f.output.rays, full.rays);
            } else {
                // Everything but the specular objects is reused.
                assert!(
                    f.stats.reused_fraction() > 0.8,
                    "{path:?} frame {k}: {:?}",
                    f.stats
                );
                assert_eq!(f.stats.holes, 0);
                assert_eq!(f.stats.rejected, 0);
                let rc = f.reference.as_ref().unwrap();
                assert!(rc.ray_fraction < 0.6, "ray fraction {}", rc.ray_fraction);
            }
        }
    }
    common::assert_validation_clean(&ctx);
}

#[test]
#[ignore]
fn orbit_smoke() {
    let ctx = common::gpu();
    let scene = rqr::scene::load_default().unwrap();
    let r = renderer(&ctx, &scene);
    let n: u32 = std::env::var("RQR_SMOKE_SIZE")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(128);
    let s = settings(n);
    let env = |k: &str| std::env::var(k).ok();
    let options = SequenceOptions {
        path: if env("RQR_SMOKE_HYBRID").is_some() {
            RenderPath::Hybrid
        } else {
            RenderPath::Rt
        },
        reuse: ReuseOptions {
            adaptive_subsample: env("RQR_SMOKE_ADAPTIVE").is_some(),
            frameless_percent: env("RQR_SMOKE_FRAMELESS").and_then(|v| v.parse().ok()),
            max_age: env("RQR_SMOKE_MAX_AGE").and_then(|v| v.parse().ok()),
            ..reproject()
        },
        reference: true,
    };
    let mut seq = Sequence::new(
        &ctx,
        &r,
        &scene,
        &s,
        scene.cameras[0],
        CameraPath::Orbit {
            degrees_per_frame: 0.5,
            pivot: scene.bounds.center(),
        },
        options,
    )
    .unwrap();
    let frames: u32 = env("RQR_SMOKE_FRAMES")
        .and_then(|v| v.parse().ok())
        .unwrap_or(8);
    for k in 0..frames {
        let f = seq.render_frame(&ctx, k).unwrap();
        assert_stats_add_up(&f);
        let rc = f.reference.as_ref().unwrap();
        eprintln!(
            "frame {k}: {:?} rays {} fraction {:.3} flip {:.4} psnr {:.1}",
            f.stats,
            f.output.rays.total(),
            rc.ray_fraction,
            rc.diff.flip_mean,
            rc.diff.psnr_db
        );
        debug_dump(&f, "orbit");
    }
    common::assert_validation_clean(&ctx);
}

/// With RQR_DEBUG_DIR set: writes sources | frame | reference, 4x, for looking at failures.
fn debug_dump(f: &SequenceFrame, name: &str) {
    let Ok(dir) = std::env::var("RQR_DEBUG_DIR") else {
        return;
    };
    let (w, h) = (f.output.width as usize, f.output.height as usize);
    let panels: Vec<Vec<u8>> = vec![
        f.sources
            .iter()
            .flat_map(|s| match s {
                PixelSource::Reused => [40u8, 40, 40, 255],
                PixelSource::Traced => [255, 0, 0, 255],
                PixelSource::Interpolated => [0, 255, 0, 255],
            })
            .collect(),
        f.output.rgba8.clone(),
        f.reference_output
            .as_ref()
            .map(|r| r.rgba8.clone())
            .unwrap_or_else(|| vec![0; w * h * 4]),
        f.reference
            .as_ref()
            .map(|r| {
                r.diff
                    .heatmap
                    .chunks_exact(3)
                    .flat_map(|p| [p[0], p[1], p[2], 255])
                    .collect()
            })
            .unwrap_or_else(|| vec![0; w * h * 4]),
    ];
    let z = if w > 100 { 2 } else { 4 };
    let (ow, oh) = (w * z * panels.len(), h * z);
    let mut out = vec![0u8; ow * oh * 4];
    for (i, p) in panels.iter().enumerate() {
        for y in 0..oh {
            for x in 0..w * z {
                let s = ((y / z) * w + x / z) * 4;
                let d = (y * ow + i * w * z + x) * 4;
                out[d..d + 4].copy_from_slice(&p[s..s + 4]);
            }
        }
    }
    image::save_buffer(
        format!("{dir}/{name}_{:04}.png", f.index),
        &out,
        ow as u32,
        oh as u32,
        image::ColorType::Rgba8,
    )
    .unwrap();
}

#[test]
#[ignore]
fn debug_lateral_shift() {
    use rqr::render::reproject::Reprojector;
    use rqr::scene::procedural::{assemble, look_at, quad};
    use rqr::scene::{Instance, Material};
    let ctx = common::gpu();
    let wall = Material {
        roughness: 1.0,
        metallic: 0.0,
        ..Default::default()
    };
    let scene = assemble(
        vec![quad(0)],
        vec![Instance {
            geometry: 0,
            transform: glam::Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2)
                * glam::Mat4::from_scale(Vec3::splat(50.0)),
            node: 0,
        }],
        vec![wall],
        rqr::scene::default_lights(),
        vec![],
    );
    let r = renderer(&ctx, &scene);
    let s = settings(64);
    let mut rp = Reprojector::new(&ctx, &r, RenderPath::Rt, &s, reproject()).unwrap();
    for k in 0..6 {
        let x = k as f32 * 0.0137;
        let cam = look_at(Vec3::new(x, 0.0, 5.0), Vec3::new(x, 0.0, 0.0), 40.0);
        let f = rp.render(&ctx, &[], &cam, k).unwrap();
        eprintln!("frame {k}: {:?}", f.stats);
    }
}
