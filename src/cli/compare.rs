//! `rqr compare`: renders the pure ray-traced and the hybrid path (optionally with every
//! backend) and writes the images, a FLIP heat map, a labelled side-by-side and a report.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result};
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use rqr::accel::Backend;
use rqr::render::{compare, gbuffer, label, output, RenderOutput, Renderer};
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
    /// Timed repetitions per path (the report gives medians); one extra warm-up frame first.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
    repeat: u32,
}

/// Median GPU ms per pass over repeated frames (pass order of the first frame).
fn median_passes(frames: &[RenderOutput]) -> Vec<(String, f64)> {
    let Some(first) = frames.first() else {
        return Vec::new();
    };
    first
        .gpu_ms
        .iter()
        .map(|(name, _)| {
            let mut v: Vec<f64> = frames
                .iter()
                .filter_map(|f| f.gpu_ms.iter().find(|(n, _)| n == name).map(|p| p.1))
                .collect();
            v.sort_by(f64::total_cmp);
            (name.clone(), v[v.len() / 2])
        })
        .collect()
}

struct PathResult {
    passes: Vec<(String, f64)>,
    last: RenderOutput,
}

impl PathResult {
    fn total(&self) -> f64 {
        self.passes.iter().map(|p| p.1).sum()
    }
    fn json(&self) -> serde_json::Value {
        let with_medians = RenderOutput {
            gpu_ms: self.passes.clone(),
            ..clone_stats(&self.last)
        };
        json!({
            "gpu_ms": self.passes.iter().map(|(k, v)| (k.clone(), json!(v))).collect::<serde_json::Map<_, _>>(),
            "total_ms": self.total(),
            "rays": self.last.rays,
            "rays_total": self.last.rays.total(),
            "mrays_per_s": mrays_per_s(&with_medians),
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

/// Runs `rqr compare`.
pub fn run(args: &CompareArgs) -> Result<()> {
    let settings = args.image.settings()?;
    std::fs::create_dir_all(&args.output)
        .with_context(|| format!("cannot create output directory '{}'", args.output.display()))?;
    let scene = args.scene.load()?;
    let camera = args
        .camera
        .resolve(&scene, settings.width as f32 / settings.height as f32)?;
    let ctx = args.device.open()?;
    let (first, _) = args.device.backend(&ctx)?;
    let mut backends = vec![first];
    if args.backends == Backends::All {
        for b in [Backend::Hw, Backend::Bvh] {
            if !backends.contains(&b) && (b == Backend::Bvh || ctx.features().ray_query) {
                backends.push(b);
            }
        }
    }
    let draws = gbuffer::draws(&scene);
    // Shading is one dispatch per path (primary hit, shadow rays and the reflection/refraction
    // loop share one whitted() call), so its split is derived: the same frame at depth 1 (direct
    // light and shadow rays only) is timed too, and the rest of the depth-N frame is the
    // secondary rays' share.
    let depth1 = (settings.max_depth > 1).then(|| rqr::render::RenderSettings {
        max_depth: 1,
        ..settings.clone()
    });
    let paths_per_round = if depth1.is_some() { 4 } else { 2 };
    let frames_per_backend = paths_per_round * (u64::from(args.repeat) + 1);
    let bar = ProgressBar::new(frames_per_backend * backends.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} frames {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut table = String::new();
    let mut split_table = String::new();
    let mut report_backends = Vec::new();
    let mut rt_images: Vec<(Backend, RenderOutput)> = Vec::new();
    for backend in &backends {
        bar.set_message(format!("{} backend", backend.as_str()));
        let renderer =
            Renderer::with_bvh_build(&ctx, &scene, *backend, args.device.bvh_build(&ctx))?;
        // The two paths alternate frame by frame, so a machine whose speed drifts (shared
        // CPUs) slows both alike. Frame 0 of each warms up pipelines (lavapipe JIT-compiles
        // shaders on first use) and is not timed.
        let (mut rt_frames, mut hybrid_frames) = (Vec::new(), Vec::new());
        let (mut rt_d1, mut hybrid_d1) = (Vec::new(), Vec::new());
        for i in 0..=args.repeat {
            let rt = renderer.render_rt(&ctx, &settings, &camera, true)?;
            bar.inc(1);
            let hybrid = renderer.render_hybrid(&ctx, &draws, &settings, &camera, true)?;
            bar.inc(1);
            if i > 0 {
                rt_frames.push(rt);
                hybrid_frames.push(hybrid);
            }
            if let Some(d1) = &depth1 {
                let rt = renderer.render_rt(&ctx, d1, &camera, false)?;
                bar.inc(1);
                let hybrid = renderer.render_hybrid(&ctx, &draws, d1, &camera, false)?;
                bar.inc(1);
                if i > 0 {
                    rt_d1.push(rt);
                    hybrid_d1.push(hybrid);
                }
            }
        }
        let split = |shading: &str, full: &[RenderOutput], direct: &[RenderOutput]| {
            let ms = |frames: &[RenderOutput]| {
                median_passes(frames)
                    .into_iter()
                    .find(|p| p.0 == shading)
                    .map_or(0.0, |p| p.1)
            };
            let (total, first) = (ms(full), ms(direct));
            (!direct.is_empty()).then(|| {
                json!({
                    "shading_ms": total,
                    "direct_and_shadows_ms": first,
                    "reflections_refractions_ms": (total - first).max(0.0),
                    "method": "shading pass at depth 1 (primary hit, direct light, shadow rays) vs at the requested depth; medians of the same alternating frames",
                })
            })
        };
        let rt_split = split("rt", &rt_frames, &rt_d1);
        let hybrid_split = split("hybrid shading", &hybrid_frames, &hybrid_d1);
        let finish = |mut frames: Vec<RenderOutput>| -> Result<PathResult> {
            let passes = median_passes(&frames);
            let last = frames.pop().context("no frames")?;
            Ok(PathResult { passes, last })
        };
        let rt = finish(rt_frames)?;
        let hybrid = finish(hybrid_frames)?;
        let diff = compare::compare(
            settings.width,
            settings.height,
            &rt.last.rgba8,
            &hybrid.last.rgba8,
        );
        let dir = if *backend == first {
            args.output.clone()
        } else {
            let d = args.output.join(backend.as_str());
            std::fs::create_dir_all(&d)?;
            d
        };
        output::write_png(&dir.join("rt.png"), &rt.last)?;
        output::write_png(&dir.join("hybrid.png"), &hybrid.last)?;
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
                (
                    &format!("RAY TRACED ({})", backend.as_str()),
                    &rt.last.rgba8,
                    4,
                ),
                ("HYBRID", &hybrid.last.rgba8, 4),
                (&format!("FLIP {:.4}", diff.flip_mean), &diff.heatmap, 3),
            ],
        );
        write_rgb(
            &dir.join("side_by_side.png"),
            sbs.width,
            sbs.height,
            sbs.rgb,
        )?;

        for (name, r) in [("rt", &rt), ("hybrid", &hybrid)] {
            let get = |k: &str| {
                r.passes
                    .iter()
                    .find(|p| p.0 == k)
                    .map_or("-".to_string(), |p| format!("{:.2}", p.1))
            };
            let shading = if name == "rt" {
                get("rt")
            } else {
                get("hybrid shading")
            };
            let rays = r.last.rays;
            writeln!(
                table,
                "| {:<7} | {:<6} | {:>8} | {:>9} | {:>7} | {:>9.2} | {:>9} | {:>8} | {:>8} | {:>8} | {:>8.2} |",
                backend.as_str(),
                name,
                get("gbuffer"),
                shading,
                get("tonemap"),
                r.total(),
                rays.primary,
                rays.shadow,
                rays.reflection,
                rays.refraction,
                mrays_per_s(&RenderOutput { gpu_ms: r.passes.clone(), ..clone_stats(&r.last) }),
            )?;
        }
        for (name, sp) in [("rt", &rt_split), ("hybrid", &hybrid_split)] {
            if let Some(sp) = sp {
                writeln!(
                    split_table,
                    "| {:<7} | {:<6} | {:>9.2} | {:>29.2} | {:>23.2} |",
                    backend.as_str(),
                    name,
                    sp["shading_ms"].as_f64().unwrap_or(0.0),
                    sp["direct_and_shadows_ms"].as_f64().unwrap_or(0.0),
                    sp["reflections_refractions_ms"].as_f64().unwrap_or(0.0),
                )?;
            }
        }
        let mut rt_json = rt.json();
        rt_json["shading_split"] = rt_split.unwrap_or(serde_json::Value::Null);
        let mut hybrid_json = hybrid.json();
        hybrid_json["shading_split"] = hybrid_split.unwrap_or(serde_json::Value::Null);
        report_backends.push(json!({
            "backend": backend.as_str(),
            "rt": rt_json,
            "hybrid": hybrid_json,
            "hybrid_over_rt_time": hybrid.total() / rt.total().max(1e-9),
            "flip": diff,
            "files": {
                "rt": dir.join("rt.png"), "hybrid": dir.join("hybrid.png"),
                "flip": dir.join("flip.png"), "side_by_side": dir.join("side_by_side.png"),
            },
        }));
        rt_images.push((*backend, rt.last));
    }
    bar.finish_and_clear();
    let cross_backend = if rt_images.len() > 1 {
        let (a, b) = (&rt_images[0].1, &rt_images[1].1);
        let d = compare::compare(settings.width, settings.height, &a.rgba8, &b.rgba8);
        let ids = a
            .aov
            .iter()
            .zip(&b.aov)
            .filter(|(x, y)| x.instance() == y.instance() && x.primitive() == y.primitive())
            .count() as f64
            / a.aov.len().max(1) as f64;
        Some(
            json!({"backends": [rt_images[0].0.as_str(), rt_images[1].0.as_str()], "flip": d, "primary_ids_agree": ids}),
        )
    } else {
        None
    };
    let report = json!({
        "schema": 1,
        "device": ctx.info().name,
        "device_type": ctx.info().device_type,
        "scene": args.scene.name(),
        "settings": settings,
        "timing": format!("GPU timestamps, median of {} frames after one untimed warm-up frame; ray-traced and hybrid frames alternate", args.repeat),
        "backends": report_backends,
        "rt_across_backends": cross_backend,
    });
    std::fs::write(
        args.output.join("report.json"),
        serde_json::to_string_pretty(&report)?,
    )?;

    let header = "| backend | path   | gbuffer  | rt/shade  | tonemap | total ms  | primary   | shadow   | reflect  | refract  | Mrays/s  |\n|---------|--------|----------|-----------|---------|-----------|-----------|----------|----------|----------|----------|\n";
    let mut md = format!(
        "# rqr compare: {}\n\nDevice: {} ({}). {}x{}, {} spp ({:?}), max depth {}, hybrid G-buffer: {:?}. GPU ms are medians of {} frames, the two paths alternating (first frame excluded: pipeline JIT on lavapipe).\n\n{header}{table}\n",
        args.scene.name(),
        ctx.info().name,
        ctx.info().device_type,
        settings.width,
        settings.height,
        settings.spp,
        settings.sampler,
        settings.max_depth,
        settings.gbuffer,
        args.repeat
    );
    if !split_table.is_empty() {
        write!(
            md,
            "Where the shading pass's time goes (derived: the same frames at depth 1 give direct light and shadow rays; the rest is reflection and refraction rays):\n\n| backend | path   | shading   | depth 1: hit, direct, shadows | reflections/refractions |\n|---------|--------|-----------|-------------------------------|-------------------------|\n{split_table}\n"
        )?;
    }
    for b in &report_backends {
        let f = &b["flip"];
        writeln!(
            md,
            "{}: hybrid vs ray traced: FLIP mean {:.4} (p95 {:.4}, p99 {:.4}, max {:.4}), PSNR {:.2} dB; hybrid/RT time {:.2}",
            b["backend"].as_str().unwrap_or("?"),
            f["flip_mean"].as_f64().unwrap_or(0.0),
            f["flip_p95"].as_f64().unwrap_or(0.0),
            f["flip_p99"].as_f64().unwrap_or(0.0),
            f["flip_max"].as_f64().unwrap_or(0.0),
            f["psnr_db"].as_f64().unwrap_or(f64::INFINITY),
            b["hybrid_over_rt_time"].as_f64().unwrap_or(0.0),
        )?;
    }
    if let Some(c) = &cross_backend {
        writeln!(
            md,
            "\nRay traced, {} vs {}: FLIP mean {:.5}, primary ids agree on {:.4} % of pixels",
            c["backends"][0],
            c["backends"][1],
            c["flip"]["flip_mean"].as_f64().unwrap_or(0.0),
            100.0 * c["primary_ids_agree"].as_f64().unwrap_or(0.0)
        )?;
    }
    std::fs::write(args.output.join("report.md"), &md)?;
    out!("{md}")?;
    outln!("wrote {}", args.output.display())?;
    super::common::check_validation(&ctx)
}
