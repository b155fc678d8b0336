//! Loads every model of a sample-model folder (its `INDEX.tsv`: name, main file, ...) and
//! says, per model, whether it loads or is refused, and why; with `--render`, renders each
//! loaded model at 64×64 with every backend under validation and counts validation errors.
//!
//! `cargo run --release --example sweep_models -- ../shared/gltf [--render] [NAME...]`
//!
//! Exit status 1 when a model fails for any reason other than a required extension rqr does
//! not implement, or when rendering reports validation errors.
use std::path::PathBuf;

use rqr::accel::Backend;
use rqr::render::{RenderSettings, Renderer};
use rqr::scene::{self, LoadOptions, SceneError};
use rqr::vk::{Context, ContextOptions};

fn main() -> anyhow::Result<()> {
    env_logger::init();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = PathBuf::from(args.first().map_or("../shared/gltf", String::as_str));
    let render = args.iter().any(|a| a == "--render");
    let only: Vec<&String> = args
        .iter()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let index = std::fs::read_to_string(dir.join("INDEX.tsv"))?;
    let ctx = if render {
        Some(Context::new(&ContextOptions {
            validation: Some(true),
            ..Default::default()
        })?)
    } else {
        None
    };
    let mut failures = 0;
    for line in index.lines().skip(1).filter(|l| !l.trim().is_empty()) {
        let fields: Vec<&str> = line.split('\t').collect();
        let (name, main_file) = (fields[0], fields[1]);
        if !only.is_empty() && !only.iter().any(|o| o.as_str() == name) {
            continue;
        }
        let t0 = std::time::Instant::now();
        let scene = match scene::load(&dir.join(main_file), &LoadOptions::default()) {
            Ok(s) => s,
            Err(SceneError::UnsupportedExtensions { extensions, .. }) => {
                println!("{name:<28} refused: requires {}", extensions.join(", "));
                continue;
            }
            Err(e) => {
                println!("{name:<28} ERROR: {e}");
                failures += 1;
                continue;
            }
        };
        let mut status = format!(
            "loaded in {:.2} s: {} triangles, ignored extensions: {}",
            t0.elapsed().as_secs_f64(),
            scene.triangle_count(),
            if scene.extensions_unsupported.is_empty() {
                "-".to_string()
            } else {
                scene.extensions_unsupported.join(", ")
            }
        );
        if !scene.variants.is_empty() {
            status.push_str(&format!(", variants: {}", scene.variants.join(", ")));
        }
        if let Some(ctx) = &ctx {
            let camera = scene
                .cameras
                .first()
                .copied()
                .unwrap_or_else(|| scene::auto_camera(&scene.bounds, 1.0));
            let settings = RenderSettings {
                width: 64,
                height: 64,
                ..Default::default()
            };
            let mut backends = vec![Backend::Bvh];
            if ctx.features().ray_query {
                backends.insert(0, Backend::Hw);
            }
            let before = ctx.validation_errors().len();
            for backend in backends {
                let result = Renderer::new(ctx, &scene, backend)
                    .and_then(|r| r.render_rt(ctx, &settings, &camera, false));
                match result {
                    Ok(_) => status.push_str(&format!("; {} ok", backend.as_str())),
                    Err(e) => {
                        status.push_str(&format!("; {} FAILED: {e}", backend.as_str()));
                        failures += 1;
                    }
                }
            }
            let errors = ctx.validation_errors().len() - before;
            if errors > 0 {
                status.push_str(&format!("; {errors} VALIDATION ERRORS"));
                failures += 1;
            }
        }
        println!("{name:<28} {status}");
    }
    if failures > 0 {
        anyhow::bail!("{failures} failure(s)");
    }
    Ok(())
}
