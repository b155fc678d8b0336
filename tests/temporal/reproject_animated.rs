//! Reprojection with moving objects: on an animated scene with a static
//! camera, reprojected frames stay close to full renders of the same frames, and samples on
//! the moving objects are reused where they went, which world-space positions cannot do
//! (checked by rendering the same frames with the anchors off).

use crate::support;

use rqr::accel::bvh::BvhBuild;
use rqr::accel::BackendChoice;
use rqr::render::drivers::animated::AnimatedFrames;
use rqr::render::drivers::sequence::{CameraPath, Sequence, SequenceFrame, SequenceOptions};
use rqr::render::temporal::{PrimaryRayCheck, ReuseOptions};
use rqr::render::{RenderPath, RenderSettings};
use rqr::vk::Context;

use support::animated::{camera, load};

const SIZE: u32 = 64;
const FPS: f32 = 24.0;

/// One reprojected frame of [`run`]: rays traced, reused pixels, rejected samples, and with a
/// reference the ray fraction and mean FLIP against the full render of the same frame.
struct Frame {
    rays: u64,
    reused: u64,
    rejected: u64,
    expired: u64,
    reference: Option<(f64, f32)>,
}

/// Renders `frames` frames of `rel`'s first animation at 24 fps with a static camera,
/// reprojecting on `path` (`visibility`: the rt path's check), the scene updated in place
/// between frames ([`AnimatedFrames`], [`Sequence::update_scene`]); with `reference` each frame
/// is compared with its full render. `anchors` off leaves the samples at their world
/// positions (reprojection without anchors).
fn run(
    ctx: &Context,
    rel: &str,
    (path, visibility): (RenderPath, PrimaryRayCheck),
    frames: u32,
    anchors: bool,
    reference: bool,
) -> Vec<Frame> {
    let (rest, anims) = load(rel);
    let cam = camera(&rest);
    let backend = BackendChoice::Auto.resolve(ctx.info()).unwrap().0;
    let mut anim = AnimatedFrames::new(ctx, &rest, &anims, 0.0, backend, BvhBuild::Gpu).unwrap();
    let settings = RenderSettings {
        width: SIZE,
        height: SIZE,
        ..Default::default()
    };
    let options = SequenceOptions {
        path,
        reuse: ReuseOptions {
            reproject: true,
            rt_visibility: visibility,
            ..Default::default()
        },
        reference,
    };
    let first = rest.posed(&anims, 0.0);
    let mut seq = Sequence::new(
        ctx,
        anim.renderer(),
        &first,
        &settings,
        cam,
        CameraPath::Static,
        options,
    )
    .unwrap();
    if anchors {
        seq.track_moving_geometry(ctx).unwrap();
    }
    let mut out = Vec::new();
    for k in 0..frames {
        if k > 0 {
            let (posed, _) = anim.update(ctx, k as f32 / FPS).unwrap();
            seq.update_scene(ctx, anim.renderer(), &posed, cam).unwrap();
        }
        let f: SequenceFrame = seq.render_frame(ctx, k).unwrap();
        assert_eq!(f.reused_history, k > 0, "{rel}: frame {k} reuses the last");
        let frame = Frame {
            rays: f.output.rays.total(),
            reused: f.stats.reused,
            rejected: f.stats.rejected,
            expired: f.stats.expired,
            reference: f
                .reference
                .as_ref()
                .map(|r| (r.ray_fraction, r.diff.flip_mean)),
        };
        eprintln!(
            "{rel} {path:?} {visibility:?} anchors {anchors} frame {k}: rays {} reused {} rejected {} (ray fraction, FLIP) {:?}",
            frame.rays, frame.reused, frame.rejected, frame.reference
        );
        out.push(frame);
    }
    out
}

/// Sum of `f` over the frames after the first (a full render).
fn reusing_sum(frames: &[Frame], f: impl Fn(&Frame) -> u64) -> u64 {
    frames.iter().skip(1).map(f).sum()
}

/// Checks every frame against its full render: mean FLIP within the bound, and rays
/// at most `max_ray_fraction` of the full render's on average over the reusing frames.
fn assert_close_to_full_renders(what: &str, frames: &[Frame], max_ray_fraction: f64) {
    let mut fractions = Vec::new();
    for (k, f) in frames.iter().enumerate() {
        let (fraction, flip) = f.reference.expect("rendered with references");
        assert!(
            flip <= 0.05,
            "{what} frame {k}: mean FLIP {flip} against the full render (bound 0.05)"
        );
        if k > 0 {
            fractions.push(fraction);
        }
    }
    let mean = fractions.iter().sum::<f64>() / fractions.len() as f64;
    assert!(
        mean <= max_ray_fraction,
        "{what}: {mean:.3} of the full renders' rays (bound {max_ray_fraction})"
    );
}

/// Hybrid path on a skinned figure (CesiumMan walks): frames stay within the FLIP bound of
/// full renders at under 0.4 of their rays, and the samples on the figure follow it (and are
/// re-traced after MOVED_MAX_AGE frames). With
/// world-space positions (anchors off) the G-buffer test rejects the figure's samples
/// wherever a limb moved, and those pixels are traced again.
#[test]
fn hybrid_reprojection_follows_a_skinned_figure() {
    let ctx = support::gpu();
    let rel = "CesiumMan/CesiumMan.glb";
    let mode = (RenderPath::Hybrid, PrimaryRayCheck::Edges);
    let tracked = run(&ctx, rel, mode, 60, true, true);
    assert_close_to_full_renders("CesiumMan hybrid", &tracked, 0.4);
    let world = run(&ctx, rel, mode, 12, false, false);
    let tracked = &tracked[..world.len()];
    let (rays, rays_world) = (
        reusing_sum(tracked, |f| f.rays),
        reusing_sum(&world, |f| f.rays),
    );
    let (rejected, rejected_world) = (
        reusing_sum(tracked, |f| f.rejected),
        reusing_sum(&world, |f| f.rejected),
    );
    eprintln!("rays {rays} vs {rays_world} world-space; rejected {rejected} vs {rejected_world}");
    // Rejections fall by more than half; rays fall less, because a sample that moved with
    // the figure is re-traced anyway once it is MOVED_MAX_AGE frames old (its shading belongs
    // to where the figure was).
    assert!(
        rays < rays_world && 2 * rejected < rejected_world,
        "samples that follow the figure save rays: {rays} rays, {rejected} rejected; world-space samples: {rays_world} rays, {rejected_world} rejected"
    );
    assert!(reusing_sum(tracked, |f| f.reused) > reusing_sum(&world, |f| f.reused));
    // No --max-age here: only samples that moved with the figure expire.
    assert!(
        reusing_sum(tracked, |f| f.expired) > 0,
        "samples that moved with the figure are re-traced after MOVED_MAX_AGE frames"
    );
    support::assert_validation_clean(&ctx);
}

/// Pure ray-traced path on node animation (BoxAnimated) and the skinned figure: with every
/// sample checked by a primary ray (`--rt-visibility full`), moved samples pass the rejection
/// tests where world-space ones fail them; with the default edge test, frames stay within the
/// FLIP bound of full renders.
#[test]
fn rt_reprojection_follows_moving_objects() {
    let ctx = support::gpu();
    let full = (RenderPath::RayTraced, PrimaryRayCheck::Full);
    for rel in ["BoxAnimated/BoxAnimated.glb", "CesiumMan/CesiumMan.glb"] {
        let tracked = run(&ctx, rel, full, 10, true, false);
        let world = run(&ctx, rel, full, 10, false, false);
        let (rejected, rejected_world) = (
            reusing_sum(&tracked, |f| f.rejected),
            reusing_sum(&world, |f| f.rejected),
        );
        assert!(
            2 * rejected < rejected_world,
            "{rel}: moved samples rejected {rejected} times, world-space samples {rejected_world}"
        );
    }
    let edges = (RenderPath::RayTraced, PrimaryRayCheck::Edges);
    let frames = run(&ctx, "CesiumMan/CesiumMan.glb", edges, 16, true, true);
    assert_close_to_full_renders("CesiumMan rt", &frames, 1.0);
    support::assert_validation_clean(&ctx);
}
