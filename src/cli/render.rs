//! `rqr render`: one image of a scene with the pure ray-traced or the hybrid path, or a
//! sequence of frames along a camera path with reuse between frames (`--frames`,
//! `--reproject`, `--frameless`, `--adaptive-subsample`).

use std::ops::Range;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context as _, Result};
use clap::Args;
use rqr::render::drivers::animated::{AnimatedFrames, AnimationUpdate};
use rqr::render::drivers::sequence::SequenceFrame;
use rqr::render::drivers::sequence::{
    self, CameraAnimation, CameraPath, CameraPathSpec, FrameSummary, Sequence, SequenceOptions,
    SequenceSummary,
};
use rqr::render::image::output;
use rqr::render::passes::draw_list;
use rqr::render::readback::RingContents;
use rqr::render::temporal::{
    PixelSource, PrimaryRayCheck, ReuseOptions, DEFAULT_SUBSAMPLE_THRESHOLD,
};
use rqr::render::RenderPath;
use rqr::render::{PassScope, RenderOutput, RenderSettings, Renderer};
use serde_json::json;

use super::common::{check_output_file, CameraArgs, DeviceArgs, ImageArgs, SceneArgs};
use super::{out, outln, usage};

/// `rqr render` arguments.
#[derive(Args, Debug)]
pub struct RenderArgs {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    device: DeviceArgs,
    #[command(flatten)]
    camera: CameraArgs,
    #[command(flatten)]
    image: ImageArgs,
    /// Rendering path.
    #[arg(long, value_enum, default_value_t = RenderPath::RayTraced)]
    mode: RenderPath,
    /// Output: .png (tonemapped sRGB), .exr (linear HDR) or .pfm (linear HDR, the portable
    /// float map that Intel Open Image Denoise's `oidnDenoise` reads).
    #[arg(short, long, default_value = "out.png")]
    output: PathBuf,
    /// Also write 32-bit float AOVs next to the output (comma-separated): depth, normal
    /// (shading), geometric_normal, albedo, instance, primitive, barycentrics, position. They
    /// are `.pfm` when the output is, else `.exr`.
    #[arg(long, value_delimiter = ',')]
    aov: Vec<String>,
    /// Print a JSON summary (device, backend, per-pass GPU ms, rays by kind, Mrays/s); for a
    /// sequence, one JSON object per line per frame, then a summary line.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    sequence: SequenceArgs,
}

/// Sequence flags of `rqr render`.
#[derive(Args, Debug)]
pub struct SequenceArgs {
    /// Render N frames (0..N) along --camera-path; `-o out.png` writes out_0000.png, ….
    #[arg(long)]
    frames: Option<u32>,
    /// Render only frames A..B (B excluded) of the sequence. Numbering stays global; the
    /// sample cache starts empty at A, so a range never depends on frames before it.
    #[arg(long, value_parser = parse_range)]
    frame_range: Option<Range<u32>>,
    /// Camera path: orbit:DEG_PER_FRAME (about world +Y through --look-at, else the scene
    /// bounds' centre), dolly:DIST_PER_FRAME (along the view direction), gltf (the file's
    /// animation of the chosen camera's node), static.
    #[arg(long, default_value = "static")]
    camera_path: CameraPathSpec,
    /// Frames per second of --camera-path gltf: frame k samples the animation at k/fps s.
    #[arg(long, default_value_t = 24.0)]
    fps: f32,
    /// How the frames of an animated sequence are updated: refit (GPU skinning into the
    /// scene's vertex buffers, refit of the deformed geometry's BLASes, TLAS built again;
    /// static geometry is never rebuilt) or rebuild (upload the posed scene and build every
    /// acceleration structure again per frame, for comparisons). Frames' `gpu_ms` list the
    /// update's passes (skin, blas refit / blas build, tlas build).
    #[arg(long, value_enum, default_value = "refit")]
    animation_update: AnimationUpdate,
    /// Reproject the previous frame's samples; trace only disoccluded, rejected,
    /// view-dependent (mirror, metal, glass) and expired pixels.
    #[arg(long)]
    reproject: bool,
    /// Frameless rendering: re-trace at least P % of the pixels per frame, sweeping over the
    /// image in a fixed stratified order (implies --reproject).
    #[arg(long, value_name = "P")]
    frameless: Option<f32>,
    /// Adaptive sub-sampling of the pixels that need new colour: trace 4x4 blocks' corners
    /// and centre, interpolate similar blocks, recurse into 2x2 blocks, trace the rest.
    #[arg(long)]
    adaptive_subsample: bool,
    /// Adaptive sub-sampling: interpolate a block when its samples differ by at most this
    /// (largest channel difference of the colours as displayed: x/(1+x), then a square root).
    #[arg(long, default_value_t = DEFAULT_SUBSAMPLE_THRESHOLD)]
    subsample_threshold: f32,
    /// Re-trace samples older than K frames (default: no limit).
    #[arg(long, value_name = "K")]
    max_age: Option<u32>,
    /// rt path: which reprojected samples get a primary ray to check visibility. `edges`:
    /// only those next to a depth edge or a hole; `full`: all of them.
    #[arg(long, value_enum, default_value_t = PrimaryRayCheck::Edges)]
    rt_visibility: PrimaryRayCheck,
    /// Also render every frame in full; report rays relative to it, FLIP and PSNR.
    #[arg(long)]
    reference: bool,
    /// Write the sequence report: .json (summary and frames) or .md (table).
    #[arg(long)]
    report: Option<PathBuf>,
    /// Write a PNG chart of rays per frame and FLIP over the sequence.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Also write out_NNNN.sources.png per frame: reused pixels grey, traced red,
    /// interpolated green.
    #[arg(long)]
    sources: bool,
    /// Time the sequence the way a GPU runs it: warm up until two consecutive bursts agree
    /// within 3 %, then record up to --burst frames back to back per submission, with no
    /// readback, file writing or FLIP between them (images, statistics and FLIP are produced
    /// after each burst). Images are identical to a run without --benchmark.
    #[arg(long)]
    benchmark: bool,
    /// Frames per submission with --benchmark (fewer when their readback slots would exceed
    /// 1 GiB).
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(1..=4096))]
    burst: u32,
}

impl SequenceArgs {
    fn active(&self) -> bool {
        self.frames.is_some()
            || self.frame_range.is_some()
            || self.reproject
            || self.frameless.is_some()
            || self.adaptive_subsample
            || self.reference
            || self.report.is_some()
            || self.plot.is_some()
            || self.benchmark
            || self.camera_path != CameraPathSpec::Static
    }

    fn range(&self) -> Result<Range<u32>> {
        match (self.frames, &self.frame_range) {
            (Some(0), _) => usage!("--frames", "--frames must be at least 1"),
            (Some(n), Some(r)) if r.end > n => {
                usage!(
                    "--frame-range",
                    "--frame-range {}..{} goes past --frames {n}",
                    r.start,
                    r.end
                )
            }
            (_, Some(r)) => Ok(r.clone()),
            (Some(n), None) => Ok(0..n),
            (None, None) => usage!(
                "--frames",
                "a sequence needs --frames N or --frame-range A..B"
            ),
        }
    }

    fn reuse(&self) -> ReuseOptions {
        ReuseOptions {
            reproject: self.reproject || self.frameless.is_some(),
            frameless_percent: self.frameless,
            adaptive_subsample: self.adaptive_subsample,
            subsample_threshold: self.subsample_threshold,
            max_age: self.max_age,
            rt_visibility: self.rt_visibility,
            linear_color: true,
            // Set once the scene is loaded (an animation that moves geometry).
            moving_geometry: false,
        }
    }
}

fn parse_range(s: &str) -> Result<Range<u32>, String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("expected A..B, got '{s}'"))?;
    let a: u32 = a.trim().parse().map_err(|e| format!("'{a}': {e}"))?;
    let b: u32 = b.trim().parse().map_err(|e| format!("'{b}': {e}"))?;
    if b <= a {
        return Err(format!("empty frame range {a}..{b} (the end is excluded)"));
    }
    Ok(a..b)
}

/// `out.png` → `out_0007.png`.
pub fn frame_path(output: &Path, frame: u32) -> PathBuf {
    let stem = output
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let ext = output
        .extension()
        .map(|e| e.to_string_lossy().into_owned())
        .unwrap_or_else(|| "png".into());
    output.with_file_name(format!("{stem}_{frame:04}.{ext}"))
}

/// Mrays/s over the ray-tracing passes of a frame.
pub fn mrays_per_s(out: &RenderOutput) -> f64 {
    let ms: f64 = out
        .gpu_ms
        .iter()
        .filter(|(name, _)| name != PassScope::Tonemap.name() && name != PassScope::Gbuffer.name())
        .map(|p| p.1)
        .sum();
    if ms > 0.0 {
        out.rays.total() as f64 / ms / 1e3
    } else {
        0.0
    }
}

/// Runs `rqr render`.
pub fn run(args: &RenderArgs) -> Result<()> {
    let mut settings = args.image.settings()?;
    for name in &args.aov {
        if !output::AOV_NAMES.contains(&name.as_str()) {
            usage!(
                "--aov",
                "--aov: unknown AOV '{name}' (known: {})",
                output::AOV_NAMES.join(", ")
            );
        }
    }
    let ext = args
        .output
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_lowercase();
    if !["png", "exr", "pfm"].contains(&ext.as_str()) {
        usage!(
            "--output",
            "output '{}' must end in .png (tonemapped sRGB), .exr or .pfm (linear HDR)",
            args.output.display()
        );
    }
    if args.sequence.active() {
        return run_sequence(args, &ext);
    }
    check_output_file(&args.output)?;
    let environment = args.image.load_environment()?;
    let mut scene = args.scene.load()?;
    let environment = args.image.light_scene(&mut scene, environment)?;
    args.image.apply_light_sizes(&mut scene);
    let camera = args
        .camera
        .resolve(&scene, settings.width as f32 / settings.height as f32)?;
    let ctx = args.device.open()?;
    let textures = args.scene.apply_texture_format(&ctx, &mut [&mut scene]);
    let (backend, reason) = args.device.backend(&ctx)?;
    log::info!("backend {} ({reason})", backend.as_str());
    let (raster, raster_reason) = args.image.raster(&ctx);
    if matches!(args.mode, RenderPath::Hybrid) {
        log::info!("visibility pass: {} ({raster_reason})", raster.as_str());
    }
    settings.raster = raster;
    let mut renderer = {
        let _spinner = super::progress::Spinner::start(super::progress::build_message(backend));
        Renderer::with_bvh_build(&ctx, &scene, backend, args.device.bvh_build(&ctx))?
    };
    let environment_ms = super::common::light_with(&ctx, &mut renderer, environment.as_ref())?;
    let write_aov = !args.aov.is_empty();
    let out = match args.mode {
        RenderPath::RayTraced => renderer.render_rt(&ctx, &settings, &camera, write_aov)?,
        RenderPath::Hybrid => renderer.render_hybrid(
            &ctx,
            &draw_list::draws(&scene),
            &settings,
            &camera,
            write_aov,
        )?,
    };
    match ext.as_str() {
        "exr" => output::write_exr(&args.output, &out)?,
        "pfm" => output::write_color_pfm(&args.output, &out)?,
        _ => output::write_png(&args.output, &out)?,
    }
    let aov_format = if ext == "pfm" {
        output::FloatFormat::Pfm
    } else {
        output::FloatFormat::Exr
    };
    let aovs = output::write_aovs(&args.output, &out, &args.aov, aov_format)?;
    if args.json {
        let summary = json!({
            "device": ctx.info().name,
            "backend": backend.as_str(),
            "backend_reason": reason,
            "mode": args.mode,
            "scene": args.scene.name(),
            "width": settings.width,
            "height": settings.height,
            "spp": settings.spp,
            "sampler": settings.sampler,
            "mean_spp": out.mean_spp(),
            "max_depth": settings.max_depth,
            "gbuffer": matches!(args.mode, RenderPath::Hybrid).then_some(settings.gbuffer),
            "raster": matches!(args.mode, RenderPath::Hybrid).then_some(settings.raster),
            "raster_reason": matches!(args.mode, RenderPath::Hybrid).then_some(raster_reason),
            "texture_format": textures.as_ref().map(|t| t.0),
            "texture_format_reason": textures.map(|t| t.1),
            "gpu_ms": out.gpu_ms.iter().map(|(k, v)| (k.clone(), json!(v))).collect::<serde_json::Map<_, _>>(),
            "total_gpu_ms": out.total_ms(),
            "rays": out.rays,
            "rays_total": out.rays.total(),
            "mrays_per_s": mrays_per_s(&out),
            "acceleration": renderer.backend.stats_json(),
            "environment_prepare": environment_ms,
            "output": args.output,
            "aovs": aovs,
        });
        outln!("{}", serde_json::to_string_pretty(&summary)?)?;
    } else {
        outln!(
            "{} {}x{} {} spp ({}, {}): {:.1} ms GPU, {} rays ({:.2} Mrays/s) -> {}",
            args.scene.name(),
            settings.width,
            settings.height,
            settings.spp,
            args.mode.label(),
            backend.as_str(),
            out.total_ms(),
            out.rays.total(),
            mrays_per_s(&out),
            args.output.display()
        )?;
        for p in &aovs {
            outln!("  AOV {}", p.display())?;
        }
    }
    super::common::check_validation(&ctx)
}

fn run_sequence(args: &RenderArgs, ext: &str) -> Result<()> {
    let seq = &args.sequence;
    let settings = args.image.settings()?;
    let range = seq.range()?;
    let mut reuse = seq.reuse();
    // Only float (EXR, PFM) frames read the linear colour.
    reuse.linear_color = ext != "png";
    reuse.validate()?;
    if !args.aov.is_empty() {
        usage!(
            "--aov",
            "--aov is for single images; sequences write colour only"
        );
    }
    if reuse.any() {
        rqr::render::temporal::check_sampling(&settings)?;
    }
    for p in [&seq.report, &seq.plot].into_iter().flatten() {
        check_output_file(p)?;
    }
    if let Some(p) = &seq.report {
        let e = p.extension().and_then(|e| e.to_str()).unwrap_or("");
        if e != "json" && e != "md" {
            usage!(
                "--report",
                "--report '{}' must end in .json or .md",
                p.display()
            );
        }
    }
    check_output_file(&frame_path(&args.output, range.start))?;
    let environment = args.image.load_environment()?;
    let (mut rest, animations) = args.scene.load_rest()?;
    let environment = args.image.light_scene(&mut rest, environment)?;
    args.image.apply_light_sizes(&mut rest);
    // A skinned or morphed scene is posed even without animation (the bind pose is not the
    // rest pose); it changes between frames only when an animation moves more than cameras.
    let deformable = rest.is_animated();
    let animated = deformable && rest.animation_moves_geometry(&animations);
    if animated {
        check_animated_sequence(args, &reuse)?;
        // Samples on moving geometry move with their objects: the anchors are checked with
        // the sample cache before anything is allocated.
        reuse.moving_geometry = true;
    }
    // Frame k of an animated scene shows it at k / --fps seconds.
    let pose_at = |k: u32| match deformable {
        true => rest.posed(&animations, k as f32 / seq.fps),
        false => rest.clone(),
    };
    let mut scene = pose_at(range.start);
    let aspect = settings.width as f32 / settings.height as f32;
    let base = args.camera.resolve(&scene, aspect)?;
    let path = match seq.camera_path {
        CameraPathSpec::Static => CameraPath::Static,
        CameraPathSpec::Orbit(d) => CameraPath::Orbit {
            degrees_per_frame: d,
            pivot: args.camera.look_at.unwrap_or(scene.bounds.center()),
        },
        CameraPathSpec::Dolly(d) => CameraPath::Dolly {
            distance_per_frame: d,
        },
        CameraPathSpec::Gltf => {
            let Some(file) = &args.scene.scene else {
                usage!(
                    "--camera-path",
                    "--camera-path gltf: the built-in scene has no camera animation"
                );
            };
            if args.camera.look_from.is_some() || args.camera.look_at.is_some() {
                usage!(
                    "--camera-path",
                    "--camera-path gltf takes the camera from the file: drop --look-from/--look-at"
                );
            }
            if scene.cameras.is_empty() {
                usage!(
                    "--camera-path",
                    "--camera-path gltf: scene has no camera animation (it has no camera)"
                );
            }
            CameraPath::Animation(Box::new(CameraAnimation::load(
                file,
                args.scene.scene_index,
                args.camera.camera.unwrap_or(0),
                seq.fps,
            )?))
        }
    };
    let ctx = args.device.open()?;
    // The animated renderer uploads the rest pose's textures, the others the posed scene's.
    args.scene
        .apply_texture_format(&ctx, &mut [&mut rest, &mut scene]);
    let (backend, reason) = args.device.backend(&ctx)?;
    log::info!("backend {} ({reason})", backend.as_str());
    // An animated scene keeps one renderer whose vertices and acceleration structures are
    // updated per frame; any other sequence renders every frame from one upload.
    let bvh_build = args.device.bvh_build(&ctx);
    let (renderer, animated_frames) = {
        let _spinner = super::progress::Spinner::start(super::progress::build_message(backend));
        match animated {
            true => (
                None,
                Some(AnimatedFrames::new(
                    &ctx,
                    &rest,
                    &animations,
                    range.start as f32 / seq.fps,
                    backend,
                    bvh_build,
                )?),
            ),
            false => (
                Some(Renderer::with_bvh_build(&ctx, &scene, backend, bvh_build)?),
                None,
            ),
        }
    };
    let prepared = match &environment {
        Some(map) => Some(super::common::prepare_environment(&ctx, map)?),
        None => None,
    };
    let (mut renderer, mut animated_frames) = (renderer, animated_frames);
    if let Some(r) = renderer.as_mut() {
        r.set_environment(&ctx, prepared)?;
    } else if let Some(a) = animated_frames.as_mut() {
        a.set_environment(&ctx, prepared)?;
    }
    let render_path = args.mode;
    let options = SequenceOptions {
        path: render_path,
        reuse,
        reference: seq.reference,
    };
    // One sequence for every frame, so that reuse keeps its sample cache across an animated
    // scene's updates (which happen in place in the animated renderer).
    let mut sequence = Sequence::new(
        &ctx,
        match (&renderer, &animated_frames) {
            (Some(renderer), _) => renderer,
            (None, Some(anim)) => anim.renderer(),
            (None, None) => bail!("internal error: a sequence without a renderer"),
        },
        &scene,
        &settings,
        base,
        path.clone(),
        options,
    )?;
    let bar = indicatif::ProgressBar::new(u64::from(range.end - range.start));
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} frames {elapsed} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    // Frames per submission: one (and every frame read back before the next) without
    // --benchmark; bursts after a warm-up with it (refused for animated scenes).
    let (burst, warm_up) = match (animated, seq.benchmark) {
        (false, true) => {
            let contents = RingContents {
                rgba8: true,
                color: ext != "png",
                aov: false,
                states: seq.sources,
            };
            let burst = sequence.prepare_bursts(&ctx, seq.burst, contents, 1 << 30)?;
            bar.set_message("warming up");
            let warm = sequence.warm_up(&ctx, range.start, burst.min(4))?;
            if !warm.settled {
                log::warn!(
                    "GPU times did not settle within {} warm-up bursts ({:?} ms per frame)",
                    warm.bursts,
                    warm.burst_mean_ms
                );
            }
            (burst, Some(warm))
        }
        _ => (1, None),
    };
    let mut summaries: Vec<FrameSummary> = Vec::new();
    let mut start = range.start;
    while start < range.end {
        let end = range.end.min(start.saturating_add(burst));
        let frames = match &mut animated_frames {
            Some(anim) => {
                // Frame k shows the animation at k / --fps s; the first frame is the pose
                // the renderer was built with. The update happens in place, so the sequence
                // (and its sample cache) carries on with the updated scene.
                let mut update_ms = Vec::new();
                if start != range.start {
                    let (posed, ms) =
                        anim.update_with(&ctx, start as f32 / seq.fps, seq.animation_update)?;
                    let base = match posed.cameras.is_empty() {
                        true => base,
                        false => args.camera.resolve(&posed, aspect)?,
                    };
                    sequence.update_scene(&ctx, anim.renderer(), &posed, base)?;
                    update_ms = ms;
                }
                let mut frames = sequence.render_burst(&ctx, start..end)?;
                for frame in &mut frames {
                    frame.frame_gpu_ms += update_ms.iter().map(|p| p.1).sum::<f64>();
                    frame.output.gpu_ms.splice(0..0, update_ms.iter().cloned());
                }
                frames
            }
            None => sequence.render_burst(&ctx, start..end)?,
        };
        start = end;
        for frame in frames {
            let summary = write_frame(args, ext, &settings, &frame, &bar)?;
            summaries.push(summary);
        }
    }
    bar.finish_and_clear();
    let total = SequenceSummary::new(&summaries);
    let header = json!({
        "device": ctx.info().name,
        "backend": backend.as_str(),
        "mode": args.mode,
        "scene": args.scene.name(),
        "width": settings.width,
        "height": settings.height,
        "frames": [range.start, range.end],
        "camera_path": seq.camera_path.to_string(),
        "reuse": reuse,
        "timing": match &warm_up {
            Some(w) => json!({
                "method": "burst",
                "description": format!("GPU timestamps per frame; up to {burst} frames (with --reference each followed by its full render) recorded back to back per submission, no host work between them; warm-up bursts of {} frames until two consecutive ones agreed within 3 %", w.frames_per_burst),
                "burst_frames": burst,
                "warm_up": w,
            }),
            None => json!({
                "method": "per-frame",
                "description": "GPU timestamps per frame; every frame is its own submission, read back (and its files written) before the next, so the GPU may idle and drop its clock between frames: use --benchmark for burst timing",
            }),
        },
    });
    if args.json {
        outln!(
            "{}",
            json!({"type": "summary", "run": header, "summary": total})
        )?;
    } else {
        out!("{}", markdown_report(&header, &summaries, &total))?;
    }
    if let Some(p) = &seq.report {
        if p.extension().and_then(|e| e.to_str()) == Some("json") {
            let report = json!({"run": header, "summary": total, "frames": summaries});
            std::fs::write(p, serde_json::to_string_pretty(&report)?)
                .with_context(|| format!("cannot write '{}'", p.display()))?;
        } else {
            std::fs::write(p, markdown_report(&header, &summaries, &total))
                .with_context(|| format!("cannot write '{}'", p.display()))?;
        }
    }
    if let Some(p) = &seq.plot {
        let title = format!(
            "{} {}x{} {} {}",
            args.scene.name(),
            settings.width,
            settings.height,
            args.mode.as_str(),
            seq.camera_path
        );
        let chart = sequence::plot(&summaries, &title);
        image::save_buffer(
            p,
            &chart.rgb,
            chart.width,
            chart.height,
            image::ColorType::Rgb8,
        )
        .with_context(|| format!("cannot write '{}'", p.display()))?;
    }
    super::common::check_validation(&ctx)
}

/// Refuses what animated sequences do not support: reuse between frames with
/// `--animation-update rebuild` (which replaces the renderer the sample cache is bound to)
/// and burst timing (each frame's scene update is its own submission between frames).
fn check_animated_sequence(args: &RenderArgs, reuse: &ReuseOptions) -> Result<()> {
    let seq = &args.sequence;
    if reuse.any() && seq.animation_update == AnimationUpdate::Rebuild {
        usage!("--animation-update", "--reproject, --frameless and --adaptive-subsample keep their sample cache bound to one renderer updated in place, which --animation-update rebuild replaces every frame: use --animation-update refit");
    }
    if seq.benchmark {
        usage!("--benchmark", "--benchmark does not support animated scenes: it records frames back to back in one submission, but every animated frame updates its scene (skinning, acceleration structures) in a submission of its own before it is rendered; time them without --benchmark (per-frame GPU timestamps)");
    }
    if args.scene.time.is_some() {
        usage!("--time", "--time is for single images: frame k of a sequence shows the animation at k/--fps seconds");
    }
    if !(seq.fps.is_finite() && seq.fps > 0.0) {
        usage!("--fps", "--fps {} must be a positive number", seq.fps);
    }
    Ok(())
}

/// Writes a frame's image (and sources map), prints its JSON line and returns its summary.
fn write_frame(
    args: &RenderArgs,
    ext: &str,
    settings: &RenderSettings,
    frame: &SequenceFrame,
    bar: &indicatif::ProgressBar,
) -> Result<FrameSummary> {
    let seq = &args.sequence;
    let k = frame.index;
    let file = frame_path(&args.output, k);
    match ext {
        "exr" => output::write_exr(&file, &frame.output)?,
        "pfm" => output::write_color_pfm(&file, &frame.output)?,
        _ => output::write_png(&file, &frame.output)?,
    }
    if seq.sources {
        let rgb: Vec<u8> = frame
            .sources
            .iter()
            .flat_map(|s| match s {
                PixelSource::Reused => [96, 96, 96],
                PixelSource::Traced => [230, 40, 30],
                PixelSource::Interpolated => [40, 200, 60],
            })
            .collect();
        let path = file.with_extension("sources.png");
        image::save_buffer(
            &path,
            &rgb,
            settings.width,
            settings.height,
            image::ColorType::Rgb8,
        )
        .with_context(|| format!("cannot write '{}'", path.display()))?;
    }
    let summary = frame.summary();
    if args.json {
        let mut line = serde_json::to_value(&summary)?;
        if let Some(o) = line.as_object_mut() {
            o.insert("type".into(), json!("frame"));
            o.insert("output".into(), json!(file));
            o.insert(
                "gpu_ms".into(),
                json!(summary
                    .gpu_ms
                    .iter()
                    .map(|(k, v)| (k.clone(), json!(v)))
                    .collect::<serde_json::Map<_, _>>()),
            );
        }
        bar.suspend(|| outln!("{line}"))?;
    }
    bar.set_message(match &summary.reference {
        Some(r) => format!(
            "rays {:.1} % of full, FLIP {:.4}",
            r.ray_fraction * 100.0,
            r.flip_mean
        ),
        None => format!(
            "reused {:.1} %, traced {:.1} %",
            summary.reused_fraction * 100.0,
            summary.traced_fraction * 100.0
        ),
    });
    bar.inc(1);
    Ok(summary)
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map(|x| format!("{x:.digits$}"))
        .unwrap_or_else(|| "-".into())
}

/// The compare-style report of a sequence: one row per frame, then the means.
fn markdown_report(
    header: &serde_json::Value,
    frames: &[FrameSummary],
    total: &SequenceSummary,
) -> String {
    let mut md = format!("# rqr sequence\n\n`{header}`\n\n");
    md.push_str("| frame | rays | rays / full | reused | traced | interpolated | holes | rejected | view-dep. | verify rays | FLIP | PSNR dB | GPU ms |\n");
    md.push_str("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for f in frames {
        let r = f.reference.as_ref();
        md.push_str(&format!(
            "| {} | {} | {} | {:.1} % | {:.1} % | {:.1} % | {} | {} | {} | {} | {} | {} | {:.1} |\n",
            f.frame,
            f.rays_total,
            opt(r.map(|r| r.ray_fraction), 3),
            f.reused_fraction * 100.0,
            f.traced_fraction * 100.0,
            f.interpolated_fraction * 100.0,
            f.reuse.holes,
            f.reuse.rejected,
            f.reuse.view_dependent,
            f.reuse.verify_rays,
            opt(r.map(|r| f64::from(r.flip_mean)), 4),
            opt(r.map(|r| r.psnr_db).filter(|p| p.is_finite()), 1),
            f.total_gpu_ms,
        ));
    }
    md.push_str(&format!(
        "\n**{} frames**: mean rays {:.0} ({} of a full frame, max {}), reused {:.1} %, traced {:.1} %, interpolated {:.1} %, mean FLIP {} (max {}), mean PSNR {} dB, GPU {:.1} ms/frame (full {}).\n",
        total.frames,
        total.mean_rays,
        opt(total.mean_ray_fraction, 3),
        opt(total.max_ray_fraction, 3),
        total.mean_reused_fraction * 100.0,
        total.mean_traced_fraction * 100.0,
        total.mean_interpolated_fraction * 100.0,
        opt(total.mean_flip, 4),
        opt(total.max_flip, 4),
        opt(total.mean_psnr_db, 1),
        total.mean_gpu_ms,
        opt(total.mean_reference_gpu_ms, 1),
    ));
    md
}
