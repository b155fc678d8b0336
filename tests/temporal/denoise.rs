//! The denoiser (`--denoise`) against converged references and against itself: without
//! history it changes nothing it should not (demodulation multiplies back exactly), the
//! spatial filter lowers the error and keeps a depth edge, a static view accumulates the plain
//! mean of its frames and holds still, 30 accumulated frames beat 16 samples per pixel, the hybrid path and both backends agree, runs repeat bit for bit (in bursts or
//! frame by frame), a camera cut drops the history, a disoccluded pixel starts again within
//! one frame, a light seen directly leaves no trail when the view moves, and neither does a
//! moving shadow on a still surface; the background is looked up at pixel centres over their
//! footprint rather than accumulated.

use crate::support;

use glam::{Mat4, Vec3, Vec4};
use rqr::accel::Backend;
use rqr::render::denoise::DenoiseMode;
use rqr::render::drivers::sequence::{CameraPath, Sequence, SequenceOptions};
use rqr::render::image::metrics;
use rqr::render::passes::draw_list;
use rqr::render::readback::RingContents;
use rqr::render::{
    CameraSetup, FrameTargets, RenderOutput, RenderPath, RenderSettings, Renderer, SamplerKind,
    Shading,
};
use rqr::scene::procedural::{assemble, cornell, look_at, quad};
use rqr::scene::{Camera, Instance, Light, LightKind, Material, MaterialLayers, Scene};
use rqr::vk::Context;

const SIDE: u32 = 64;

/// What burst frames read back: the image and its linear colour.
const FRAMES: RingContents = RingContents {
    rgba8: true,
    color: true,
    aov: false,
    states: false,
};

fn backends(ctx: &Context) -> Vec<Backend> {
    let mut b = vec![Backend::Bvh];
    if ctx.features().ray_query {
        b.push(Backend::Hw);
    }
    b
}

/// The test room with sphere lights.
fn soft_cornell() -> Scene {
    let mut scene = cornell();
    for l in &mut scene.lights {
        l.size = 0.2;
    }
    scene
}

fn settings(denoise: DenoiseMode, spp: u32) -> RenderSettings {
    sized(denoise, spp, SIDE)
}

fn sized(denoise: DenoiseMode, spp: u32, side: u32) -> RenderSettings {
    RenderSettings {
        width: side,
        height: side,
        spp,
        sampler: SamplerKind::Sobol,
        shading: Shading::Distributed,
        denoise,
        ..Default::default()
    }
}

fn targets(
    ctx: &Context,
    renderer: &Renderer,
    scene: &Scene,
    path: RenderPath,
    s: &RenderSettings,
) -> FrameTargets {
    FrameTargets::new(ctx, renderer, path, s, &draw_list::draws(scene), true).unwrap()
}

/// Writes `target/denoise-tests/<name>-actual.png` and `-diff.png` (FLIP heatmap against
/// `reference`) for a failing comparison, and returns the folder.
fn save_failure(name: &str, actual: &RenderOutput, reference: &RenderOutput) -> String {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("denoise-tests");
    std::fs::create_dir_all(&dir).unwrap();
    let (w, h) = (actual.width, actual.height);
    let save = |file: &str, rgba: &[u8]| {
        image::save_buffer(dir.join(file), rgba, w, h, image::ColorType::Rgba8).unwrap();
    };
    save(&format!("{name}-actual.png"), &actual.rgba8);
    save(&format!("{name}-reference.png"), &reference.rgba8);
    let d = metrics::compare(w, h, &reference.rgba8, &actual.rgba8);
    image::save_buffer(
        dir.join(format!("{name}-diff.png")),
        &d.heatmap,
        w,
        h,
        image::ColorType::Rgb8,
    )
    .unwrap();
    dir.display().to_string()
}

/// The converged image: `spp` samples per pixel, no denoiser.
fn reference(ctx: &Context, renderer: &Renderer, camera: &Camera, spp: u32) -> RenderOutput {
    let s = RenderSettings {
        seed: 99,
        ..settings(DenoiseMode::None, spp)
    };
    renderer.render_rt(ctx, &s, camera, false).unwrap()
}

#[test]
fn without_history_temporal_mode_returns_the_frame_as_shaded() {
    let ctx = support::gpu();
    let scene = soft_cornell();
    let camera = scene.cameras[0];
    let renderer = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    for path in [RenderPath::RayTraced, RenderPath::Hybrid] {
        let spp = if path == RenderPath::Hybrid { 2 } else { 1 };
        let raw = targets(
            &ctx,
            &renderer,
            &scene,
            path,
            &settings(DenoiseMode::None, spp),
        )
        .render(&ctx, &camera)
        .unwrap();
        let mut t = targets(
            &ctx,
            &renderer,
            &scene,
            path,
            &settings(DenoiseMode::Temporal, spp),
        );
        let split = t.render(&ctx, &camera).unwrap();
        // Demodulated, accumulated over one frame and multiplied back: the colour again.
        let mut worst = 0f32;
        for (a, b) in raw.color.iter().zip(&split.color) {
            for c in 0..3 {
                worst = worst.max((a[c] - b[c]).abs() / a[c].abs().max(0.05));
            }
        }
        assert!(worst < 1e-3, "{path:?}: worst relative change {worst}");
        // The guide's parts never exceed the colour they split.
        let guide = t.denoiser().unwrap().read_guide(&ctx).unwrap();
        for (g, c) in guide.iter().zip(&raw.color) {
            let w = g.diffuse[3].max(1e-6);
            for (k, &colour) in c.iter().take(3).enumerate() {
                let parts = (g.diffuse[k] + g.unfiltered[k]) / w;
                assert!(
                    parts <= colour * 1.001 + 1e-5,
                    "{path:?}: parts {parts} > {colour}"
                );
            }
        }
        assert!(
            guide.iter().any(|g| g.diffuse[0] > 0.0),
            "{path:?}: no diffuse light in the split"
        );
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn the_spatial_filter_lowers_the_error_of_one_frame() {
    let ctx = support::gpu();
    let scene = soft_cornell();
    let camera = scene.cameras[0];
    let renderer = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    // 128² (the à-trous footprint, 62 pixels, then covers a wall, not the whole image).
    let side = 128;
    // Both estimators of a spent diffuse lobe: light sampling alone (the default here) and the
    // traced diffuse ray, whose noisier frame (glossy draws' fireflies on the walls) leaves
    // the filter more to remove.
    let estimators = [(false, 0.8), (true, 0.6)];
    for (path, (traced, wall_limit)) in [RenderPath::RayTraced, RenderPath::Hybrid]
        .into_iter()
        .flat_map(|p| estimators.map(|e| (p, e)))
    {
        let sized = |denoise, spp, side| RenderSettings {
            trace_spent_diffuse: traced,
            ..sized(denoise, spp, side)
        };
        let truth = renderer
            .render_rt(
                &ctx,
                &RenderSettings {
                    seed: 99,
                    ..sized(DenoiseMode::None, 512, side)
                },
                &camera,
                false,
            )
            .unwrap();
        let raw = targets(
            &ctx,
            &renderer,
            &scene,
            path,
            &sized(DenoiseMode::None, 1, side),
        )
        .render(&ctx, &camera)
        .unwrap();
        let svgf = targets(
            &ctx,
            &renderer,
            &scene,
            path,
            &sized(DenoiseMode::Svgf, 1, side),
        )
        .render(&ctx, &camera)
        .unwrap();
        let (e_raw, e_svgf) = (
            metrics::display_mse(&raw.color, &truth.color),
            metrics::display_mse(&svgf.color, &truth.color),
        );
        // On the room's diffuse walls (instances 0-4) the filter has the most to do; the
        // mirror and glass spheres' sharp reflections are left to accumulation over frames.
        let walls = |img: &RenderOutput| -> Vec<[f32; 4]> {
            img.color
                .iter()
                .zip(&raw.aov)
                .filter(|(_, a)| (0..5).contains(&a.instance()))
                .map(|(c, _)| *c)
                .collect()
        };
        let (w_raw, w_svgf) = (
            metrics::display_mse(&walls(&raw), &walls(&truth)),
            metrics::display_mse(&walls(&svgf), &walls(&truth)),
        );
        if e_svgf >= 0.9 * e_raw || w_svgf >= wall_limit * w_raw {
            let dir = save_failure(&format!("one-frame-{}", path.as_str()), &svgf, &truth);
            panic!(
                "{path:?}, traced diffuse ray {traced}: MSE raw {e_raw:.3e}, one denoised frame {e_svgf:.3e}; on the walls {w_raw:.3e} and {w_svgf:.3e} (images in {dir})"
            );
        }
        // Its passes are timed under their own scopes.
        for scope in [
            "denoise temporal",
            "denoise variance",
            "denoise atrous",
            "denoise remodulate",
        ] {
            assert!(
                svgf.gpu_ms.iter().any(|(n, ms)| n == scope && *ms >= 0.0),
                "{path:?}: no {scope} timing in {:?}",
                svgf.gpu_ms
            );
        }
    }
    support::assert_validation_clean(&ctx);
}

/// Frame `k` of a sequence through `camera` in `t` (its samples numbered k × spp on).
fn numbered(ctx: &Context, t: &mut FrameTargets, camera: &Camera, k: u32) -> RenderOutput {
    let frame = t.sequence_frame(camera, k);
    ctx.run("test frame", |cmd| {
        t.record(ctx, cmd, &frame, None, Some((t.readback_ring(), 0)));
        Ok(())
    })
    .unwrap();
    t.read().unwrap()
}

#[test]
fn a_static_view_accumulates_the_plain_mean_of_its_jittered_frames_and_holds_still() {
    // The light is accumulated before it is divided by the albedo, so with no spatial filter
    // the output is the mean of the frames, even where a jittered sample lands on another
    // surface of the pixel every frame; the history is tested against the pixel centre's
    // surface, so no pixel (silhouettes included) drops it; and the denoised frames change
    // from one to the next by under a tenth of what the raw frames do.
    const N: u32 = 30;
    let ctx = support::gpu();
    let scene = soft_cornell();
    let camera = scene.cameras[0];
    let renderer = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    for path in [RenderPath::RayTraced, RenderPath::Hybrid] {
        let accumulate = settings(DenoiseMode::Temporal, 1);
        // A history of one frame: each frame as shaded, with the same jittered samples.
        let alone = RenderSettings {
            history_cap: 1,
            ..accumulate.clone()
        };
        let svgf = settings(DenoiseMode::Svgf, 1);
        let mut acc = targets(&ctx, &renderer, &scene, path, &accumulate);
        let mut each = targets(&ctx, &renderer, &scene, path, &alone);
        let mut filtered = targets(&ctx, &renderer, &scene, path, &svgf);
        let mut sum = vec![[0.0f64; 3]; (SIDE * SIDE) as usize];
        let (mut raw_frames, mut denoised_frames, mut last) = (Vec::new(), Vec::new(), None);
        for k in 0..N {
            let f = numbered(&ctx, &mut each, &camera, k);
            for (s, c) in sum.iter_mut().zip(&f.color) {
                for ch in 0..3 {
                    s[ch] += f64::from(c[ch]);
                }
            }
            last = Some(numbered(&ctx, &mut acc, &camera, k));
            if k >= 20 {
                raw_frames.push(f);
                denoised_frames.push(numbered(&ctx, &mut filtered, &camera, k));
            } else {
                numbered(&ctx, &mut filtered, &camera, k);
            }
        }
        let last = last.unwrap();
        let worst = last
            .color
            .iter()
            .zip(&sum)
            .flat_map(|(c, s)| {
                (0..3).map(move |ch| {
                    let mean = s[ch] / f64::from(N);
                    (f64::from(c[ch]) - mean).abs() / mean.max(1e-2)
                })
            })
            .fold(0.0, f64::max);
        assert!(
            worst < 1e-3,
            "{path:?}: accumulated frame off the frames' mean by {worst:.2e}"
        );
        let lengths = acc.denoiser().unwrap().history_lengths(&ctx).unwrap();
        let dropped = lengths
            .iter()
            .filter(|&&l| l != 0.0 && l != N as f32)
            .count();
        assert_eq!(dropped, 0, "{path:?}: {dropped} pixels lost their history");
        let change = |frames: &[RenderOutput]| {
            frames
                .windows(2)
                .map(|w| metrics::display_mean_abs_diff(&w[0].color, &w[1].color))
                .sum::<f64>()
                / (frames.len() - 1) as f64
        };
        let (raw, denoised) = (change(&raw_frames), change(&denoised_frames));
        assert!(
            denoised <= 0.1 * raw,
            "{path:?}: frame-to-frame change {denoised:.2e} denoised against {raw:.2e} raw"
        );
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn thirty_accumulated_frames_beat_sixteen_samples_per_pixel() {
    let ctx = support::gpu();
    let scene = soft_cornell();
    let camera = scene.cameras[0];
    let renderer = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    let truth = reference(&ctx, &renderer, &camera, 1024);
    let sixteen = renderer
        .render_rt(&ctx, &settings(DenoiseMode::None, 16), &camera, false)
        .unwrap();
    let mut seq = Sequence::new(
        &ctx,
        &renderer,
        &scene,
        &settings(DenoiseMode::Svgf, 1),
        camera,
        CameraPath::Static,
        SequenceOptions {
            path: RenderPath::RayTraced,
            reuse: Default::default(),
            reference: false,
        },
    )
    .unwrap();
    let frames = seq.prepare_bursts(&ctx, 30, FRAMES, 1 << 30);
    let frames = frames.unwrap();
    let mut last = None;
    let mut start = 0;
    while start < 30 {
        let end = (start + frames).min(30);
        last = seq.render_burst(&ctx, start..end).unwrap().pop();
        start = end;
    }
    let last = last.unwrap();
    let (e16, e30) = (
        metrics::display_mse(&sixteen.color, &truth.color),
        metrics::display_mse(&last.output.color, &truth.color),
    );
    if e30 > e16 {
        let dir = save_failure("thirty-frames", &last.output, &truth);
        panic!("MSE after 30 denoised frames {e30:.3e}, 16 spp {e16:.3e} (images in {dir})");
    }
    let lengths = seq
        .full_targets()
        .denoiser()
        .unwrap()
        .history_lengths(&ctx)
        .unwrap();
    let max = lengths.iter().cloned().fold(0.0, f32::max);
    assert_eq!(max, 30.0, "a static pixel's history is every frame so far");
    support::assert_validation_clean(&ctx);
}

/// A white floor (y = 0) and, over x < 0, a white plane one unit above it, seen from straight
/// above, lit by a small sun from the upper left: the upper plane is lit, the floor beside
/// its edge lies in its shadow. The same normal on both sides, a step in depth and in light.
fn step_scene() -> (Scene, Camera) {
    let white = Material {
        base_color: Vec4::new(0.8, 0.8, 0.8, 1.0),
        metallic: 0.0,
        roughness: 1.0,
        layers: Some(Box::new(MaterialLayers {
            specular: 0.0,
            ..Default::default()
        })),
        ..Default::default()
    };
    let scene = assemble(
        vec![quad(0)],
        vec![
            Instance {
                geometry: 0,
                transform: Mat4::from_scale(Vec3::new(20.0, 1.0, 20.0)),
                node: 0,
            },
            Instance {
                geometry: 0,
                transform: Mat4::from_translation(Vec3::new(-5.0, 1.0, 0.0))
                    * Mat4::from_scale(Vec3::new(10.0, 1.0, 20.0)),
                node: 1,
            },
        ],
        vec![white],
        vec![Light {
            kind: LightKind::Directional,
            color: Vec3::ONE,
            intensity: 3.0,
            range: f32::INFINITY,
            position: Vec3::ZERO,
            direction: Vec3::new(1.0, -1.0, 0.0).normalize(),
            size: 0.02,
        }],
        vec![],
    );
    let camera = look_at(Vec3::new(0.0, 8.0, 0.0), Vec3::ZERO, 12.0);
    (scene, camera)
}

#[test]
fn the_spatial_filter_keeps_a_depth_edge() {
    let ctx = support::gpu();
    let (scene, camera) = step_scene();
    let renderer = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    let truth = reference(&ctx, &renderer, &camera, 1024);
    let out = renderer
        .render_rt(&ctx, &settings(DenoiseMode::Svgf, 1), &camera, true)
        .unwrap();
    // The edge's column: where the hit depth jumps along the middle row.
    let row = SIDE as usize / 2;
    let depth = |x: usize| out.aov[row * SIDE as usize + x].depth();
    let edge = (1..SIDE as usize)
        .find(|&x| (depth(x) - depth(x - 1)).abs() > 0.5)
        .expect("no depth edge in the middle row");
    assert!((16..48).contains(&edge), "edge at column {edge}");
    let luminance = |c: &[f32; 4]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    // Mean over the rows of the 3 columns beside the edge on each side (the edge column's
    // pixels straddle it and are left out).
    let side_mean = |img: &[[f32; 4]], cols: std::ops::Range<usize>| {
        let mut sum = 0.0;
        let mut n = 0.0;
        for y in 8..SIDE as usize - 8 {
            for x in cols.clone() {
                sum += luminance(&img[y * SIDE as usize + x]);
                n += 1.0;
            }
        }
        sum / n
    };
    let near = (edge - 4)..(edge - 1);
    let far = (edge + 1)..(edge + 4);
    let (t_near, t_far) = (
        side_mean(&truth.color, near.clone()),
        side_mean(&truth.color, far.clone()),
    );
    assert!(
        t_near > 4.0 * t_far,
        "the upper side should be lit, the lower in shadow: {t_near} vs {t_far}"
    );
    for (name, cols, want) in [("upper", near, t_near), ("lower", far, t_far)] {
        let got = side_mean(&out.color, cols);
        assert!(
            (got - want).abs() <= 0.06 * want + 0.01 * t_near,
            "{name} side of the edge: denoised {got}, reference {want}"
        );
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn hybrid_and_both_backends_denoise_alike() {
    let ctx = support::gpu();
    let scene = soft_cornell();
    let camera = scene.cameras[0];
    let s = settings(DenoiseMode::Svgf, 1);
    let mut images = Vec::new();
    for backend in backends(&ctx) {
        let renderer = Renderer::new(&ctx, &scene, backend).unwrap();
        for path in [RenderPath::RayTraced, RenderPath::Hybrid] {
            let out = targets(&ctx, &renderer, &scene, path, &s)
                .render(&ctx, &camera)
                .unwrap();
            images.push((format!("{backend:?} {path:?}"), out.rgba8));
        }
    }
    let (first_name, first) = &images[0];
    for (name, img) in &images[1..] {
        let d = metrics::compare(SIDE, SIDE, first, img);
        assert!(
            d.flip_mean <= 0.01,
            "{name} against {first_name}: FLIP {}",
            d.flip_mean
        );
    }
    support::assert_validation_clean(&ctx);
}

fn orbit_sequence(ctx: &Context, renderer: &Renderer, scene: &Scene, path: RenderPath) -> Sequence {
    Sequence::new(
        ctx,
        renderer,
        scene,
        &settings(DenoiseMode::Svgf, 1),
        scene.cameras[0],
        CameraPath::Orbit {
            degrees_per_frame: 1.0,
            pivot: Vec3::new(0.0, 2.0, 0.0),
        },
        SequenceOptions {
            path,
            reuse: Default::default(),
            reference: false,
        },
    )
    .unwrap()
}

#[test]
fn denoised_frames_repeat_bit_for_bit_in_bursts_and_one_by_one() {
    let ctx = support::gpu();
    let scene = soft_cornell();
    let renderer = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    for path in [RenderPath::RayTraced, RenderPath::Hybrid] {
        let one_by_one: Vec<Vec<u8>> = {
            let mut seq = orbit_sequence(&ctx, &renderer, &scene, path);
            (0..5)
                .map(|k| seq.render_frame(&ctx, k).unwrap().output.rgba8)
                .collect()
        };
        let burst: Vec<Vec<u8>> = {
            let mut seq = orbit_sequence(&ctx, &renderer, &scene, path);
            let n = seq.prepare_bursts(&ctx, 5, FRAMES, 1 << 30).unwrap();
            assert_eq!(n, 5);
            seq.render_burst(&ctx, 0..5)
                .unwrap()
                .into_iter()
                .map(|f| f.output.rgba8)
                .collect()
        };
        let again: Vec<Vec<u8>> = {
            let mut seq = orbit_sequence(&ctx, &renderer, &scene, path);
            (0..5)
                .map(|k| seq.render_frame(&ctx, k).unwrap().output.rgba8)
                .collect()
        };
        assert!(one_by_one == again, "{path:?}: two runs differ");
        assert!(
            one_by_one == burst,
            "{path:?}: burst and frame by frame differ"
        );
        // History is used: frame 4 differs from a fresh render of the same frame.
        let mut fresh = orbit_sequence(&ctx, &renderer, &scene, path);
        let alone = fresh.render_frame(&ctx, 4).unwrap().output.rgba8;
        assert!(
            alone != one_by_one[4],
            "{path:?}: history made no difference"
        );
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn a_camera_cut_drops_the_history() {
    let ctx = support::gpu();
    let scene = soft_cornell();
    let a = scene.cameras[0];
    let renderer = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    let s = settings(DenoiseMode::Svgf, 1);
    let mut t = targets(&ctx, &renderer, &scene, RenderPath::RayTraced, &s);
    for _ in 0..4 {
        t.render(&ctx, &a).unwrap();
    }
    let lengths = t.denoiser().unwrap().history_lengths(&ctx).unwrap();
    assert!(lengths.contains(&4.0), "no history before the cut");
    // A small step keeps the history ...
    let mut nudged = a;
    nudged.camera_to_world = Mat4::from_translation(Vec3::new(0.01, 0.0, 0.0)) * a.camera_to_world;
    t.render(&ctx, &nudged).unwrap();
    let lengths = t.denoiser().unwrap().history_lengths(&ctx).unwrap();
    // (a moving history is capped at MOVING_HISTORY_CAP frames; a dropped one restarts at 1)
    let kept = 5.0f32.min(rqr::render::denoise::MOVING_HISTORY_CAP as f32);
    assert!(
        lengths.iter().any(|&l| l >= kept),
        "a small step lost the history"
    );
    // ... a jump across the room does not.
    let mut cut = a;
    cut.camera_to_world = Mat4::from_translation(Vec3::new(0.0, 0.0, -1.5))
        * Mat4::from_rotation_y(0.9)
        * a.camera_to_world;
    let after_cut = t.render(&ctx, &cut).unwrap();
    let lengths = t.denoiser().unwrap().history_lengths(&ctx).unwrap();
    assert!(
        lengths.iter().all(|&l| l <= 1.0),
        "history used after a cut: longest {}",
        lengths.iter().cloned().fold(0.0, f32::max)
    );
    let fresh = targets(&ctx, &renderer, &scene, RenderPath::RayTraced, &s)
        .render(&ctx, &cut)
        .unwrap();
    assert_eq!(
        after_cut.rgba8, fresh.rgba8,
        "the frame after a cut is not a fresh one"
    );
    support::assert_validation_clean(&ctx);
}

#[test]
fn a_disoccluded_pixel_starts_again_within_one_frame() {
    let ctx = support::gpu();
    let scene = soft_cornell();
    let a = scene.cameras[0];
    let renderer = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    let s = settings(DenoiseMode::Temporal, 1);
    let mut t = targets(&ctx, &renderer, &scene, RenderPath::RayTraced, &s);
    let mut first = None;
    for _ in 0..4 {
        first = Some(t.render(&ctx, &a).unwrap());
    }
    let first = first.unwrap();
    // A sideways step (not a cut) uncovers the wall behind the box and spheres.
    let mut b = a;
    b.camera_to_world = a.camera_to_world * Mat4::from_translation(Vec3::new(1.5, 0.0, 0.0));
    let second = t.render(&ctx, &b).unwrap();
    let lengths = t.denoiser().unwrap().history_lengths(&ctx).unwrap();
    // Where each of b's hits was in a's image, and what a saw there.
    let setup = CameraSetup::new(&a, SIDE, SIDE, renderer.scene_scale());
    let view_proj = setup.proj * setup.view();
    let (mut disoccluded, mut kept, mut continued) = (0, 0, 0);
    for (i, hit) in second.aov.iter().enumerate() {
        if !hit.hit() {
            continue;
        }
        let p = hit.world_position();
        let clip = view_proj * p.extend(1.0);
        let px = (clip.truncate() / clip.w).truncate() * 0.5 + glam::Vec2::splat(0.5);
        let (x, y) = ((px.x * SIDE as f32) as i32, (px.y * SIDE as f32) as i32);
        if x < 1 || y < 1 || x >= SIDE as i32 - 1 || y >= SIDE as i32 - 1 {
            continue;
        }
        // Hidden in a: every neighbour there saw something at least 5 % of the depth nearer.
        let hidden = (-1..=1).all(|dy| {
            (-1..=1).all(|dx| {
                let seen = &first.aov[((y + dy) as u32 * SIDE + (x + dx) as u32) as usize];
                seen.hit()
                    && (seen.world_position() - setup.camera_to_world.w_axis.truncate()).length()
                        < 0.95 * (p - setup.camera_to_world.w_axis.truncate()).length()
            })
        });
        if hidden {
            disoccluded += 1;
            assert_eq!(
                lengths[i], 1.0,
                "disoccluded pixel {i} kept {} frames",
                lengths[i]
            );
        } else {
            kept += 1;
            continued += usize::from(lengths[i] >= 2.0);
        }
    }
    // 13 at 64² (pixel-centre surfaces): enough to see a reset that does not happen.
    assert!(disoccluded >= 10, "only {disoccluded} disoccluded pixels");
    assert!(
        continued * 10 >= kept * 8,
        "{continued} of {kept} visible pixels kept their history"
    );
    support::assert_validation_clean(&ctx);
}

#[test]
fn a_light_seen_directly_leaves_no_trail_when_the_view_moves() {
    let ctx = support::gpu();
    let scene = soft_cornell();
    let a = scene.cameras[0];
    let renderer = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    let side = 96;
    let s = sized(DenoiseMode::Temporal, 1, side);
    let mut t = targets(&ctx, &renderer, &scene, RenderPath::RayTraced, &s);
    for _ in 0..6 {
        t.render(&ctx, &a).unwrap();
    }
    // A sideways step (not a cut): the ceiling light, 2 units in front of the wall behind it,
    // moves some 5 pixels further across the image than that wall, whose motion the history
    // follows.
    let mut b = a;
    b.camera_to_world = a.camera_to_world * Mat4::from_translation(Vec3::new(1.5, 0.0, 0.0));
    let moved = t.render(&ctx, &b).unwrap();
    let converged = renderer
        .render_rt(
            &ctx,
            &RenderSettings {
                seed: 99,
                ..sized(DenoiseMode::None, 64, side)
            },
            &b,
            false,
        )
        .unwrap();
    let luminance = |c: [f32; 4]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    let n = side as i32;
    // Within 2 pixels of a light (a pixel its edge covers in part is lit by some frames'
    // samples and not by others).
    let lit_near = |x: i32, y: i32| {
        (-2..=2).any(|dy| {
            (-2..=2).any(|dx| {
                let (qx, qy) = (x + dx, y + dy);
                (0..n).contains(&qx)
                    && (0..n).contains(&qy)
                    && luminance(converged.color[(qy * n + qx) as usize]) > 2.0
            })
        })
    };
    let light_pixels = converged
        .color
        .iter()
        .filter(|&&c| luminance(c) > 2.0)
        .count();
    assert!(
        light_pixels >= 4,
        "the light covers only {light_pixels} pixels"
    );
    // A pixel brighter than any surface in the room with no light near it now: the light's
    // history, reprojected with the wall behind it, is a patch of such pixels. A lone one is
    // a caustic through the glass ball that lit this frame's sample (the reference has them
    // too), not history.
    let stray = |x: i32, y: i32| {
        (0..n).contains(&x)
            && (0..n).contains(&y)
            && luminance(moved.color[(y * n + x) as usize]) > 2.0
            && !lit_near(x, y)
    };
    let trail: Vec<i32> = (0..n * n)
        .filter(|&i| {
            let (x, y) = (i % n, i / n);
            stray(x, y)
                && (-1..=1).any(|dy| (-1..=1).any(|dx| (dx, dy) != (0, 0) && stray(x + dx, y + dy)))
        })
        .collect();
    assert!(
        trail.is_empty(),
        "{} pixels keep the light's history (first {:?}); see {}",
        trail.len(),
        &trail[..trail.len().min(8)],
        save_failure("light-trail", &moved, &converged)
    );
    support::assert_validation_clean(&ctx);
}

#[test]
fn denoise_settings_are_checked() {
    let bad = [
        (
            RenderSettings {
                denoise: DenoiseMode::Svgf,
                ..Default::default()
            },
            "--shading distributed",
        ),
        (
            RenderSettings {
                history_cap: 0,
                ..settings(DenoiseMode::Svgf, 1)
            },
            "--history-cap",
        ),
    ];
    for (s, want) in bad {
        let e = s.validate(1 << 14).unwrap_err().to_string();
        assert!(e.contains(want), "{e}");
    }
    let (out, _) = support::run_rqr(
        &[
            "render",
            "--denoise",
            "svgf",
            "--width",
            "8",
            "--height",
            "8",
            "-o",
            "/dev/null",
        ],
        &[],
        std::time::Duration::from_secs(120),
    );
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--shading distributed"));
    let (out, _) = support::run_rqr(
        &[
            "render",
            "--shading",
            "distributed",
            "--denoise",
            "svgf",
            "--frames",
            "2",
            "--reproject",
            "--sampler",
            "center",
            "--width",
            "8",
            "--height",
            "8",
            "-o",
            "/tmp/rqr-denoise-reproject.png",
        ],
        &[],
        std::time::Duration::from_secs(120),
    );
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("temporal reuse"), "{err}");
}

/// CesiumMan walking over a floor under a low sun, seen from a still camera: as the figure's
/// shadow moves on, the floor it uncovers is lit again within a frame or two. Counted at the
/// last frame: floor pixels lit in a plain render of that pose that the denoised frame shows
/// at under 80 % of their brightness (a shadow's trail: the history of a still surface kept
/// the dark frames).
#[test]
fn a_moving_shadow_leaves_no_trail() {
    use rqr::accel::bvh::BvhBuild;
    use rqr::render::drivers::animated::{AnimatedFrames, AnimationUpdate};
    let ctx = support::gpu();
    let mut rest = rqr::scene::load(
        &support::scene_files::asset("CesiumMan/CesiumMan.glb"),
        &Default::default(),
    )
    .unwrap();
    let b = rest.bounds;
    let centre = 0.5 * (b.min + b.max);
    let size = (b.max - b.min).max_element();
    // A floor of its own node (posing leaves it where it is), ten times the figure's size.
    let floor_material = Material {
        name: "floor".into(),
        base_color: Vec4::new(0.6, 0.6, 0.6, 1.0),
        metallic: 0.0,
        roughness: 1.0,
        ..Default::default()
    };
    let transform = Mat4::from_translation(Vec3::new(centre.x, b.min.y, centre.z))
        * Mat4::from_scale(Vec3::new(10.0 * size, 1.0, 10.0 * size));
    rest.add_still_object(floor_material, quad, transform);
    rest.lights = vec![Light {
        kind: LightKind::Directional,
        color: Vec3::ONE,
        intensity: 3.0,
        range: f32::INFINITY,
        position: Vec3::ZERO,
        direction: Vec3::new(1.0, -0.6, 0.3).normalize(),
        size: 0.0,
    }];
    let camera = rqr::scene::auto_camera(&rest.bounds, 1.0);
    let floor = (rest.instances.len() - 1) as i32;
    let animations = [0usize];
    let mut anim =
        AnimatedFrames::new(&ctx, &rest, &animations, 0.0, Backend::Bvh, BvhBuild::Host).unwrap();
    let s = settings(DenoiseMode::Temporal, 1);
    let posed = rest.posed(&animations, 0.0);
    let mut seq = Sequence::new(
        &ctx,
        anim.renderer(),
        &posed,
        &s,
        camera,
        CameraPath::Static,
        SequenceOptions {
            path: RenderPath::RayTraced,
            reuse: Default::default(),
            reference: false,
        },
    )
    .unwrap();
    let frames = 16;
    let mut last = None;
    let mut before_last = None;
    // Pixels whose 3x3 neighbourhood is all floor in a render's AOV (away from the figure's
    // outline, where its motion restarts histories by disocclusion).
    let floor_mask = |r: &rqr::render::RenderOutput| -> Vec<bool> {
        let (w, h) = (r.width as i64, r.height as i64);
        (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                (-1..=1).all(|dy| {
                    (-1..=1).all(|dx| {
                        let (qx, qy) = ((x + dx).clamp(0, w - 1), (y + dy).clamp(0, h - 1));
                        let a = &r.aov[(qy * w + qx) as usize];
                        a.hit() && a.instance() == floor
                    })
                })
            })
            .collect()
    };
    for k in 0..frames {
        if k > 0 {
            let (posed, _) = anim
                .update_with(&ctx, k as f32 / 30.0, AnimationUpdate::Refit)
                .unwrap();
            seq.update_scene(&ctx, anim.renderer(), &posed, camera)
                .unwrap();
        }
        last = Some(seq.render_frame(&ctx, k).unwrap().output);
        if k == frames - 2 {
            let r = anim
                .renderer()
                .render_rt(&ctx, &settings(DenoiseMode::None, 1), &camera, true)
                .unwrap();
            before_last = Some(floor_mask(&r));
        }
    }
    let denoised = last.unwrap();
    let plain = anim
        .renderer()
        .render_rt(&ctx, &settings(DenoiseMode::None, 16), &camera, true)
        .unwrap();
    // Floor, away from the figure, in both of the last two frames, so the history matched:
    // only the clamp moving a history far (the shadow came or went) restarts it to one frame.
    let lengths = seq
        .full_targets()
        .denoiser()
        .expect("a denoised sequence has a denoiser")
        .history_lengths(&ctx)
        .unwrap();
    let (before_last, now) = (before_last.unwrap(), floor_mask(&plain));
    let restarted = (0..lengths.len())
        .filter(|&i| before_last[i] && now[i] && lengths[i] == 1.0)
        .count();
    println!("{restarted} floor pixels restarted their history in the last frame");
    // 133 pixels along the shadow's edges; none without the restart.
    assert!(
        restarted >= 40,
        "only {restarted} still floor pixels restarted under the moving shadow"
    );
    let luma = |c: &[f32; 4]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    let lit: Vec<usize> = (0..plain.color.len())
        .filter(|&i| plain.aov[i].hit() && plain.aov[i].instance() == floor)
        .filter(|&i| luma(&plain.color[i]) > 0.1)
        .collect();
    // Under 80 % of the plain render: 99 of 2379 pixels when the history of a still surface
    // is kept whole, 53 with it clamped to this frame's neighbourhood (the shadow's edge,
    // where the neighbourhood still holds shadowed pixels), 51 when a history clamped far
    // also restarts.
    let trail = lit
        .iter()
        .filter(|&&i| luma(&denoised.color[i]) < 0.8 * luma(&plain.color[i]))
        .count();
    assert!(lit.len() > 1000, "only {} lit floor pixels", lit.len());
    println!(
        "{trail} of {} lit floor pixels under 80 % of the plain render",
        lit.len()
    );
    if trail * 100 > lit.len() * 3 {
        let dir = save_failure("shadow-trail", &denoised, &plain);
        panic!(
            "{trail} of {} lit floor pixels kept some of a shadow's darkness (images in {dir})",
            lit.len()
        );
    }
    support::assert_validation_clean(&ctx);
}

/// A small sphere under a checker map of `texels` texels around, bright (`bright`) and dark
/// (`dark`), with its renderer.
fn sphere_under_a_checker(
    ctx: &Context,
    texels: u32,
    bright: [f32; 3],
    dark: [f32; 3],
) -> (Scene, Renderer) {
    let map = rqr::environment::EnvironmentMap::from_fn(texels, |d| {
        let (u, v) = rqr::environment::direction_to_uv(d);
        let columns = (u * texels as f32) as u32;
        let rows = (v * (texels / 2) as f32) as u32;
        if (columns + rows) % 2 == 0 {
            bright
        } else {
            dark
        }
    });
    let scene = assemble(
        vec![rqr::scene::procedural::sphere(0, 32, 16)],
        vec![Instance {
            geometry: 0,
            transform: Mat4::from_scale(Vec3::splat(0.5)),
            node: 0,
        }],
        vec![Material::default()],
        vec![],
        vec![look_at(Vec3::new(0.0, 0.5, 6.0), Vec3::ZERO, 40.0)],
    );
    let mut renderer = Renderer::new(ctx, &scene, Backend::Bvh).unwrap();
    let env = rqr::environment::GpuEnvironment::prepare(ctx, &map).unwrap();
    renderer.set_environment(ctx, Some(env)).unwrap();
    (scene, renderer)
}

#[test]
fn a_moving_view_shows_the_background_at_pixel_centres() {
    let ctx = support::gpu();
    // A small sphere under a coarse checker of bright and dark texels (each some 9 pixels
    // wide, so the map's lookup at a pixel's centre is its own mip 0): a jittered sample or
    // a resampled history of the background differs from that lookup by up to half the
    // checker's contrast.
    let (scene, renderer) = sphere_under_a_checker(&ctx, 64, [3.0, 2.0, 1.0], [0.1, 0.2, 0.3]);
    let base = scene.cameras[0];
    // Turning 1° a frame: a moving history (not a cut).
    let turned = |k: u32| {
        let mut c = base;
        c.camera_to_world =
            base.camera_to_world * Mat4::from_rotation_y((k as f32 * 1.0).to_radians());
        c
    };
    let last = turned(6);
    let centres = renderer
        .render_rt(
            &ctx,
            &RenderSettings {
                sampler: SamplerKind::Center,
                ..settings(DenoiseMode::None, 1)
            },
            &last,
            true,
        )
        .unwrap();
    let n = SIDE as i32;
    // Pixels that see the background and so do their 8 neighbours (no silhouette).
    let background: Vec<usize> = (0..n * n)
        .filter(|&i| {
            let (x, y) = (i % n, i / n);
            (-1..=1).all(|dy| {
                (-1..=1).all(|dx| {
                    let (qx, qy) = ((x + dx).clamp(0, n - 1), (y + dy).clamp(0, n - 1));
                    !centres.aov[(qy * n + qx) as usize].hit()
                })
            })
        })
        .map(|i| i as usize)
        .collect();
    assert!(
        background.len() > (n * n / 2) as usize,
        "the sphere covers too much"
    );
    for path in [RenderPath::RayTraced, RenderPath::Hybrid] {
        let s = settings(DenoiseMode::Svgf, 1);
        let mut t = targets(&ctx, &renderer, &scene, path, &s);
        let mut out = None;
        for k in 0..=6 {
            out = Some(t.render(&ctx, &turned(k)).unwrap());
        }
        let out = out.unwrap();
        let worst = background
            .iter()
            .map(|&i| {
                (0..3)
                    .map(|c| (out.color[i][c] - centres.color[i][c]).abs())
                    .fold(0.0, f32::max)
            })
            .fold(0.0, f32::max);
        assert!(
            worst < 1e-3,
            "{path:?}: the background is {worst} off its lookup at the pixels' centres; see {}",
            save_failure("background", &out, &centres)
        );
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn a_denoised_frame_averages_a_fine_background_over_each_pixel() {
    let ctx = support::gpu();
    // A checker of texels finer than the pixels (1024 texels around, 64 pixels over 40°):
    // a lookup at each pixel's centre alone would show bright or dark texels; over the
    // pixel's footprint it is their mean, as a converged render's many samples are.
    let (scene, renderer) = sphere_under_a_checker(&ctx, 1024, [2.0; 3], [0.2; 3]);
    let camera = scene.cameras[0];
    let converged = reference(&ctx, &renderer, &camera, 64);
    let one =
        |settings: RenderSettings| renderer.render_rt(&ctx, &settings, &camera, true).unwrap();
    let denoised = one(settings(DenoiseMode::Svgf, 1));
    let centres = one(RenderSettings {
        sampler: SamplerKind::Center,
        ..settings(DenoiseMode::None, 1)
    });
    let background: Vec<usize> = (0..centres.aov.len())
        .filter(|&i| !centres.aov[i].hit())
        .collect();
    let mean_error = |out: &RenderOutput| {
        background
            .iter()
            .map(|&i| (out.color[i][1] - converged.color[i][1]).abs() / converged.color[i][1])
            .sum::<f32>()
            / background.len() as f32
    };
    // The setup's check: point lookups are far off (0.21; the footprint's 0.024).
    assert!(
        mean_error(&centres) > 0.15,
        "point lookups {}",
        mean_error(&centres)
    );
    assert!(
        mean_error(&denoised) < 0.05,
        "the denoised background is {} off the converged one; see {}",
        mean_error(&denoised),
        save_failure("fine-background", &denoised, &converged)
    );
    support::assert_validation_clean(&ctx);
}
