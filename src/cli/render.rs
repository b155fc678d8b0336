//! `rqr render`: one image of a scene with the pure ray-traced or the hybrid path.

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::{Args, ValueEnum};
use rqr::render::{gbuffer, output, RenderOutput, Renderer};
use serde_json::json;

use super::common::{check_output_file, CameraArgs, DeviceArgs, ImageArgs, SceneArgs};

/// Which rendering path.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// Pure ray tracing: primary, shadow, reflection and refraction rays.
    #[default]
    Rt,
    /// Raster G-buffer for primary visibility, ray-traced shadows/reflections/refractions.
    Hybrid,
}

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
    #[arg(long, value_enum, default_value_t = Mode::Rt)]
    mode: Mode,
    /// Output: .png (tonemapped sRGB) or .exr (linear HDR).
    #[arg(short, long, default_value = "out.png")]
    output: PathBuf,
    /// Also write 32-bit float EXR AOVs next to the output: depth, normal, instance,
    /// primitive, barycentrics, position (comma-separated).
    #[arg(long, value_delimiter = ',')]
    aov: Vec<String>,
    /// Print a JSON summary (device, backend, per-pass GPU ms, rays by kind, Mrays/s).
    #[arg(long)]
    json: bool,
}

/// Mrays/s over the ray-tracing passes of a frame.
pub fn mrays_per_s(out: &RenderOutput) -> f64 {
    let ms: f64 = out
        .gpu_ms
        .iter()
        .filter(|(name, _)| name != "tonemap" && name != "gbuffer")
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
    let settings = args.image.settings()?;
    for name in &args.aov {
        if !output::AOV_NAMES.contains(&name.as_str()) {
            bail!(
                "unknown AOV '{name}' (known: {})",
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
    if ext != "png" && ext != "exr" {
        bail!(
            "output '{}' must end in .png or .exr",
            args.output.display()
        );
    }
    check_output_file(&args.output)?;
    let scene = args.scene.load()?;
    let camera = args
        .camera
        .resolve(&scene, settings.width as f32 / settings.height as f32)?;
    let ctx = args.device.open()?;
    let (backend, reason) = args.device.backend(&ctx)?;
    log::info!("backend {} ({reason})", backend.as_str());
    let renderer = Renderer::new(&ctx, &scene, backend)?;
    let write_aov = !args.aov.is_empty();
    let out = match args.mode {
        Mode::Rt => renderer.render_rt(&ctx, &settings, &camera, write_aov)?,
        Mode::Hybrid => {
            renderer.render_hybrid(&ctx, &gbuffer::draws(&scene), &settings, &camera, write_aov)?
        }
    };
    if ext == "exr" {
        output::write_exr(&args.output, &out)?;
    } else {
        output::write_png(&args.output, &out)?;
    }
    let aovs = output::write_aovs(&args.output, &out, &args.aov)?;
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
            "gpu_ms": out.gpu_ms.iter().map(|(k, v)| (k.clone(), json!(v))).collect::<serde_json::Map<_, _>>(),
            "total_gpu_ms": out.total_ms(),
            "rays": out.rays,
            "rays_total": out.rays.total(),
            "mrays_per_s": mrays_per_s(&out),
            "acceleration": renderer.backend.stats_json(),
            "output": args.output,
            "aovs": aovs,
        });
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        println!(
            "{} {}x{} {} spp ({}, {}): {:.1} ms GPU, {} rays ({:.2} Mrays/s) -> {}",
            args.scene.name(),
            settings.width,
            settings.height,
            settings.spp,
            match args.mode {
                Mode::Rt => "ray traced",
                Mode::Hybrid => "hybrid",
            },
            backend.as_str(),
            out.total_ms(),
            out.rays.total(),
            mrays_per_s(&out),
            args.output.display()
        );
        for p in &aovs {
            println!("  AOV {}", p.display());
        }
    }
    let errors = ctx.validation_errors();
    if !errors.is_empty() {
        bail!(
            "{} Vulkan validation error(s); first: {}",
            errors.len(),
            errors[0]
        );
    }
    Ok(())
}
