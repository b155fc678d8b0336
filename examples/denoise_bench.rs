//! The denoiser's benchmark (`scripts/bench-denoise.sh` runs it on the three scenes): against a
//! converged reference rendered in batches of 16 samples, at `--size`² and 1 spp per frame,
//! distributed shading, ray-traced path:
//!
//! - static camera, 30 frames: MSE of the denoised frame 30 (and of the temporal accumulation
//!   alone) against raw 16 spp;
//! - temporal stability: mean absolute difference of consecutive output frames (20..30),
//!   denoised against raw;
//! - camera motion: 60 frames of `orbit:0.5`, mean FLIP against per-frame references (every
//!   10th frame), denoised against raw;
//! - cost: the denoised 1-spp frame's GPU time over the raw one's at `--cost-size`², with a
//!   still and an orbiting camera (bursts after a warm-up), and the denoiser's passes apart;
//! - with `--ghosting` (an animated scene, static camera): mean FLIP, against per-frame
//!   references, of the pixels the moving object left 4 frames earlier, and the lag; and the
//!   FLIP between two independent halves of each reference on the same pixels, the floor
//!   below which a FLIP against that reference measures the reference's own noise.
//!
//! It writes the raw frame 30 with its albedo and normal guides, the reference and rqr's
//! outputs as PFM into `--out`, for `scripts/oidn_denoise.py` to run OIDN on the same frame,
//! and prints one JSON object.

use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result};
use clap::Parser;
use glam::{Mat4, Vec3, Vec4};
use rqr::accel::Backend;
use rqr::environment::GpuEnvironment;
use rqr::render::denoise::{self, DenoiseMode};
use rqr::render::drivers::animated::{AnimatedFrames, AnimationUpdate};
use rqr::render::drivers::sequence::{CameraPath, Sequence, SequenceFrame, SequenceOptions};
use rqr::render::image::{metrics, output, tonemap};
use rqr::render::readback::RingContents;
use rqr::render::{
    FrameTargets, RenderOutput, RenderPath, RenderSettings, Renderer, SamplerKind, Shading,
};
use rqr::scene::{Camera, Material, Scene};
use rqr::vk::{Context, ContextOptions};
use serde_json::json;

#[derive(Parser)]
struct Args {
    /// glTF scene (omitted: the built-in one).
    scene: Option<PathBuf>,
    /// Image side in pixels.
    #[arg(long, default_value_t = 128)]
    size: u32,
    /// Samples per pixel of the references.
    #[arg(long, default_value_t = 1024)]
    reference_spp: u32,
    /// Image side of the cost measurement.
    #[arg(long, default_value_t = 512)]
    cost_size: u32,
    /// Environment map lighting the scene.
    #[arg(long)]
    environment: Option<PathBuf>,
    /// Radius of every point and spot light.
    #[arg(long)]
    light_radius: Option<f32>,
    /// Add a rough metal sphere on the scene's floor (its bounds' bottom centre).
    #[arg(long)]
    add_rough_sphere: bool,
    /// Measure ghosting on the scene's first animation (static camera) instead of the rest;
    /// the scene stands on a floor added under its bounds, where a ghost would show.
    #[arg(long)]
    ghosting: bool,
    /// Folder for the PFM images.
    #[arg(long)]
    out: PathBuf,
    /// Folder that keeps the references between runs (keyed by scene, options, camera, size
    /// and samples; the ghosting run's by frame too), so that a run that changes only the
    /// denoiser renders none again. The key does not cover the shading code: empty the folder
    /// when that changes.
    #[arg(long)]
    reference_cache: Option<PathBuf>,
}

const STATIC_FRAMES: u32 = 30;
const ORBIT_FRAMES: u32 = 60;
const ORBIT_DEG: f32 = 0.5;
const GHOST_FRAMES: u32 = 24;
const GHOST_LAG: u32 = 4;
const MAX_LAG: u32 = 8;

fn main() -> Result<()> {
    env_logger::init();
    let args = Args::parse();
    std::fs::create_dir_all(&args.out)?;
    let ctx = Context::new(&ContextOptions::default())?;
    let mut scene = match &args.scene {
        Some(p) => rqr::scene::load(p, &Default::default())
            .with_context(|| format!("loading {}", p.display()))?,
        None => rqr::scene::load_default()?,
    };
    if let Some(r) = args.light_radius {
        for l in &mut scene.lights {
            l.size = r;
        }
    }
    if args.add_rough_sphere {
        add_rough_sphere(&mut scene);
    }
    let camera = scene
        .cameras
        .first()
        .copied()
        .unwrap_or_else(|| rqr::scene::auto_camera(&scene.bounds, 1.0));
    if args.ghosting {
        add_floor(&mut scene);
    }
    let environment = match &args.environment {
        Some(p) => Some(rqr::environment::map::load(p)?.0),
        None => None,
    };
    let settings = |denoise: DenoiseMode, spp: u32, side: u32| RenderSettings {
        width: side,
        height: side,
        spp,
        sampler: SamplerKind::Sobol,
        shading: Shading::Distributed,
        denoise,
        environment_background: true,
        ..Default::default()
    };
    if args.ghosting {
        let report = ghosting(&ctx, &args, &scene, camera, environment.as_ref(), &settings)?;
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    let mut renderer = Renderer::new(&ctx, &scene, Backend::Bvh)?;
    if let Some(map) = &environment {
        renderer.set_environment(&ctx, Some(GpuEnvironment::prepare(&ctx, map)?))?;
    }
    let side = args.size;
    let scene_key = format!(
        "{:?}|{:?}|{:?}|{}",
        args.scene, args.environment, args.light_radius, args.add_rough_sphere
    );
    let cache = args
        .reference_cache
        .as_deref()
        .map(|dir| (dir, scene_key.as_str()));

    // Static camera: the reference, raw 16 spp, and the denoised and raw sequences.
    let reference = render_reference(
        &ctx,
        &renderer,
        &settings(DenoiseMode::None, 1, side),
        &camera,
        args.reference_spp,
        cache,
    )?;
    let sixteen =
        renderer.render_rt(&ctx, &settings(DenoiseMode::None, 16, side), &camera, false)?;
    let denoised = sequence(
        &ctx,
        &renderer,
        &scene,
        &settings(DenoiseMode::Svgf, 1, side),
        camera,
        CameraPath::Static,
        STATIC_FRAMES,
    )?;
    let accumulated = sequence(
        &ctx,
        &renderer,
        &scene,
        &settings(DenoiseMode::Temporal, 1, side),
        camera,
        CameraPath::Static,
        STATIC_FRAMES,
    )?;
    let raw = sequence(
        &ctx,
        &renderer,
        &scene,
        &settings(DenoiseMode::None, 1, side),
        camera,
        CameraPath::Static,
        STATIC_FRAMES,
    )?;
    let last = (STATIC_FRAMES - 1) as usize;
    let stability = |frames: &[SequenceFrame]| -> f64 {
        let pairs = &frames[20..];
        pairs
            .windows(2)
            .map(|w| metrics::display_mean_abs_diff(&w[0].output.color, &w[1].output.color))
            .sum::<f64>()
            / (pairs.len() - 1) as f64
    };
    // The single-frame filter on the same frame (frame 30's samples, no history).
    let single = {
        let s = settings(DenoiseMode::Svgf, 1, side);
        let mut t = FrameTargets::new(&ctx, &renderer, RenderPath::RayTraced, &s, &[], true)?;
        render_numbered(&ctx, &mut t, &camera, last as u32)?
    };
    // Guides of frame 30 for OIDN: albedo and normal of the same samples.
    let guides = {
        let s = settings(DenoiseMode::None, 1, side);
        let mut t = FrameTargets::new(&ctx, &renderer, RenderPath::RayTraced, &s, &[], true)?;
        render_numbered(&ctx, &mut t, &camera, last as u32)?
    };
    write(&args.out, "reference", &reference)?;
    write(&args.out, "raw", &raw[last].output)?;
    write(&args.out, "raw16", &sixteen)?;
    write(&args.out, "denoised30", &denoised[last].output)?;
    write(&args.out, "denoised1", &single)?;
    for name in ["albedo", "normal"] {
        output::write_aov(
            &output::aov_path(&args.out.join("guide.pfm"), name, output::FloatFormat::Pfm),
            &guides,
            name,
            output::FloatFormat::Pfm,
        )?;
    }
    let static_report = json!({
        "mse_raw_1spp": metrics::display_mse(&raw[last].output.color, &reference.color),
        "mse_raw_16spp": metrics::display_mse(&sixteen.color, &reference.color),
        "mse_denoised_single_frame": metrics::display_mse(&single.color, &reference.color),
        "mse_denoised_frame_30": metrics::display_mse(&denoised[last].output.color, &reference.color),
        "mse_temporal_frame_30": metrics::display_mse(&accumulated[last].output.color, &reference.color),
        "stability_raw": stability(&raw),
        "stability_denoised": stability(&denoised),
    });

    // Camera motion: per-frame references every 10th frame.
    let orbit = CameraPath::Orbit {
        degrees_per_frame: ORBIT_DEG,
        pivot: 0.5 * (scene.bounds.min + scene.bounds.max),
    };
    let moving = sequence(
        &ctx,
        &renderer,
        &scene,
        &settings(DenoiseMode::Svgf, 1, side),
        camera,
        orbit.clone(),
        ORBIT_FRAMES,
    )?;
    let moving_raw = sequence(
        &ctx,
        &renderer,
        &scene,
        &settings(DenoiseMode::None, 1, side),
        camera,
        orbit.clone(),
        ORBIT_FRAMES,
    )?;
    let (mut flip_denoised, mut flip_raw, mut n) = (0.0, 0.0, 0.0);
    for k in (9..ORBIT_FRAMES).step_by(10) {
        let cam = orbit.camera(&camera, k);
        let r = render_reference(
            &ctx,
            &renderer,
            &settings(DenoiseMode::None, 1, side),
            &cam,
            args.reference_spp / 4,
            cache,
        )?;
        flip_denoised += f64::from(
            metrics::compare(side, side, &r.rgba8, &moving[k as usize].output.rgba8).flip_mean,
        );
        flip_raw += f64::from(
            metrics::compare(side, side, &r.rgba8, &moving_raw[k as usize].output.rgba8).flip_mean,
        );
        if k + 10 >= ORBIT_FRAMES {
            write(&args.out, "orbit-reference", &r)?;
            write(&args.out, "orbit-denoised", &moving[k as usize].output)?;
            write(&args.out, "orbit-raw", &moving_raw[k as usize].output)?;
        }
        n += 1.0;
    }
    let motion_report = json!({
        "flip_raw": flip_raw / n,
        "flip_denoised": flip_denoised / n,
        "reference_spp": args.reference_spp / 4,
        "frames_compared": n,
    });

    // Cost at --cost-size: bursts after a warm-up, denoised and not, still and orbiting. The
    // denoiser's cost is the denoised frame's GPU time over the raw one's (that includes the
    // pixel-centre ray the shading passes add for it), and its passes are listed apart.
    let timed = |mode: DenoiseMode, path: CameraPath| -> Result<(f64, f64, serde_json::Value)> {
        burst_cost(
            &ctx,
            &renderer,
            &scene,
            &settings(mode, 1, args.cost_size),
            camera,
            path,
        )
    };
    let (raw_ms, _, _) = timed(DenoiseMode::None, CameraPath::Static)?;
    let (still_ms, still_passes_ms, passes) = timed(DenoiseMode::Svgf, CameraPath::Static)?;
    let (raw_orbit_ms, _, _) = timed(DenoiseMode::None, orbit.clone())?;
    let (orbit_ms, orbit_passes_ms, _) = timed(DenoiseMode::Svgf, orbit.clone())?;
    let cost = json!({
        "size": args.cost_size,
        "raw_frame_ms": raw_ms,
        "denoised_frame_ms": still_ms,
        "denoise_passes_ms": still_passes_ms,
        "denoise_share_of_undenoised_frame": (still_ms - raw_ms) / raw_ms.max(1e-9),
        "orbit_raw_frame_ms": raw_orbit_ms,
        "orbit_denoised_frame_ms": orbit_ms,
        "orbit_denoise_passes_ms": orbit_passes_ms,
        "orbit_denoise_share_of_undenoised_frame": (orbit_ms - raw_orbit_ms) / raw_orbit_ms.max(1e-9),
        "passes": passes,
    });
    let report = json!({
        "device": ctx.info().name,
        "scene": args.scene.as_ref().map_or("built-in".into(), |p| p.display().to_string()),
        "size": side,
        "reference_spp": args.reference_spp,
        "static": static_report,
        "motion": motion_report,
        "cost": cost,
        "history_cap": denoise::DEFAULT_HISTORY_CAP,
    });
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}

/// A rough metal sphere (roughness 0.35) on the floor of the scene's bounds, a fifth of their
/// width across.
fn add_rough_sphere(scene: &mut Scene) {
    let b = scene.bounds;
    let size = b.max - b.min;
    let radius = 0.1 * size.x.min(size.z);
    let centre = Vec3::new(
        b.min.x + 0.3 * size.x,
        b.min.y + radius,
        b.min.z + 0.6 * size.z,
    );
    let metal = Material {
        name: "rough metal".into(),
        base_color: Vec4::new(0.9, 0.75, 0.55, 1.0),
        metallic: 1.0,
        roughness: 0.35,
        ..Default::default()
    };
    let transform = Mat4::from_translation(centre) * Mat4::from_scale(Vec3::splat(radius));
    scene.add_still_object(
        metal,
        |m| rqr::scene::procedural::sphere(m, 64, 32),
        transform,
    );
}

/// A grey Lambert floor under the scene's bounds, ten times their width.
fn add_floor(scene: &mut Scene) {
    let b = scene.bounds;
    let size = (b.max - b.min).max_element() * 10.0;
    let centre = 0.5 * (b.min + b.max);
    let floor = Material {
        name: "floor".into(),
        base_color: Vec4::new(0.6, 0.6, 0.6, 1.0),
        metallic: 0.0,
        roughness: 1.0,
        ..Default::default()
    };
    let transform = Mat4::from_translation(Vec3::new(centre.x, b.min.y, centre.z))
        * Mat4::from_scale(Vec3::new(size, 1.0, size));
    scene.add_still_object(floor, rqr::scene::procedural::quad, transform);
}

/// GPU ms per frame over the second burst of 8 frames of `path` (after a warm-up and a first
/// burst, so that still pixels have history), the denoiser passes' share of it, and the
/// passes of its first frame.
fn burst_cost(
    ctx: &Context,
    renderer: &Renderer,
    scene: &Scene,
    settings: &RenderSettings,
    camera: Camera,
    path: CameraPath,
) -> Result<(f64, f64, serde_json::Value)> {
    let mut seq = ray_traced_sequence(ctx, renderer, scene, settings, camera, path)?;
    let contents = RingContents {
        rgba8: true,
        color: false,
        aov: false,
        states: false,
    };
    let burst = seq.prepare_bursts(ctx, 8, contents, 1 << 30)?;
    seq.warm_up(ctx, 0, burst.min(4))?;
    seq.render_burst(ctx, 0..burst)?;
    let frames = seq.render_burst(ctx, burst..2 * burst)?;
    let (mut denoise_ms, mut frame_ms) = (0.0, 0.0);
    for f in &frames {
        frame_ms += f.frame_gpu_ms;
        denoise_ms += f
            .output
            .gpu_ms
            .iter()
            .filter(|(name, _)| name.starts_with("denoise "))
            .map(|p| p.1)
            .sum::<f64>();
    }
    let n = frames.len() as f64;
    Ok((frame_ms / n, denoise_ms / n, json!(frames[0].output.gpu_ms)))
}

/// A ray-traced sequence of `path` without temporal reuse.
fn ray_traced_sequence(
    ctx: &Context,
    renderer: &Renderer,
    scene: &Scene,
    settings: &RenderSettings,
    camera: Camera,
    path: CameraPath,
) -> Result<Sequence> {
    let options = SequenceOptions {
        path: RenderPath::RayTraced,
        reuse: Default::default(),
        reference: false,
    };
    Ok(Sequence::new(
        ctx, renderer, scene, settings, camera, path, options,
    )?)
}

/// Rec. 709 luminance of pixel `i` of 8-bit RGBA display values, in [0, 1].
fn display_luma(rgba8: &[u8], i: usize) -> f64 {
    let c = |k: usize| f64::from(rgba8[4 * i + k]) / 255.0;
    0.2126 * c(0) + 0.7152 * c(1) + 0.0722 * c(2)
}

/// `frames` frames of `path` (one by one).
fn sequence(
    ctx: &Context,
    renderer: &Renderer,
    scene: &Scene,
    settings: &RenderSettings,
    camera: Camera,
    path: CameraPath,
    frames: u32,
) -> Result<Vec<SequenceFrame>> {
    let mut seq = ray_traced_sequence(ctx, renderer, scene, settings, camera, path)?;
    (0..frames).map(|k| Ok(seq.render_frame(ctx, k)?)).collect()
}

/// Frame `k` of a sequence through `camera` in `targets` (its samples numbered k × spp on).
fn render_numbered(
    ctx: &Context,
    targets: &mut FrameTargets,
    camera: &Camera,
    k: u32,
) -> Result<RenderOutput> {
    let frame = targets.sequence_frame(camera, k);
    ctx.run("benchmark frame", |cmd| {
        targets.record(ctx, cmd, &frame, None, Some((targets.readback_ring(), 0)));
        Ok(())
    })?;
    Ok(targets.read()?)
}

/// The ray-traced image at `spp` samples, in batches of 16 with successive seeds, averaged
/// and tonemapped on the host.
fn render_reference(
    ctx: &Context,
    renderer: &Renderer,
    settings: &RenderSettings,
    camera: &Camera,
    spp: u32,
    cache: Option<(&Path, &str)>,
) -> Result<RenderOutput> {
    let color = cached_accumulation(ctx, renderer, settings, camera, spp, 1000, cache)?;
    Ok(linear_output(settings, color))
}

/// [`accumulate_reference`], kept in the folder of `cache` (with the scene's key) between runs.
fn cached_accumulation(
    ctx: &Context,
    renderer: &Renderer,
    settings: &RenderSettings,
    camera: &Camera,
    spp: u32,
    first_seed: u32,
    cache: Option<(&Path, &str)>,
) -> Result<Vec<[f32; 4]>> {
    let cached = cache.map(|(dir, scene_key)| {
        // FNV-1a of everything the image depends on: stable across runs and builds.
        // The first seed only where it is not the default, so that older caches still apply.
        let seed = if first_seed == 1000 {
            String::new()
        } else {
            format!("|seed {first_seed}")
        };
        let key = format!(
            "{scene_key}{seed}|{:?}|{}x{}|{spp}|{:?}",
            camera.camera_to_world.to_cols_array(),
            settings.width,
            settings.height,
            (
                camera.projection,
                settings.max_depth,
                settings.shading,
                settings.tonemap,
                settings.exposure
            )
        );
        let hash = key.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
            (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
        });
        dir.join(format!("{hash:016x}.f32"))
    });
    if let Some(bytes) = cached.as_deref().and_then(|f| std::fs::read(f).ok()) {
        if bytes.len() == settings.pixels() as usize * 16 {
            return Ok(bytes
                .chunks_exact(16)
                .map(|c| {
                    std::array::from_fn(|k| {
                        f32::from_le_bytes(c[4 * k..4 * k + 4].try_into().unwrap())
                    })
                })
                .collect());
        }
    }
    let color = accumulate_reference(ctx, renderer, settings, camera, spp, first_seed)?;
    if let Some(f) = &cached {
        std::fs::create_dir_all(f.parent().unwrap())?;
        let bytes: Vec<u8> = color
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        std::fs::write(f, bytes)?;
    }
    Ok(color)
}

/// An image of linear colours, tonemapped as `settings` say.
fn linear_output(settings: &RenderSettings, color: Vec<[f32; 4]>) -> RenderOutput {
    let rgba8 = color
        .iter()
        .flat_map(|c| {
            tonemap::tonemap_rgba8([c[0], c[1], c[2]], settings.tonemap, settings.exposure)
        })
        .collect();
    RenderOutput {
        width: settings.width,
        height: settings.height,
        color,
        rgba8,
        aov: Vec::new(),
        rays: Default::default(),
        samples: 0,
        gpu_ms: Vec::new(),
    }
}

/// A reference of `spp` samples rendered as two independent halves: the reference (their
/// mean) and the FLIP map between the halves. Each half has twice the variance of the
/// whole, so their difference has four times the reference's own error variance: a FLIP
/// against the reference that is not clearly above this floor measures the reference's noise.
fn reference_with_floor(
    ctx: &Context,
    renderer: &Renderer,
    settings: &RenderSettings,
    camera: &Camera,
    spp: u32,
    cache: Option<(&Path, &str)>,
) -> Result<(RenderOutput, Vec<f32>)> {
    let half = (spp / 2).max(1);
    let a = cached_accumulation(ctx, renderer, settings, camera, half, 1000, cache)?;
    let b = cached_accumulation(ctx, renderer, settings, camera, half, 1_000_000, cache)?;
    let mean: Vec<[f32; 4]> = a
        .iter()
        .zip(&b)
        .map(|(x, y)| std::array::from_fn(|k| 0.5 * (x[k] + y[k])))
        .collect();
    let (w, h) = (settings.width, settings.height);
    let floor = metrics::compare(
        w,
        h,
        &linear_output(settings, a).rgba8,
        &linear_output(settings, b).rgba8,
    )
    .error_map;
    Ok((linear_output(settings, mean), floor))
}

/// The linear colour of [`render_reference`], rendered.
fn accumulate_reference(
    ctx: &Context,
    renderer: &Renderer,
    settings: &RenderSettings,
    camera: &Camera,
    spp: u32,
    first_seed: u32,
) -> Result<Vec<[f32; 4]>> {
    let pixels = settings.pixels() as usize;
    let mut sum = vec![[0.0f64; 3]; pixels];
    let mut done = 0;
    let mut batch = 0;
    while done < spp {
        let n = 16.min(spp - done);
        let s = RenderSettings {
            spp: n,
            seed: first_seed + batch,
            ..settings.clone()
        };
        let out = renderer.render_rt(ctx, &s, camera, false)?;
        for (acc, c) in sum.iter_mut().zip(&out.color) {
            for k in 0..3 {
                acc[k] += f64::from(c[k]) * f64::from(n);
            }
        }
        done += n;
        batch += 1;
    }
    let color: Vec<[f32; 4]> = sum
        .iter()
        .map(|c| {
            [
                (c[0] / f64::from(spp)) as f32,
                (c[1] / f64::from(spp)) as f32,
                (c[2] / f64::from(spp)) as f32,
                1.0,
            ]
        })
        .collect();
    Ok(color)
}

fn write(dir: &Path, name: &str, out: &RenderOutput) -> Result<()> {
    output::write_color_pfm(&dir.join(format!("{name}.pfm")), out)?;
    output::write_png(&dir.join(format!("{name}.png")), out)?;
    Ok(())
}

/// Static camera on an animated scene: frame k shows the animation at k / 30 s. Pixels the
/// object covered GHOST_LAG frames earlier and no longer covers are compared with the
/// frame's reference. The lag, by frames since a pixel was uncovered (1..MAX_LAG): the mean
/// FLIP of such pixels, and the fraction whose history reaches back past their uncovering
/// (history kept from the figure: a ghost).
fn ghosting(
    ctx: &Context,
    args: &Args,
    rest: &Scene,
    camera: Camera,
    environment: Option<&rqr::environment::EnvironmentMap>,
    settings: &dyn Fn(DenoiseMode, u32, u32) -> RenderSettings,
) -> Result<serde_json::Value> {
    let side = args.size;
    let fps = 30.0;
    let animations = vec![0usize];
    let mut results = Vec::new();
    let mut references: Vec<Option<(RenderOutput, Vec<f32>)>> =
        (0..GHOST_FRAMES).map(|_| None).collect();
    for mode in [DenoiseMode::Svgf, DenoiseMode::None] {
        let mut anim = AnimatedFrames::new(
            ctx,
            rest,
            &animations,
            0.0,
            Backend::Bvh,
            rqr::accel::bvh::BvhBuild::Host,
        )?;
        if let Some(map) = environment {
            anim.set_environment(ctx, Some(GpuEnvironment::prepare(ctx, map)?))?;
        }
        let posed = rest.posed(&animations, 0.0);
        let s = settings(mode, 1, side);
        let mut seq = Sequence::new(
            ctx,
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
        )?;
        let mut covered: Vec<Vec<bool>> = Vec::new();
        let mut flips: Vec<(u32, f64, usize)> = Vec::new();
        // Per compared frame: the FLIP between the reference's two halves on the same pixels.
        let mut floors: Vec<f64> = Vec::new();
        // Per compared frame: the whole image's mean FLIP (what the rest of the frame pays).
        let mut whole: Vec<f64> = Vec::new();
        // Left pixels next to the figure's outline and away from it: FLIP sum, pixels.
        let mut outline = ((0.0f64, 0usize), (0.0f64, 0usize));
        // By frames since uncovered (1..=MAX_LAG): FLIP sum, pixels, pixels whose history
        // reaches back past their uncovering (a ghost of the figure), and the FLIP sum
        // between the reference's halves on the same pixels (its noise floor).
        let mut by_age = vec![(0.0f64, 0usize, 0usize, 0.0f64); MAX_LAG as usize + 1];
        // By frames since uncovered: the sum of the display luminance's error and of its
        // square (a history kept from the figure would show as a bias, noise and blur as
        // spread around none).
        let mut signed = vec![(0.0f64, 0.0f64); MAX_LAG as usize + 1];
        for k in 0..GHOST_FRAMES {
            if k > 0 {
                let (posed, _) = anim.update_with(ctx, k as f32 / fps, AnimationUpdate::Refit)?;
                seq.update_scene(ctx, anim.renderer(), &posed, camera)?;
            }
            let frame = seq.render_frame(ctx, k)?;
            let lengths = match seq.full_targets().denoiser() {
                Some(d) => Some(d.history_lengths(ctx)?),
                None => None,
            };
            // At pixel centres, where the denoiser tests its history.
            let centres = RenderSettings {
                sampler: SamplerKind::Center,
                ..settings(DenoiseMode::None, 1, side)
            };
            let mut t = FrameTargets::new(
                ctx,
                anim.renderer(),
                RenderPath::RayTraced,
                &centres,
                &[],
                true,
            )?;
            let mask_frame = t.render(ctx, &camera)?;
            // The figure: every instance but the floor (the last one).
            let floor = (rest.instances.len() - 1) as i32;
            covered.push(
                mask_frame
                    .aov
                    .iter()
                    .map(|a| a.hit() && a.instance() != floor)
                    .collect(),
            );
            if k < GHOST_LAG {
                continue;
            }
            // Both modes see the same poses and share the frame's reference; on disk, the
            // frame's number joins the key, since each frame's pose differs.
            let slot = &mut references[k as usize];
            if slot.is_none() {
                let frame_key = format!(
                    "{:?}|{:?}|ghosting frame {k} at {fps} fps",
                    args.scene, args.environment
                );
                *slot = Some(reference_with_floor(
                    ctx,
                    anim.renderer(),
                    &settings(DenoiseMode::None, 1, side),
                    &camera,
                    args.reference_spp / 4,
                    args.reference_cache
                        .as_deref()
                        .map(|d| (d, frame_key.as_str())),
                )?);
            }
            let (r, floor) = slot.as_ref().unwrap();
            let d = metrics::compare(side, side, &r.rgba8, &frame.output.rgba8);
            whole.push(f64::from(d.flip_mean));
            let now = &covered[k as usize];
            // Frames since each pixel was last covered (None: covered now, or never in view).
            let age = |i: usize| -> Option<u32> {
                (1..=k.min(MAX_LAG))
                    .find(|&j| covered[(k - j) as usize][i])
                    .filter(|_| !now[i])
            };
            let before = &covered[(k - GHOST_LAG) as usize];
            let left: Vec<usize> = (0..now.len()).filter(|&i| before[i] && !now[i]).collect();
            for i in 0..now.len() {
                if let Some(j) = age(i) {
                    let slot = &mut by_age[j as usize];
                    slot.0 += f64::from(d.error_map[i]);
                    slot.1 += 1;
                    slot.3 += f64::from(floor[i]);
                    let e = display_luma(&frame.output.rgba8, i) - display_luma(&r.rgba8, i);
                    signed[j as usize].0 += e;
                    signed[j as usize].1 += e * e;
                    if lengths.as_ref().is_some_and(|l| l[i] > j as f32) {
                        slot.2 += 1;
                    }
                }
            }
            if left.is_empty() {
                continue;
            }
            let mean_over_left = |map: &[f32]| {
                left.iter().map(|&i| f64::from(map[i])).sum::<f64>() / left.len() as f64
            };
            flips.push((k, mean_over_left(&d.error_map), left.len()));
            // The same away from the figure's outline: left pixels none of whose 8
            // neighbours it covers now. At the outline the reference is a mix of figure
            // and floor (its samples cover the whole pixel), which a history a few samples
            // long cannot match: that is anti-aliasing, not history kept from the figure.
            let w = side as usize;
            let near_outline = |i: usize| {
                let (x, y) = ((i % w) as i64, (i / w) as i64);
                (-1..=1).any(|dy| {
                    (-1..=1).any(|dx| {
                        let (qx, qy) = (x + dx, y + dy);
                        qx >= 0
                            && qy >= 0
                            && qx < w as i64
                            && qy < w as i64
                            && now[(qy * w as i64 + qx) as usize]
                    })
                })
            };
            for &i in &left {
                let slot = if near_outline(i) {
                    &mut outline.0
                } else {
                    &mut outline.1
                };
                slot.0 += f64::from(d.error_map[i]);
                slot.1 += 1;
            }
            if k == GHOST_FRAMES - 1 {
                let tag = mode.as_str();
                write(&args.out, &format!("ghosting-{tag}"), &frame.output)?;
                write(&args.out, "ghosting-reference", r)?;
                // The FLIP map, with the pixels compared in magenta.
                let mut marked = linear_output(
                    &settings(DenoiseMode::None, 1, side),
                    d.error_map.iter().map(|&e| [e, e, e, 1.0]).collect(),
                );
                for &i in &left {
                    marked.rgba8[4 * i..4 * i + 3].copy_from_slice(&[255, 0, 255]);
                }
                output::write_png(&args.out.join(format!("ghosting-{tag}-flip.png")), &marked)?;
            }
            floors.push(mean_over_left(floor));
        }
        let mean = flips.iter().map(|f| f.1).sum::<f64>() / flips.len().max(1) as f64;
        let ages: Vec<_> = (1..=MAX_LAG as usize)
            .filter(|&j| by_age[j].1 > 0)
            .map(|j| {
                let (f, n, stale, halves) = by_age[j];
                json!({ "frames_since_uncovered": j, "pixels": n, "mean_flip": f / n as f64,
                        "stale_history_fraction": stale as f64 / n as f64,
                        "reference_halves_flip": halves / n as f64,
                        "mean_luma_error": signed[j].0 / n as f64,
                        "rms_luma_error": (signed[j].1 / n as f64).sqrt() })
            })
            .collect();
        results.push(json!({
            "denoise": mode.as_str(),
            "mean_flip_left_pixels": mean,
            "mean_flip_whole_frame": whole.iter().sum::<f64>() / whole.len().max(1) as f64,
            "mean_flip_left_pixels_at_outline": outline.0.0 / outline.0.1.max(1) as f64,
            "left_pixels_at_outline": outline.0.1,
            "mean_flip_left_pixels_off_outline": outline.1.0 / outline.1.1.max(1) as f64,
            "left_pixels_off_outline": outline.1.1,
            "reference_halves_flip_left_pixels": floors.iter().sum::<f64>() / floors.len().max(1) as f64,
            "by_frames_since_uncovered": ages,
            "per_frame": flips,
        }));
    }
    Ok(
        json!({ "device": ctx.info().name, "size": side, "lag_frames_compared": GHOST_LAG, "results": results }),
    )
}
