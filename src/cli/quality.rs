//! `rqr compare --reference-spp N`: error against time. A converged image of the distributed
//! model (ray traced, N samples per pixel) is the reference; the Whitted model and the
//! distributed one at 1, 4 and 16 spp, on both paths, are rendered and reported with
//! their FLIP and PSNR against it next to their GPU milliseconds. With `--denoise`, the
//! denoised 1-spp frame joins them twice: filtered alone (no history), and after
//! [`DENOISED_FRAMES`] frames of a static camera (its GPU ms: that last frame's).

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context as _, Result};
use rqr::accel::Backend;
use rqr::environment::EnvironmentMap;
use rqr::render::denoise::DenoiseMode;
use rqr::render::drivers::sequence::{CameraPath, Sequence, SequenceOptions};
use rqr::render::image::tonemap::tonemap_rgba8;
use rqr::render::image::{metrics, output};
use rqr::render::passes::draw_list;
use rqr::render::{RenderOutput, RenderPath, RenderSettings, Renderer, SamplerKind, Shading};
use rqr::scene::{Camera, Scene};
use rqr::vk::Context;
use serde_json::json;

/// One rendered configuration against the reference.
#[derive(serde::Serialize)]
pub struct QualityRow {
    /// `whitted`, or `distributed N spp`.
    pub config: String,
    /// `rt` or `hybrid`.
    pub path: &'static str,
    /// Samples per pixel.
    pub spp: u32,
    /// GPU milliseconds of the frame (timestamps of one frame, every pass).
    pub gpu_ms: f64,
    /// Mean FLIP against the reference (tonemapped 8-bit images).
    pub flip_mean: f32,
    /// PSNR against the reference, dB.
    pub psnr_db: f64,
}

/// Frames timed per cheap configuration (their median is reported).
const TIMED_FRAMES: usize = 3;

/// The distributed spp the ladder shows.
const LADDER_SPP: [u32; 3] = [1, 4, 16];

/// Frames of history behind the ladder's accumulated denoised row.
pub const DENOISED_FRAMES: u32 = 30;

fn render_path(
    ctx: &Context,
    renderer: &mut Renderer,
    draws: &[draw_list::Draw],
    settings: &RenderSettings,
    camera: &Camera,
    path: RenderPath,
) -> Result<RenderOutput> {
    Ok(match path {
        RenderPath::RayTraced => renderer.render_rt(ctx, settings, camera, false)?,
        RenderPath::Hybrid => renderer.render_hybrid(ctx, draws, settings, camera, false)?,
    })
}

/// Camera samples per render of the reference: a long one is cut into renders this size, so
/// that no submission nears the GPU timeout.
const REFERENCE_BATCH: u32 = 16;

/// The ray-traced image of `settings` at `spp` samples per pixel, rendered in batches of
/// [`REFERENCE_BATCH`] samples with successive seeds (independent samples), their linear
/// colours averaged and tonemapped on the host. Its `gpu_ms` sums the batches'.
fn render_reference(
    ctx: &Context,
    renderer: &mut Renderer,
    settings: &RenderSettings,
    camera: &Camera,
    spp: u32,
) -> Result<RenderOutput> {
    let mut sum: Vec<[f64; 3]> = vec![[0.0; 3]; settings.pixels() as usize];
    let mut total: Option<RenderOutput> = None;
    let mut done = 0;
    for batch in 0.. {
        if done >= spp {
            break;
        }
        let n = REFERENCE_BATCH.min(spp - done);
        let s = RenderSettings {
            spp: n,
            seed: settings.seed.wrapping_add(batch),
            ..settings.clone()
        };
        s.validate(u32::MAX)?;
        let out = renderer.render_rt(ctx, &s, camera, false)?;
        for (acc, c) in sum.iter_mut().zip(&out.color) {
            for (a, &v) in acc.iter_mut().zip(c) {
                *a += f64::from(v) * f64::from(n);
            }
        }
        done += n;
        total = Some(match total {
            None => out,
            Some(mut t) => {
                t.rays = t.rays + out.rays;
                t.samples += out.samples;
                t.gpu_ms.extend(out.gpu_ms);
                t
            }
        });
    }
    let mut out = total.context("a reference needs at least one sample")?;
    out.color = sum
        .iter()
        .map(|c| {
            let m = c.map(|v| (v / f64::from(spp)) as f32);
            [m[0], m[1], m[2], 1.0]
        })
        .collect();
    out.rgba8 = out
        .color
        .iter()
        .flat_map(|c| tonemap_rgba8([c[0], c[1], c[2]], settings.tonemap, settings.exposure))
        .collect();
    Ok(out)
}

/// Renders the reference and the ladder on `backend`, writes `reference.png`, the ladder's
/// ray-traced images (`quality-whitted.png`, `quality-distributed-4-spp.png`, …),
/// `quality.json` and `quality.md` into `dir`, and returns the markdown table.
#[allow(clippy::too_many_arguments)]
pub fn error_against_time(
    ctx: &Context,
    scene: &Scene,
    environment: Option<&EnvironmentMap>,
    settings: &RenderSettings,
    camera: &Camera,
    backend: Backend,
    reference_spp: u32,
    dir: &Path,
) -> Result<String> {
    let mut renderer = Renderer::new(ctx, scene, backend)?;
    super::common::light_with(ctx, &mut renderer, environment)?;
    let draws = draw_list::draws(scene);
    let distributed = |spp: u32, seed: u32| RenderSettings {
        spp,
        sampler: SamplerKind::Sobol,
        shading: Shading::Distributed,
        seed,
        denoise: DenoiseMode::None,
        ..settings.clone()
    };
    // Other seeds than the ladder's, so the reference's noise is independent of theirs.
    let reference = render_reference(
        ctx,
        &mut renderer,
        &distributed(1, settings.seed.wrapping_add(0x9e37)),
        camera,
        reference_spp,
    )?;
    output::write_png(&dir.join("reference.png"), &reference)?;
    let mut configs = vec![(
        "whitted".to_string(),
        RenderSettings {
            shading: Shading::Whitted,
            diffuse_bounces: 0,
            denoise: DenoiseMode::None,
            ..settings.clone()
        },
    )];
    for spp in LADDER_SPP {
        configs.push((
            format!("distributed {spp} spp"),
            distributed(spp, settings.seed),
        ));
    }
    let denoised = settings.denoise.enabled().then(|| RenderSettings {
        denoise: settings.denoise,
        ..distributed(1, settings.seed)
    });
    if let Some(s) = &denoised {
        configs.push((format!("{} 1 spp alone", s.denoise.as_str()), s.clone()));
    }
    // One frame of each model and path first: a CPU device may finish compiling a pipeline
    // on its first dispatch, which is not the frame's cost.
    for (_, s) in &configs[..2] {
        for path in [RenderPath::RayTraced, RenderPath::Hybrid] {
            render_path(ctx, &mut renderer, &draws, s, camera, path)?;
        }
    }
    let mut rows = Vec::new();
    for (config, s) in &configs {
        for path in [RenderPath::RayTraced, RenderPath::Hybrid] {
            // The median of TIMED_FRAMES frames for the cheap configurations (below 16 spp),
            // one frame otherwise.
            let frames = if s.spp < 16 { TIMED_FRAMES } else { 1 };
            let mut outs = Vec::new();
            for _ in 0..frames {
                outs.push(render_path(ctx, &mut renderer, &draws, s, camera, path)?);
            }
            outs.sort_by(|a, b| a.total_ms().total_cmp(&b.total_ms()));
            let out = outs.swap_remove(outs.len() / 2);
            if path == RenderPath::RayTraced {
                let name = format!("quality-{}.png", config.replace(' ', "-"));
                output::write_png(&dir.join(name), &out)?;
            }
            let d = metrics::compare(s.width, s.height, &reference.rgba8, &out.rgba8);
            rows.push(QualityRow {
                config: config.clone(),
                path: path.as_str(),
                spp: s.spp,
                gpu_ms: out.total_ms(),
                flip_mean: d.flip_mean,
                psnr_db: d.psnr_db,
            });
        }
    }
    if let Some(s) = &denoised {
        for path in [RenderPath::RayTraced, RenderPath::Hybrid] {
            let out = accumulated(ctx, &renderer, scene, s, camera, path)?;
            let config = format!(
                "{} 1 spp after {DENOISED_FRAMES} frames",
                s.denoise.as_str()
            );
            if path == RenderPath::RayTraced {
                let name = format!("quality-{}.png", config.replace(' ', "-"));
                output::write_png(&dir.join(name), &out)?;
            }
            let d = metrics::compare(s.width, s.height, &reference.rgba8, &out.rgba8);
            rows.push(QualityRow {
                config,
                path: path.as_str(),
                spp: 1,
                gpu_ms: out.total_ms(),
                flip_mean: d.flip_mean,
                psnr_db: d.psnr_db,
            });
        }
    }
    let mut md = format!(
        "Error against a converged reference (distributed, ray traced, {reference_spp} spp, {} ms GPU), {} backend, {}x{}; GPU timestamps of one frame (median of 3 below 16 spp) after a warm-up frame of each model and path:\n\n| shading | path | spp | GPU ms | FLIP mean | PSNR dB |\n|---|---|---:|---:|---:|---:|\n",
        fmt_ms(reference.total_ms()),
        backend.as_str(),
        settings.width,
        settings.height
    );
    for r in &rows {
        writeln!(
            md,
            "| {} | {} | {} | {} | {:.4} | {:.2} |",
            r.config,
            r.path,
            r.spp,
            fmt_ms(r.gpu_ms),
            r.flip_mean,
            r.psnr_db
        )?;
    }
    let rows_json: Vec<serde_json::Value> = rows
        .iter()
        .map(serde_json::to_value)
        .collect::<Result<_, _>>()?;
    std::fs::write(
        dir.join("quality.svg"),
        super::report_charts::quality_svg(&rows_json),
    )
    .with_context(|| format!("cannot write '{}'", dir.join("quality.svg").display()))?;
    // report.json and report.html (written before the ladder) gain its rows and chart.
    let report_path = dir.join("report.json");
    if let Ok(text) = std::fs::read_to_string(&report_path) {
        let mut full: serde_json::Value = serde_json::from_str(&text)
            .with_context(|| format!("cannot parse '{}'", report_path.display()))?;
        full["quality"] = json!({ "reference_spp": reference_spp, "rows": &rows_json });
        std::fs::write(&report_path, serde_json::to_string_pretty(&full)?)
            .with_context(|| format!("cannot write '{}'", report_path.display()))?;
        super::report_html::write(dir, &full)?;
    }
    std::fs::write(dir.join("quality.md"), &md)
        .with_context(|| format!("cannot write '{}'", dir.join("quality.md").display()))?;
    let report = json!({
        "reference": {
            "spp": reference_spp,
            "path": "rt",
            "shading": "distributed",
            "gpu_ms": reference.total_ms(),
        },
        "backend": backend.as_str(),
        "rows": rows,
    });
    std::fs::write(
        dir.join("quality.json"),
        serde_json::to_string_pretty(&report)?,
    )
    .with_context(|| format!("cannot write '{}'", dir.join("quality.json").display()))?;
    Ok(md)
}

/// Frame [`DENOISED_FRAMES`] of a static camera's denoised sequence on `path`.
fn accumulated(
    ctx: &Context,
    renderer: &Renderer,
    scene: &Scene,
    settings: &RenderSettings,
    camera: &Camera,
    path: RenderPath,
) -> Result<RenderOutput> {
    let mut seq = Sequence::new(
        ctx,
        renderer,
        scene,
        settings,
        *camera,
        CameraPath::Static,
        SequenceOptions {
            path,
            reuse: Default::default(),
            reference: false,
        },
    )?;
    let mut last = None;
    for k in 0..DENOISED_FRAMES {
        last = Some(seq.render_frame(ctx, k)?);
    }
    Ok(last.context("no frame rendered")?.output)
}

fn fmt_ms(ms: f64) -> String {
    if ms >= 100.0 {
        format!("{ms:.0}")
    } else {
        format!("{ms:.2}")
    }
}
