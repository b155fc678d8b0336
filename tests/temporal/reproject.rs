//! Temporal reprojection, frameless rendering and adaptive sub-sampling on small
//! images of the procedural Cornell room (lavapipe is slow: ≤ 96×96, few frames).

use crate::support;

use glam::{Mat4, Vec3, Vec4};
use rqr::accel::{Backend, BackendChoice};
use rqr::render::drivers::sequence::{CameraPath, Sequence, SequenceFrame, SequenceOptions};
use rqr::render::temporal::{PixelSource, PrimaryRayCheck, ReuseOptions};
use rqr::render::{CameraSetup, RenderOutput, RenderPath, RenderSettings, Renderer};
use rqr::scene::procedural::{assemble, cornell, cube, look_at, quad};
use rqr::scene::{Camera, Instance, Material, Scene};
use rqr::vk::Context;

/// The three ways of checking reprojected samples.
const MODES: [(RenderPath, PrimaryRayCheck); 3] = [
    (RenderPath::RayTraced, PrimaryRayCheck::Edges),
    (RenderPath::RayTraced, PrimaryRayCheck::Full),
    (RenderPath::Hybrid, PrimaryRayCheck::Edges),
];

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

/// Both ray backends where the device has hardware ray queries, else the compute BVH.
fn backends(ctx: &Context) -> Vec<Backend> {
    let mut b = vec![Backend::Bvh];
    if ctx.features().ray_query {
        b.insert(0, Backend::Hw);
    }
    b
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
    let ctx = support::gpu();
    let scene = cornell();
    for backend in backends(&ctx) {
        static_camera_on(&ctx, &scene, backend);
    }
    support::assert_validation_clean(&ctx);
}

fn static_camera_on(ctx: &Context, scene: &Scene, backend: Backend) {
    let r = Renderer::new(ctx, scene, backend).unwrap();
    let s = settings(64);
    for (path, visibility) in MODES {
        let options = SequenceOptions {
            path,
            reuse: ReuseOptions {
                rt_visibility: visibility,
                ..reproject()
            },
            reference: true,
        };
        let mut seq = Sequence::new(
            ctx,
            &r,
            scene,
            &s,
            scene.cameras[0],
            CameraPath::Static,
            options,
        )
        .unwrap();
        for k in 0..3 {
            let f = seq.render_frame(ctx, k).unwrap();
            assert_stats_add_up(&f);
            let full = f.reference_output.as_ref().unwrap();
            let d = max_diff(full, &f.output);
            assert!(
                d < 2e-3,
                "{backend:?} {path:?} {visibility:?} frame {k}: max difference {d}"
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
}

/// Pixels traced from the G-buffer (hybrid path, rt path with full visibility) shade their
/// material layers (clearcoat, sheen, specular) like a full render: a static camera over
/// ClearCoatTest reproduces the full render every frame.
#[test]
fn layered_materials_shade_alike_when_reprojected() {
    let ctx = support::gpu();
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets/gltf/ClearCoatTest/ClearCoatTest.glb");
    let scene = rqr::scene::load(&path, &rqr::scene::LoadOptions::default()).unwrap();
    let r = renderer(&ctx, &scene);
    let s = settings(64);
    let camera = scene.camera(None, 1.0).unwrap();
    for (path, visibility) in MODES {
        let options = SequenceOptions {
            path,
            reuse: ReuseOptions {
                rt_visibility: visibility,
                ..reproject()
            },
            reference: true,
        };
        let mut seq =
            Sequence::new(&ctx, &r, &scene, &s, camera, CameraPath::Static, options).unwrap();
        for k in 0..3 {
            let f = seq.render_frame(&ctx, k).unwrap();
            let d = max_diff(f.reference_output.as_ref().unwrap(), &f.output);
            assert!(
                d < 2e-3,
                "{path:?} {visibility:?} frame {k}: max difference {d}"
            );
        }
    }
    support::assert_validation_clean(&ctx);
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

fn sequence(
    ctx: &Context,
    r: &Renderer,
    scene: &Scene,
    size: u32,
    path: CameraPath,
    mode: (RenderPath, PrimaryRayCheck),
    reuse: ReuseOptions,
) -> Sequence {
    Sequence::new(
        ctx,
        r,
        scene,
        &settings(size),
        scene.cameras[0],
        path,
        SequenceOptions {
            path: mode.0,
            reuse: ReuseOptions {
                rt_visibility: mode.1,
                ..reuse
            },
            reference: true,
        },
    )
    .unwrap()
}

/// Instances whose material is a mirror/metal or transmissive.
fn specular_instances(scene: &Scene) -> Vec<i32> {
    scene
        .instances
        .iter()
        .enumerate()
        .filter(|(_, inst)| {
            let m = &scene.materials[scene.geometries[inst.geometry as usize].material as usize];
            m.metallic >= 0.5 || m.transmission > 0.0
        })
        .map(|(i, _)| i as i32)
        .collect()
}

#[test]
fn specular_and_transmissive_pixels_are_never_reused() {
    let ctx = support::gpu();
    let scene = cornell();
    let specular = specular_instances(&scene);
    assert_eq!(specular.len(), 2, "the mirror and the glass sphere");
    let r = renderer(&ctx, &scene);
    let path = CameraPath::Orbit {
        degrees_per_frame: 1.0,
        pivot: Vec3::new(0.0, 2.0, 0.0),
    };
    for mode in MODES {
        for adaptive in [false, true] {
            let reuse = ReuseOptions {
                adaptive_subsample: adaptive,
                ..reproject()
            };
            let mut seq = sequence(&ctx, &r, &scene, 64, path.clone(), mode, reuse);
            for k in 0..3 {
                let f = seq.render_frame(&ctx, k).unwrap();
                assert_stats_add_up(&f);
                let full = r.render_rt(&ctx, &settings(64), &f.camera, true).unwrap();
                let mut seen = 0;
                for (i, a) in full.aov.iter().enumerate() {
                    if specular.contains(&a.instance()) {
                        seen += 1;
                        assert_ne!(
                            f.sources[i],
                            PixelSource::Reused,
                            "{mode:?} adaptive {adaptive} frame {k}: specular pixel {i} reused"
                        );
                    }
                }
                assert!(seen > 200, "{seen} specular pixels in view");
                if k > 0 {
                    assert!(
                        f.stats.view_dependent >= seen as u64 * 9 / 10,
                        "{:?}",
                        f.stats
                    );
                    assert!(f.stats.reused_fraction() > 0.5, "{:?}", f.stats);
                }
            }
        }
    }
    support::assert_validation_clean(&ctx);
}

/// A diffuse wall with a diffuse block floating in front of it.
fn block_before_wall() -> Scene {
    let diffuse = |c: Vec3| Material {
        base_color: c.extend(1.0),
        metallic: 0.0,
        roughness: 1.0,
        ..Default::default()
    };
    let camera = look_at(Vec3::new(0.0, 0.0, 8.0), Vec3::ZERO, 40.0);
    assemble(
        vec![quad(0), cube(1)],
        vec![
            Instance {
                geometry: 0,
                transform: Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2)
                    * Mat4::from_scale(Vec3::splat(40.0)),
                node: 0,
            },
            Instance {
                geometry: 1,
                transform: Mat4::from_translation(Vec3::new(0.0, 0.0, 3.0))
                    * Mat4::from_scale(Vec3::splat(1.5)),
                node: 1,
            },
        ],
        vec![
            diffuse(Vec3::new(0.2, 0.3, 0.8)),
            diffuse(Vec3::new(0.9, 0.2, 0.1)),
        ],
        vec![rqr::scene::Light {
            kind: rqr::scene::LightKind::Point,
            color: Vec3::ONE,
            intensity: 60.0,
            range: f32::INFINITY,
            position: Vec3::new(2.0, 3.0, 9.0),
            direction: -Vec3::Z,
            size: 0.0,
        }],
        vec![camera],
    )
}

/// Pixel of `p` in a `size`² image through `camera`, if in view.
fn project(camera: &Camera, size: u32, p: Vec3) -> Option<usize> {
    let setup = CameraSetup::new(camera, size, size, 1.0);
    let clip = setup.proj * setup.view() * p.extend(1.0);
    if clip.w <= 0.0 {
        return None;
    }
    let film =
        (Vec4::new(clip.x, clip.y, 0.0, 0.0) / clip.w * 0.5 + Vec4::splat(0.5)) * size as f32;
    let (x, y) = (film.x.floor(), film.y.floor());
    (x >= 0.0 && y >= 0.0 && x < size as f32 && y < size as f32)
        .then(|| y as usize * size as usize + x as usize)
}

#[test]
fn disocclusions_are_traced_not_smeared() {
    let ctx = support::gpu();
    let scene = block_before_wall();
    for backend in backends(&ctx) {
        let r = Renderer::new(&ctx, &scene, backend).unwrap();
        disocclusions_on(&ctx, &scene, &r);
    }
    support::assert_validation_clean(&ctx);
}

fn disocclusions_on(ctx: &Context, scene: &Scene, r: &Renderer) {
    let size = 64;
    // 6 degrees about the wall's centre: the block shifts by several pixels over the wall.
    let path = CameraPath::Orbit {
        degrees_per_frame: 6.0,
        pivot: Vec3::ZERO,
    };
    for mode in MODES {
        let mut seq = sequence(ctx, r, scene, size, path.clone(), mode, reproject());
        let f0 = seq.render_frame(ctx, 0).unwrap();
        let f1 = seq.render_frame(ctx, 1).unwrap();
        debug_dump(&f1, &format!("disocclusion_{mode:?}"));
        assert_stats_add_up(&f1);
        let a0 = r.render_rt(ctx, &settings(size), &f0.camera, true).unwrap();
        let a1 = r.render_rt(ctx, &settings(size), &f1.camera, true).unwrap();
        // Wall pixels of frame 1 whose wall point frame 0 saw behind the block.
        let revealed: Vec<usize> = (0..a1.aov.len())
            .filter(|&i| {
                let a = a1.aov[i];
                a.instance() == 0
                    && project(&f0.camera, size, a.world_position())
                        .is_some_and(|j| a0.aov[j].instance() == 1)
            })
            .collect();
        assert!(
            revealed.len() >= 40,
            "{mode:?}: {} revealed pixels",
            revealed.len()
        );
        let traced = revealed
            .iter()
            .filter(|&&i| f1.sources[i] == PixelSource::Traced)
            .count();
        assert!(
            traced * 10 >= revealed.len() * 8,
            "{mode:?}: {traced} of {} revealed pixels traced",
            revealed.len()
        );
        // Whatever their source, revealed pixels show the wall, not the block's red.
        let full = f1.reference_output.as_ref().unwrap();
        for &i in &revealed {
            let (c, e) = (f1.output.color[i], full.color[i]);
            let d = (0..3).map(|k| (c[k] - e[k]).abs()).fold(0.0, f32::max);
            assert!(
                d < 0.05,
                "{mode:?}: revealed pixel {i} ({:?}) shows {c:?}, the wall is {e:?}",
                f1.sources[i]
            );
        }
        // And the image as a whole matches the full render.
        let rc = f1.reference.as_ref().unwrap();
        assert!(
            rc.diff.flip_mean < 0.03,
            "{mode:?}: FLIP {}",
            rc.diff.flip_mean
        );
    }
}

/// rt path: an interpolated pixel on a block whose samples lie on one plane is cached where
/// its ray meets that plane, without a primary ray of its own; the cached samples then
/// reproject like traced ones (a static camera's next frame reuses them, instead of filling
/// the pixels from neighbours, and matches the full render).
#[test]
fn adaptive_subsampling_caches_planar_blocks_without_rays() {
    let ctx = support::gpu();
    let scene = cornell();
    let r = renderer(&ctx, &scene);
    let reuse = ReuseOptions {
        reproject: true,
        adaptive_subsample: true,
        subsample_threshold: 0.1,
        ..Default::default()
    };
    let mut seq = sequence(&ctx, &r, &scene, 96, CameraPath::Static, MODES[0], reuse);
    let first = seq.render_frame(&ctx, 0).unwrap();
    assert_stats_add_up(&first);
    let (traced, interpolated) = (first.stats.traced, first.stats.interpolated);
    assert!(interpolated > 96 * 96 / 4, "{:?}", first.stats);
    // Only traced pixels have primary rays.
    assert_eq!(first.output.rays.primary, traced, "{:?}", first.stats);
    let next = seq.render_frame(&ctx, 1).unwrap();
    assert_stats_add_up(&next);
    assert!(
        next.stats.reused_fraction() > 0.8,
        "static camera: {:?}",
        next.stats
    );
    // Most interpolated pixels (the Cornell box is walls and blocks) kept a sample of their
    // own; an uncached one would be empty and filled from a neighbour.
    assert!(
        next.stats.filled + next.stats.holes < interpolated / 4,
        "interpolated {interpolated} before: {:?}",
        next.stats
    );
    let rc = next.reference.as_ref().unwrap();
    assert!(rc.diff.flip_mean < 0.05, "FLIP {}", rc.diff.flip_mean);
    support::assert_validation_clean(&ctx);
}

#[test]
fn adaptive_subsampling_interpolates_smooth_blocks() {
    let ctx = support::gpu();
    let scene = cornell();
    let r = renderer(&ctx, &scene);
    let reuse = ReuseOptions {
        adaptive_subsample: true,
        subsample_threshold: 0.1,
        ..Default::default()
    };
    for mode in [MODES[0], MODES[2]] {
        let mut seq = sequence(&ctx, &r, &scene, 96, CameraPath::Static, mode, reuse);
        for k in 0..2 {
            let f = seq.render_frame(&ctx, k).unwrap();
            assert_stats_add_up(&f);
            // No reprojection: every frame is sub-sampled anew.
            assert_eq!(f.stats.reused, 0);
            let full = f.reference_output.as_ref().unwrap();
            let rc = f.reference.as_ref().unwrap();
            assert!(
                f.stats.interpolated_fraction() > 0.3 && f.stats.traced_fraction() < 0.7,
                "{mode:?}: {:?}",
                f.stats
            );
            assert!(
                f.output.rays.shadow < full.rays.shadow * 8 / 10,
                "{mode:?}: {:?} vs {:?}",
                f.output.rays,
                full.rays
            );
            assert!(
                rc.diff.flip_mean < 0.05,
                "{mode:?}: FLIP {}",
                rc.diff.flip_mean
            );
            // Block corners and centres are always traced.
            for (y, x) in [(0usize, 0usize), (4, 4), (2, 2), (8, 12), (95, 95)] {
                assert_eq!(f.sources[y * 96 + x], PixelSource::Traced, "pixel {x},{y}");
            }
        }
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn frameless_sweeps_over_every_pixel() {
    let ctx = support::gpu();
    let scene = cornell();
    let r = renderer(&ctx, &scene);
    let n = 64usize;
    let reuse = ReuseOptions {
        frameless_percent: Some(25.0),
        ..Default::default()
    };
    let mut seq = sequence(
        &ctx,
        &r,
        &scene,
        n as u32,
        CameraPath::Static,
        MODES[2],
        reuse,
    );
    let mut last_traced = vec![0u32; n * n];
    for k in 0..9 {
        let f = seq.render_frame(&ctx, k).unwrap();
        assert_stats_add_up(&f);
        for (i, s) in f.sources.iter().enumerate() {
            if *s == PixelSource::Traced {
                last_traced[i] = k;
            }
        }
        if k > 0 {
            let share = f.stats.traced_fraction();
            assert!(
                (0.24..0.28).contains(&share),
                "frame {k}: traced {share:.3}, {:?}",
                f.stats
            );
            assert!(f.stats.frameless > 0);
            let d = max_diff(f.reference_output.as_ref().unwrap(), &f.output);
            assert!(d < 2e-3, "frame {k}: static frameless differs by {d}");
        }
        if k >= 4 {
            // The sweep: 25 % a frame reaches every pixel within 4 frames (plus one for the
            // share the specular pixels take every frame).
            let stale = last_traced.iter().filter(|&&t| t + 5 < k).count();
            assert_eq!(
                stale, 0,
                "frame {k}: {stale} pixels not traced for 5 frames"
            );
        }
    }
    support::assert_validation_clean(&ctx);
}

/// A moving camera leaves holes (empty pixels no neighbour fills), which are traced anyway:
/// they count toward the frameless budget like the other pixels that must be traced, so a
/// frame traces the budget (plus what the visibility tests reject), not the budget plus its
/// holes.
#[test]
fn frameless_counts_holes_toward_its_budget() {
    let ctx = support::gpu();
    let scene = cornell();
    let r = renderer(&ctx, &scene);
    let reuse = ReuseOptions {
        frameless_percent: Some(20.0),
        ..Default::default()
    };
    let path = CameraPath::Orbit {
        degrees_per_frame: 2.0,
        pivot: Vec3::new(0.0, 2.0, 0.0),
    };
    for mode in [MODES[0], MODES[2]] {
        let mut seq = sequence(&ctx, &r, &scene, 64, path.clone(), mode, reuse);
        let mut holes = 0;
        for k in 0..5 {
            let f = seq.render_frame(&ctx, k).unwrap();
            assert_stats_add_up(&f);
            if k == 0 {
                continue;
            }
            let s = &f.stats;
            let budget = (s.pixels as f64 * 0.2).ceil() as u64;
            assert!(s.traced >= budget, "{mode:?} frame {k}: {s:?}");
            // Selected by the sweep only where the pixels that must be traced leave room (the
            // window takes whole refresh bins, so allow 1 % over).
            let forced = s.holes + s.view_dependent + s.expired;
            assert!(
                s.frameless + forced <= budget.max(forced) + s.pixels / 100,
                "{mode:?} frame {k}: {s:?}"
            );
            holes += s.holes;
        }
        assert!(
            holes > 64 * 64 / 100,
            "{mode:?}: the orbit left {holes} holes"
        );
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn max_age_and_frame_ranges() {
    let ctx = support::gpu();
    let scene = cornell();
    let r = renderer(&ctx, &scene);
    let reuse = ReuseOptions {
        max_age: Some(2),
        ..reproject()
    };
    let path = CameraPath::Orbit {
        degrees_per_frame: 0.5,
        pivot: Vec3::new(0.0, 2.0, 0.0),
    };
    let mut seq = sequence(&ctx, &r, &scene, 48, path.clone(), MODES[2], reuse);
    let frames: Vec<SequenceFrame> = (0..5).map(|k| seq.render_frame(&ctx, k).unwrap()).collect();
    // Traced at 0, reused at 1 and 2 (ages 1, 2), expired at 3.
    assert_eq!(frames[1].stats.expired, 0);
    assert_eq!(frames[2].stats.expired, 0);
    assert!(
        frames[3].stats.expired as f64 > 0.6 * frames[3].stats.pixels as f64,
        "{:?}",
        frames[3].stats
    );
    // A range starts from an empty cache and depends on nothing before it.
    let mut a = sequence(&ctx, &r, &scene, 48, path.clone(), MODES[2], reuse);
    let a3 = a.render_frame(&ctx, 3).unwrap();
    let a4 = a.render_frame(&ctx, 4).unwrap();
    assert_eq!(
        a3.stats.traced, a3.stats.pixels,
        "a range's first frame is full"
    );
    assert_eq!(a3.camera, frames[3].camera, "frame numbers are global");
    let mut b = sequence(&ctx, &r, &scene, 48, path, MODES[2], reuse);
    let b3 = b.render_frame(&ctx, 3).unwrap();
    let b4 = b.render_frame(&ctx, 4).unwrap();
    assert_eq!(a3.output.rgba8, b3.output.rgba8);
    assert_eq!(a4.output.rgba8, b4.output.rgba8);
    assert_eq!(a4.stats, b4.stats);
    // Skipping a frame restarts the cache.
    let b6 = b.render_frame(&ctx, 6).unwrap();
    assert_eq!(b6.stats.traced, b6.stats.pixels);
    support::assert_validation_clean(&ctx);
}
