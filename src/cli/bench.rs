//! `rqr bench`: acceleration-structure build cost and ray throughput per backend.

use std::time::Instant;

use anyhow::{Context as _, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use rqr::accel::bvh::{locality, sah, BvhBuild, BvhBuildOptions, GpuBvh};
use rqr::accel::{Backend, RayBackend};
use rqr::render::passes::raybench::{RayBatch, RayBench};
use rqr::render::{CameraSetup, GpuFrame, RenderSettings, Renderer};
use rqr::scene::procedural::{single_mesh, sphere};
use serde_json::json;

use super::common::{CameraArgs, DeviceArgs, SceneArgs, MAX_SIDE};
use super::outln;

/// `rqr bench` arguments.
#[derive(Args, Debug)]
pub struct BenchArgs {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    device: DeviceArgs,
    #[command(flatten)]
    camera: CameraArgs,
    /// Image width (rays per batch = width × height).
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=MAX_SIDE as i64))]
    width: u32,
    /// Image height.
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=MAX_SIDE as i64))]
    height: u32,
    /// Timed batches per ray kind (the median is reported); one untimed warm-up batch first.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=1000))]
    repeat: u32,
    /// Run every backend the device supports, not just the one `--backend` resolves to.
    #[arg(long)]
    all_backends: bool,
    /// Run the compute-BVH backend with both builders (`--bvh-build host` and `gpu`), to
    /// compare build time, SAH cost and trace speed.
    #[arg(long)]
    all_bvh_builds: bool,
    /// Also time `GpuBvh::refit` of the compute BVH (after tracing; the unchanged scene, so
    /// the whole refit runs) and, for the GPU build, `GpuBvh::rebuild_tlas`: `--repeat` times
    /// each after one untimed call, medians.
    #[arg(long)]
    refit: bool,
    /// Print the results as JSON.
    #[arg(long)]
    json: bool,
}

fn median_ms(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(0.0)
}

/// Times `repeat` refits (GPU and wall ms, the wall time including the SAH read-back) and,
/// for a GPU-built BVH, `repeat` top-level rebuilds, each after one untimed call.
fn time_refit(
    ctx: &rqr::vk::Context,
    scene: &rqr::scene::Scene,
    bvh: &mut GpuBvh,
    repeat: u32,
) -> Result<serde_json::Value> {
    let mut gpu = Vec::new();
    let mut wall = Vec::new();
    let mut last = None;
    for i in 0..=repeat {
        let start = Instant::now();
        let report = bvh.refit(ctx, scene)?;
        if i > 0 {
            wall.push(start.elapsed().as_secs_f64() * 1e3);
            gpu.push(report.gpu_ms.unwrap_or(f64::NAN));
        }
        last = Some(report);
    }
    let report = last.context("no refit")?;
    let mut out = json!({
        "refit_gpu_ms": median_ms(gpu),
        "refit_wall_ms": median_ms(wall),
        "levels": report.levels,
        "blas_sah_after": report.blas_sah_after,
        "tlas_sah_after": report.tlas_sah_after,
    });
    if bvh.stats().builder == "gpu" {
        let opts = BvhBuildOptions::default();
        let mut gpu = Vec::new();
        let mut wall = Vec::new();
        for i in 0..=repeat {
            let start = Instant::now();
            bvh.rebuild_tlas(ctx, scene, &opts)?;
            if i > 0 {
                wall.push(start.elapsed().as_secs_f64() * 1e3);
                gpu.push(
                    bvh.stats()
                        .gpu_phases
                        .as_ref()
                        .map_or(f64::NAN, |p| p.tlas_ms),
                );
            }
        }
        out["tlas_rebuild_gpu_ms"] = json!(median_ms(gpu));
        out["tlas_rebuild_wall_ms"] = json!(median_ms(wall));
    }
    Ok(out)
}

fn median(mut batches: Vec<RayBatch>) -> RayBatch {
    batches.sort_by(|a, b| a.ms.total_cmp(&b.ms));
    batches[batches.len() / 2]
}

/// Runs `rqr bench`.
pub fn run(args: &BenchArgs) -> Result<()> {
    let mut scene = args.scene.load()?;
    let camera = args
        .camera
        .resolve(&scene, args.width as f32 / args.height as f32)?;
    let ctx = args.device.open()?;
    args.scene.apply_texture_format(&ctx, &mut [&mut scene]);
    let (first, _) = args.device.backend(&ctx)?;
    let mut backends = vec![first];
    if args.all_backends {
        for b in [Backend::Hw, Backend::Bvh] {
            if !backends.contains(&b) && (b == Backend::Bvh || ctx.features().ray_query) {
                backends.push(b);
            }
        }
    }
    let settings = RenderSettings {
        width: args.width,
        height: args.height,
        ..Default::default()
    };
    settings.validate(ctx.info().max_image_dimension_2d)?;
    let chosen_build = args.device.bvh_build(&ctx);
    let mut runs: Vec<(Backend, BvhBuild)> = Vec::new();
    for b in &backends {
        if *b == Backend::Bvh && args.all_bvh_builds {
            runs.push((*b, BvhBuild::Host));
            runs.push((*b, BvhBuild::Gpu));
        } else {
            runs.push((*b, chosen_build));
        }
    }
    let bar = ProgressBar::new(runs.len() as u64 * 2 * (u64::from(args.repeat) + 1));
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} batches {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    if runs.contains(&(Backend::Bvh, BvhBuild::Gpu)) {
        // lavapipe JIT-compiles each pipeline inside its first dispatch: build a small
        // scene once so the timed build measures the build, not the compiler.
        let warm = single_mesh(sphere(0, 64, 33));
        GpuBvh::build_with(&ctx, &warm, &BvhBuildOptions::default(), BvhBuild::Gpu)?;
    }
    // Every configuration is built first; then the timed batches run round-robin over them,
    // so a device whose speed drifts (a CPU device on a shared machine, a GPU changing clocks)
    // slows every configuration alike instead of whichever happened to run last.
    struct Prepared {
        // Declared before the renderer it binds, so it is dropped first.
        bench: RayBench,
        renderer: Renderer,
        backend: Backend,
        build: serde_json::Value,
        setup_ms: f64,
        primary: Vec<RayBatch>,
        incoherent: Vec<RayBatch>,
    }
    let mut prepared = Vec::with_capacity(runs.len());
    for (backend, bvh_build) in &runs {
        bar.set_message(format!("{} backend: build", backend.as_str()));
        let start = Instant::now();
        let renderer = Renderer::with_bvh_build(&ctx, &scene, *backend, *bvh_build)?;
        let setup_ms = start.elapsed().as_secs_f64() * 1e3;
        let mut build = renderer.backend.stats_json();
        if let RayBackend::Bvh(bvh) = &renderer.backend {
            // SAH cost of the bottom levels as built (read back: not part of the build time).
            let data = bvh.read_back(&ctx)?;
            build["sah_cost"] = json!(sah::blas_cost(&data));
            build["tlas_sah_cost"] = json!(sah::subtree_cost(&data.nodes, 0));
            build["locality"] = json!(locality::measure(&data));
        }
        let setup = CameraSetup::new(&camera, args.width, args.height, renderer.scene_scale());
        let frame = GpuFrame::new(&settings, &setup, renderer.scene_traits());
        let bench = RayBench::new(&ctx, &renderer.pass_context(), &frame)?;
        prepared.push(Prepared {
            bench,
            renderer,
            backend: *backend,
            build,
            setup_ms,
            primary: Vec::new(),
            incoherent: Vec::new(),
        });
    }
    bar.set_message("timed batches, configurations in turn");
    for i in 0..=args.repeat {
        for run in &mut prepared {
            let p = run.bench.run(&ctx, false)?;
            bar.inc(1);
            let s = run.bench.run(&ctx, true)?;
            bar.inc(1);
            // Batch 0 JIT-compiles the pipeline on lavapipe: not timed.
            if i > 0 {
                run.primary.push(p);
                run.incoherent.push(s);
            }
        }
    }
    let mut results = Vec::new();
    for mut run in prepared {
        let (p, s) = (median(run.primary), median(run.incoherent));
        if args.refit {
            if let RayBackend::Bvh(bvh) = &mut run.renderer.backend {
                run.build["refit"] = time_refit(&ctx, &scene, bvh, args.repeat)?;
            }
        }
        results.push(json!({
            "backend": run.backend.as_str(),
            "build": run.build,
            "upload_and_build_wall_ms": run.setup_ms,
            "primary": {"rays": p.rays, "hits": p.hits, "gpu_ms": p.ms, "mrays_per_s": p.mrays_per_s()},
            "incoherent": {"rays": s.rays, "hits": s.hits, "gpu_ms": s.ms, "mrays_per_s": s.mrays_per_s()},
        }));
    }
    bar.finish_and_clear();
    let doc = json!({
        "device": ctx.info().name,
        "device_type": ctx.info().device_type,
        "scene": args.scene.name(),
        "triangles": scene.triangle_count(),
        "unique_triangles": scene.unique_triangle_count(),
        "width": args.width,
        "height": args.height,
        "repeat": args.repeat,
        "timing": "GPU timestamps; median of the timed batches after one untimed warm-up batch; the configurations' batches alternate",
        "backends": results,
    });
    if args.json {
        outln!("{}", serde_json::to_string_pretty(&doc)?)?;
    } else {
        outln!(
            "{} ({} triangles, {} unique) on {} ({}), {}x{}, median of {}",
            args.scene.name(),
            scene.triangle_count(),
            scene.unique_triangle_count(),
            ctx.info().name,
            ctx.info().device_type,
            args.width,
            args.height,
            args.repeat
        )?;
        outln!("| backend | builder | build ms | build MiB | SAH cost | primary Mrays/s | incoherent Mrays/s |")?;
        outln!("|---------|---------|----------|-----------|----------|-----------------|--------------------|")?;
        for r in doc["backends"].as_array().context("results")? {
            let build = &r["build"];
            let build_ms = build["build_ms"].as_f64().unwrap_or_else(|| {
                ["blas_build_ms", "compact_ms", "tlas_build_ms"]
                    .iter()
                    .filter_map(|k| build[*k].as_f64())
                    .sum()
            });
            let bytes = build["bytes"].as_u64().unwrap_or_else(|| {
                build["blas_bytes"].as_u64().unwrap_or(0)
                    + build["tlas_bytes"].as_u64().unwrap_or(0)
            });
            outln!(
                "| {:<7} | {:<7} | {:>8.2} | {:>9.2} | {:>8} | {:>15.3} | {:>18.3} |",
                r["backend"].as_str().unwrap_or("?"),
                build["builder"].as_str().unwrap_or("-"),
                build_ms,
                bytes as f64 / 1048576.0,
                build["sah_cost"]
                    .as_f64()
                    .map_or("-".to_string(), |c| format!("{c:.2}")),
                r["primary"]["mrays_per_s"].as_f64().unwrap_or(0.0),
                r["incoherent"]["mrays_per_s"].as_f64().unwrap_or(0.0)
            )?;
        }
        for r in doc["backends"].as_array().context("results")? {
            let build = &r["build"];
            let phases = &build["gpu_phases"];
            if phases.is_object() {
                let ms = |k: &str| phases[k].as_f64().unwrap_or(0.0);
                outln!(
                    "GPU build phases (GPU ms): Morton {:.2}, sort {:.2}, clustering {:.2} ({} PLOC iterations), collapse {:.2}, relocate {:.2}; peak scratch {:.1} MiB",
                    ms("morton_ms"),
                    ms("sort_ms"),
                    ms("clustering_ms"),
                    phases["ploc_iterations"].as_u64().unwrap_or(0),
                    ms("collapse_ms"),
                    ms("relocate_ms"),
                    build["peak_scratch_bytes"].as_u64().unwrap_or(0) as f64 / 1048576.0
                )?;
            }
        }
    }
    super::common::check_validation(&ctx)
}
