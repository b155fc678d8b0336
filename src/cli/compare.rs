//! `rqr compare`: renders the pure ray-traced and the hybrid path (optionally with every
//! backend) and writes the images, a FLIP heat map, a labelled side-by-side and a report.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result};
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use rqr::accel::Backend;
use rqr::render::drivers::burst::{self, BurstReport};
use rqr::render::drivers::sequence::{pass_spreads, Spread};
use rqr::render::image::{label, metrics, output};
use rqr::render::passes::draw_list;
use rqr::render::{
    merge_scopes, FrameTargets, PassScope, RenderOutput, RenderPath, RenderSettings, Renderer,
};
use rqr::vk::FrameTiming;
use serde_json::json;

use super::common::{CameraArgs, DeviceArgs, ImageArgs, SceneArgs};
use super::render::mrays_per_s;
use super::{out, outln};

/// Which backends to run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum Backends {
    /// The one `--backend` resolves to.
    #[default]
    One,
    /// Every backend the device supports (hw and bvh where ray queries exist).
    All,
}

/// `rqr compare` arguments.
#[derive(Args, Debug)]
pub struct CompareArgs {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    device: DeviceArgs,
    #[command(flatten)]
    camera: CameraArgs,
    #[command(flatten)]
    image: ImageArgs,
    /// Output directory (created if missing).
    #[arg(short, long, default_value = "compare")]
    output: PathBuf,
    /// Backends to run.
    #[arg(long, value_enum, default_value_t = Backends::One)]
    backends: Backends,
    /// Timed frames per path (the report gives medians, min and max), recorded back to back
    /// after warm-up bursts that run until two consecutive ones agree within 3 %.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
    repeat: u32,
    /// Also render a converged reference (distributed shading, ray traced, N spp) and report
    /// the Whitted model and distributed shading at 1, 4 and 16 spp, on both paths, against it:
    /// FLIP and PSNR next to GPU ms (quality.md, quality.json, reference.png and the
    /// ray-traced images quality-*.png).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=4096))]
    reference_spp: Option<u32>,
}

/// Median, smallest and largest GPU ms per pass over the timed frames (pass order of the first
/// frame; scopes of one name within a frame, one per sample, summed), and of the whole frame.
struct PathTiming {
    passes: Vec<(String, Spread)>,
    frame: Spread,
}

impl PathTiming {
    fn new(frames: &[FrameTiming]) -> Self {
        let merged: Vec<Vec<(String, f64)>> = frames
            .iter()
            .map(|f| merge_scopes(f.passes.clone()))
            .collect();
        let passes = pass_spreads(merged.iter().map(Vec::as_slice))
            .into_iter()
            .map(|p| (p.name, p.ms))
            .collect();
        let totals: Vec<f64> = frames.iter().map(|f| f.total_ms).collect();
        Self {
            passes,
            frame: Spread::of(&totals),
        }
    }

    fn median(&self, pass: &str) -> Option<f64> {
        self.passes.iter().find(|p| p.0 == pass).map(|p| p.1.median)
    }
}

struct PathResult {
    timing: PathTiming,
    last: RenderOutput,
}

impl PathResult {
    fn total(&self) -> f64 {
        self.timing.frame.median
    }
    /// The last frame's counts with the median pass times (for Mrays/s).
    fn with_medians(&self) -> RenderOutput {
        RenderOutput {
            gpu_ms: self
                .timing
                .passes
                .iter()
                .map(|(n, s)| (n.clone(), s.median))
                .collect(),
            ..clone_stats(&self.last)
        }
    }
    fn json(&self) -> serde_json::Value {
        let t = &self.timing;
        let map = |f: fn(&Spread) -> f64| {
            t.passes
                .iter()
                .map(|(k, v)| (k.clone(), json!(f(v))))
                .collect::<serde_json::Map<_, _>>()
        };
        json!({
            "gpu_ms": map(|s| s.median),
            "gpu_ms_min": map(|s| s.min),
            "gpu_ms_max": map(|s| s.max),
            "total_ms": t.frame.median,
            "total_ms_min": t.frame.min,
            "total_ms_max": t.frame.max,
            "rays": self.last.rays,
            "rays_total": self.last.rays.total(),
            "mrays_per_s": mrays_per_s(&self.with_medians()),
            "mean_spp": self.last.mean_spp(),
        })
    }
}

fn clone_stats(o: &RenderOutput) -> RenderOutput {
    RenderOutput {
        width: o.width,
        height: o.height,
        color: Vec::new(),
        rgba8: Vec::new(),
        aov: Vec::new(),
        rays: o.rays,
        samples: o.samples,
        gpu_ms: o.gpu_ms.clone(),
    }
}

fn write_rgb(path: &Path, w: u32, h: u32, rgb: Vec<u8>) -> Result<()> {
    let img = image::RgbImage::from_raw(w, h, rgb).context("image size mismatch")?;
    img.save(path)
        .with_context(|| format!("cannot write '{}'", path.display()))
}

/// Everything timed for one backend, kept until the files are written after all timing.
struct BackendRun {
    backend: Backend,
    rt: PathResult,
    hybrid: PathResult,
    /// The same frames at depth 1 (when the requested depth is larger).
    depth1: Option<(PathTiming, PathTiming)>,
    burst: BurstReport,
}

/// Runs `rqr compare`.
pub fn run(args: &CompareArgs) -> Result<()> {
    let started = Instant::now();
    let mut settings = args.image.settings()?;
    std::fs::create_dir_all(&args.output)
        .with_context(|| format!("cannot create output directory '{}'", args.output.display()))?;
    let environment = args.image.load_environment()?;
    let mut scene = args.scene.load()?;
    let environment = args.image.light_scene(&mut scene, environment)?;
    args.image.apply_light_sizes(&mut scene);
    let camera = args
        .camera
        .resolve(&scene, settings.width as f32 / settings.height as f32)?;
    let ctx = args.device.open()?;
    args.scene.apply_texture_format(&ctx, &mut [&mut scene]);
    let (first, _) = args.device.backend(&ctx)?;
    settings.raster = args.image.raster(&ctx).0;
    let mut backends = vec![first];
    if args.backends == Backends::All {
        for b in [Backend::Hw, Backend::Bvh] {
            if !backends.contains(&b) && (b == Backend::Bvh || ctx.features().ray_query) {
                backends.push(b);
            }
        }
    }
    let draws = draw_list::draws(&scene);
    let bar = ProgressBar::new(backends.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} backends {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut startup = started.elapsed();
    let mut runs = Vec::new();
    for backend in &backends {
        bar.set_message(format!(
            "{} backend: warm-up and timed bursts",
            backend.as_str()
        ));
        let (run, setup) = time_backend(
            args,
            &ctx,
            &scene,
            &draws,
            &settings,
            &camera,
            *backend,
            environment.as_ref(),
        )?;
        startup += setup;
        runs.push(run);
        bar.inc(1);
    }
    bar.finish_and_clear();
    // Everything below is host work after the timing: images, FLIP, reports.
    write_outputs(args, &ctx, &settings, &runs, started, startup)?;
    if let Some(spp) = args.reference_spp {
        let md = super::quality::error_against_time(
            &ctx,
            &scene,
            environment.as_ref(),
            &settings,
            &camera,
            first,
            spp,
            &args.output,
        )?;
        outln!("{md}")?;
        super::common::check_validation(&ctx)?;
    }
    Ok(())
}

/// Builds `backend`'s renderer and frame targets (returned as setup time), then times the
/// ray-traced and hybrid frames (and their depth-1 twins) in alternating bursts.
// The scene's parts are borrowed apart: each backend reuses them.
#[allow(clippy::too_many_arguments)]
fn time_backend(
    args: &CompareArgs,
    ctx: &rqr::vk::Context,
    scene: &rqr::scene::Scene,
    draws: &[draw_list::Draw],
    settings: &RenderSettings,
    camera: &rqr::scene::Camera,
    backend: Backend,
    environment: Option<&rqr::environment::EnvironmentMap>,
) -> Result<(BackendRun, Duration)> {
    let setup = Instant::now();
    let mut renderer = {
        let _spinner = super::progress::Spinner::start(super::progress::build_message(backend));
        Renderer::with_bvh_build(ctx, scene, backend, args.device.bvh_build(ctx))?
    };
    super::common::light_with(ctx, &mut renderer, environment)?;
    // AOVs (primary ids) only where the backends are compared with each other.
    let aov = args.backends == Backends::All;
    let targets = |path: RenderPath, s: &RenderSettings, aov: bool| {
        FrameTargets::new(ctx, &renderer, path, s, draws, aov)
    };
    let mut all = vec![
        targets(RenderPath::RayTraced, settings, aov)?,
        targets(RenderPath::Hybrid, settings, aov)?,
    ];
    // Shading is one dispatch per path (primary hit, shadow rays and the reflection/refraction
    // loop share one whitted() call), so its split is derived: the same frame at depth 1
    // (direct light and shadow rays only) is timed too, and the rest of the depth-N frame is
    // the secondary rays' share.
    if settings.max_depth > 1 {
        let d1 = RenderSettings {
            max_depth: 1,
            ..settings.clone()
        };
        all.push(targets(RenderPath::RayTraced, &d1, false)?);
        all.push(targets(RenderPath::Hybrid, &d1, false)?);
    }
    let setup = setup.elapsed();
    let refs: Vec<&FrameTargets> = all.iter().collect();
    // A submission may take a quarter of the fence timeout.
    let max_submission_ms = ctx.fence_timeout().as_secs_f64() * 1e3 / 4.0;
    let timed = burst::time_alternating(ctx, &refs, camera, args.repeat, max_submission_ms)?;
    let mut outputs = timed.outputs.into_iter();
    let mut frames = timed.frames.into_iter();
    let mut result = || -> Result<PathResult> {
        Ok(PathResult {
            timing: PathTiming::new(&frames.next().context("missing frames")?),
            last: outputs.next().context("missing output")?,
        })
    };
    let rt = result()?;
    let hybrid = result()?;
    let depth1 = if all.len() > 2 {
        Some((result()?.timing, result()?.timing))
    } else {
        None
    };
    Ok((
        BackendRun {
            backend,
            rt,
            hybrid,
            depth1,
            burst: timed.report,
        },
        setup,
    ))
}

/// Where the shading pass's time goes: the same frames at depth 1 (primary hit, direct light,
/// shadow rays) against the requested depth.
#[derive(Clone, Copy, Debug, serde::Serialize)]
struct ShadingSplit {
    shading_ms: f64,
    direct_and_shadows_ms: f64,
    reflections_refractions_ms: f64,
    method: &'static str,
}

impl ShadingSplit {
    /// The shading pass split of `full` (requested depth) by `direct` (depth 1).
    fn new(full: &PathTiming, direct: &PathTiming, shading: PassScope) -> Self {
        let (total, first) = (
            full.median(shading.name()).unwrap_or(0.0),
            direct.median(shading.name()).unwrap_or(0.0),
        );
        Self {
            shading_ms: total,
            direct_and_shadows_ms: first,
            reflections_refractions_ms: (total - first).max(0.0),
            method: "shading pass at depth 1 (primary hit, direct light, shadow rays) vs at the requested depth; medians of the same alternating bursts",
        }
    }
}

/// One backend's results as the reports need them.
struct BackendSummary {
    backend: Backend,
    diff: metrics::ImageDiff,
    hybrid_over_rt_time: f64,
    json: serde_json::Value,
}

/// The ray-traced images of the first two backends against each other.
#[derive(serde::Serialize)]
struct CrossBackend {
    backends: [&'static str; 2],
    flip: metrics::ImageDiff,
    primary_ids_agree: f64,
}

/// Wall time of the command split into start-up, GPU frames and host overhead.
#[derive(serde::Serialize)]
struct HostTimes {
    wall_ms: f64,
    startup_ms: f64,
    gpu_frames_ms: f64,
    host_overhead_ms: f64,
    host_overhead_share: f64,
    method: &'static str,
}

impl HostTimes {
    fn new(started: Instant, startup: Duration, gpu_frames_ms: f64) -> Self {
        let wall_ms = started.elapsed().as_secs_f64() * 1e3;
        let startup_ms = startup.as_secs_f64() * 1e3;
        let host_overhead_ms = wall_ms - startup_ms - gpu_frames_ms;
        Self {
            wall_ms,
            startup_ms,
            gpu_frames_ms,
            host_overhead_ms,
            host_overhead_share: host_overhead_ms / gpu_frames_ms.max(1e-9),
            method: "wall time of the command (until its reports are written) minus start-up (scene load, device, renderers, frame targets) minus the GPU time of every frame run, warm-up included",
        }
    }
}

/// Writes every backend's images, FLIP map, side-by-side, report.json and report.md (after
/// all timing), prints the table and checks the validation log.
fn write_outputs(
    args: &CompareArgs,
    ctx: &rqr::vk::Context,
    settings: &RenderSettings,
    runs: &[BackendRun],
    started: Instant,
    startup: Duration,
) -> Result<()> {
    let first = runs.first().context("no backend ran")?.backend;
    let mut table = String::new();
    let mut split_table = String::new();
    let mut summaries = Vec::new();
    for run in runs {
        let dir = if run.backend == first {
            args.output.clone()
        } else {
            let d = args.output.join(run.backend.as_str());
            std::fs::create_dir_all(&d)?;
            d
        };
        let diff = write_images(&dir, settings, run)?;
        timing_rows(&mut table, run)?;
        let splits = run.depth1.as_ref().map(|(rt_d1, hybrid_d1)| {
            (
                ShadingSplit::new(&run.rt.timing, rt_d1, PassScope::RayTraced),
                ShadingSplit::new(&run.hybrid.timing, hybrid_d1, PassScope::HybridShading),
            )
        });
        if let Some((rs, hs)) = &splits {
            for (path, sp) in [(RenderPath::RayTraced, rs), (RenderPath::Hybrid, hs)] {
                writeln!(
                    split_table,
                    "| {:<7} | {:<6} | {:>9.2} | {:>29.2} | {:>23.2} |",
                    run.backend.as_str(),
                    path.as_str(),
                    sp.shading_ms,
                    sp.direct_and_shadows_ms,
                    sp.reflections_refractions_ms,
                )?;
            }
        }
        summaries.push(backend_summary(run, &dir, diff, splits));
    }
    let gpu_frames_ms = runs.iter().map(|r| r.burst.gpu_ms_all_frames).sum();
    let cross_backend = cross_backend(settings, runs);
    let timing = format!(
        "GPU timestamps per frame; the paths' frames alternate, recorded back to back with no host work between them, after warm-up bursts of {} frames per path until two consecutive bursts agree within {:.0} %; median (and min–max) of {} timed frames per path",
        args.repeat.min(3),
        burst::WARM_UP_TOLERANCE * 100.0,
        args.repeat
    );
    let host = HostTimes::new(started, startup, gpu_frames_ms);
    let report = json!({
        "schema": 1,
        "device": ctx.info().name,
        "device_type": ctx.info().device_type,
        "scene": args.scene.name(),
        "settings": settings,
        "timing": timing,
        "host": host,
        "backends": summaries.iter().map(|s| s.json.clone()).collect::<Vec<_>>(),
        "rt_across_backends": cross_backend,
    });
    std::fs::write(
        args.output.join("report.json"),
        serde_json::to_string_pretty(&report)?,
    )?;
    super::report_html::write(&args.output, &report)?;
    let md = markdown_report(
        args,
        ctx,
        settings,
        &timing,
        &table,
        &split_table,
        &summaries,
        cross_backend.as_ref(),
        &host,
    )?;
    std::fs::write(args.output.join("report.md"), &md)?;
    out!("{md}")?;
    outln!("wrote {}", args.output.display())?;
    super::common::check_validation(ctx)
}

/// Writes `run`'s ray-traced and hybrid images, their FLIP map and the labelled side-by-side
/// into `dir`; returns the hybrid-vs-ray-traced difference.
fn write_images(
    dir: &Path,
    settings: &RenderSettings,
    run: &BackendRun,
) -> Result<metrics::ImageDiff> {
    let (rt, hybrid, backend) = (&run.rt.last, &run.hybrid.last, run.backend);
    let diff = {
        let _spinner = super::progress::Spinner::start("FLIP");
        metrics::compare(settings.width, settings.height, &rt.rgba8, &hybrid.rgba8)
    };
    output::write_png(&dir.join("rt.png"), rt)?;
    output::write_png(&dir.join("hybrid.png"), hybrid)?;
    write_rgb(
        &dir.join("flip.png"),
        settings.width,
        settings.height,
        diff.heatmap.clone(),
    )?;
    let sbs = label::side_by_side(
        settings.width,
        settings.height,
        &[
            (&format!("RAY TRACED ({})", backend.as_str()), &rt.rgba8, 4),
            ("HYBRID", &hybrid.rgba8, 4),
            (&format!("FLIP {:.4}", diff.flip_mean), &diff.heatmap, 3),
        ],
    );
    write_rgb(
        &dir.join("side_by_side.png"),
        sbs.width,
        sbs.height,
        sbs.rgb,
    )?;
    Ok(diff)
}

/// Appends `run`'s two rows (ray traced, hybrid) to the timing table.
fn timing_rows(table: &mut String, run: &BackendRun) -> Result<()> {
    for (path, r) in [
        (RenderPath::RayTraced, &run.rt),
        (RenderPath::Hybrid, &run.hybrid),
    ] {
        let get = |scope: PassScope| {
            r.timing
                .median(scope.name())
                .map_or("-".to_string(), |v| format!("{v:.2}"))
        };
        let rays = r.last.rays;
        writeln!(
            table,
            "| {:<7} | {:<6} | {:>8} | {:>9} | {:>7} | {:>9.2} | {:>15} | {:>9} | {:>8} | {:>8} | {:>8} | {:>8.2} |",
            run.backend.as_str(),
            path.as_str(),
            get(PassScope::Gbuffer),
            get(PassScope::shading(path)),
            get(PassScope::Tonemap),
            r.total(),
            format!("{:.2}–{:.2}", r.timing.frame.min, r.timing.frame.max),
            rays.primary,
            rays.shadow,
            rays.reflection,
            rays.refraction,
            mrays_per_s(&r.with_medians()),
        )?;
    }
    Ok(())
}

/// `run`'s entry of report.json, with the values the markdown report needs.
fn backend_summary(
    run: &BackendRun,
    dir: &Path,
    diff: metrics::ImageDiff,
    splits: Option<(ShadingSplit, ShadingSplit)>,
) -> BackendSummary {
    let (rt, hybrid) = (&run.rt, &run.hybrid);
    let mut rt_json = rt.json();
    let mut hybrid_json = hybrid.json();
    if let Some((rs, hs)) = splits {
        rt_json["shading_split"] = json!(rs);
        hybrid_json["shading_split"] = json!(hs);
    }
    let hybrid_over_rt_time = hybrid.total() / rt.total().max(1e-9);
    let json = json!({
        "backend": run.backend.as_str(),
        "rt": rt_json,
        "hybrid": hybrid_json,
        "hybrid_over_rt_time": hybrid_over_rt_time,
        "flip": diff,
        "burst": run.burst,
        "files": {
            "rt": dir.join("rt.png"), "hybrid": dir.join("hybrid.png"),
            "flip": dir.join("flip.png"), "side_by_side": dir.join("side_by_side.png"),
        },
    });
    BackendSummary {
        backend: run.backend,
        diff,
        hybrid_over_rt_time,
        json,
    }
}

/// The first two backends' ray-traced images against each other (FLIP, primary ids).
fn cross_backend(settings: &RenderSettings, runs: &[BackendRun]) -> Option<CrossBackend> {
    let [a, b, ..] = runs else {
        return None;
    };
    let (a_out, b_out) = (&a.rt.last, &b.rt.last);
    let flip = metrics::compare(settings.width, settings.height, &a_out.rgba8, &b_out.rgba8);
    let primary_ids_agree = a_out
        .aov
        .iter()
        .zip(&b_out.aov)
        .filter(|(x, y)| x.instance() == y.instance() && x.primitive() == y.primitive())
        .count() as f64
        / a_out.aov.len().max(1) as f64;
    Some(CrossBackend {
        backends: [a.backend.as_str(), b.backend.as_str()],
        flip,
        primary_ids_agree,
    })
}

/// The command-line spelling of `value` (`center`, `visibility`), as a user types it.
fn flag_name(value: impl clap::ValueEnum) -> String {
    value
        .to_possible_value()
        .map_or_else(String::new, |v| v.get_name().to_string())
}

/// report.md: settings, the timing tables, the image differences and the host times.
#[allow(clippy::too_many_arguments)]
fn markdown_report(
    args: &CompareArgs,
    ctx: &rqr::vk::Context,
    settings: &RenderSettings,
    timing: &str,
    table: &str,
    split_table: &str,
    summaries: &[BackendSummary],
    cross_backend: Option<&CrossBackend>,
    host: &HostTimes,
) -> Result<String> {
    let header = "| backend | path   | gbuffer  | rt/shade  | tonemap | frame ms  | frame min–max   | primary   | shadow   | reflect  | refract  | Mrays/s  |\n|---------|--------|----------|-----------|---------|-----------|-----------------|-----------|----------|----------|----------|----------|\n";
    let mut md = format!(
        "# rqr compare: {}\n\nDevice: {} ({}). {}x{}, {} spp ({}), max depth {}, hybrid G-buffer: {}, visibility pass: {}. Timing: {timing}. Pass columns are medians; \"frame ms\" is the median whole frame (passes, barriers, everything between them).\n\n{header}{table}\n",
        args.scene.name(),
        ctx.info().name,
        ctx.info().device_type,
        settings.width,
        settings.height,
        settings.spp,
        flag_name(settings.sampler),
        settings.max_depth,
        flag_name(settings.gbuffer),
        settings.raster.as_str(),
    );
    if !split_table.is_empty() {
        write!(
            md,
            "Where the shading pass's time goes (derived: the same frames at depth 1 give direct light and shadow rays; the rest is reflection and refraction rays):\n\n| backend | path   | shading   | depth 1: hit, direct, shadows | reflections/refractions |\n|---------|--------|-----------|-------------------------------|-------------------------|\n{split_table}\n"
        )?;
    }
    for s in summaries {
        let f = &s.diff;
        writeln!(
            md,
            "{}: hybrid vs ray traced: FLIP mean {:.4} (p95 {:.4}, p99 {:.4}, max {:.4}), PSNR {:.2} dB; hybrid/RT time {:.2}",
            s.backend.as_str(),
            f64::from(f.flip_mean),
            f64::from(f.flip_p95),
            f64::from(f.flip_p99),
            f64::from(f.flip_max),
            f.psnr_db,
            s.hybrid_over_rt_time,
        )?;
    }
    if let Some(c) = cross_backend {
        writeln!(
            md,
            "\nRay traced, {} vs {}: FLIP mean {:.5}, primary ids agree on {:.4} % of pixels",
            c.backends[0],
            c.backends[1],
            f64::from(c.flip.flip_mean),
            100.0 * c.primary_ids_agree
        )?;
    }
    writeln!(
        md,
        "\nWall time {:.0} ms: start-up {:.0} ms, GPU frames {:.0} ms (warm-up included), host overhead {:.0} ms ({:.1} % of the GPU time).",
        host.wall_ms,
        host.startup_ms,
        host.gpu_frames_ms,
        host.host_overhead_ms,
        100.0 * host.host_overhead_ms / host.gpu_frames_ms.max(1e-9)
    )?;
    Ok(md)
}
