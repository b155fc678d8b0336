//! Per-frame GPU cost of animation: the skinning/morphing pass (`render::passes::skin`, GPU
//! timestamps over every deformed geometry of the frame) and the acceleration-structure
//! rebuild of the posed scene (the builder's own GPU timings), for N frames of the first
//! animation at --fps 24.
//!
//! ```sh
//! cargo run --release --example anim_bench -- assets/gltf/CesiumMan/CesiumMan.glb 60 hw
//! ```

use std::path::Path;

use rqr::accel::Backend;
use rqr::render::passes::skin::SkinningPass;
use rqr::render::Renderer;
use rqr::scene::{AnimationSelection, LoadOptions};
use rqr::vk::{Context, ContextOptions, GpuProfiler};

fn stats(v: &mut [f64]) -> (f64, f64, f64) {
    v.sort_by(f64::total_cmp);
    let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
    (mean, v[v.len() / 2], v[v.len() - 1])
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let path = args
        .get(1)
        .ok_or("usage: anim_bench SCENE [FRAMES] [hw|bvh]")?;
    let frames: u32 = args.get(2).map_or(Ok(60), |f| f.parse())?;
    let backend = match args.get(3).map(String::as_str) {
        Some("bvh") => Backend::Bvh,
        _ => Backend::Hw,
    };
    let scene = rqr::scene::load(Path::new(path), &LoadOptions::default())?;
    let animations = scene.select_animations(&AnimationSelection::First)?;
    let ctx = Context::new(&ContextOptions::default())?;
    let mut passes = Vec::new();
    for (k, inst) in scene.instances.iter().enumerate() {
        let g = &scene.geometries[inst.geometry as usize];
        if g.is_deformable() {
            let joints = scene.rig.nodes[inst.node]
                .skin
                .filter(|_| !g.joints.is_empty())
                .map_or(0, |s| scene.rig.skins[s].joints.len());
            passes.push((k, SkinningPass::new(&ctx, g, joints)?));
        }
    }
    let mut profiler = GpuProfiler::new(&ctx, 2)?;
    let (mut skin_ms, mut blas_ms, mut tlas_ms) = (Vec::new(), Vec::new(), Vec::new());
    for frame in 0..frames {
        let time = frame as f32 / 24.0;
        let pose = scene.rig.pose(&animations, time);
        for (k, pass) in &mut passes {
            let (joints, weights) = scene.instance_deformation(*k, &pose);
            pass.update(joints.as_deref(), weights)?;
        }
        if !passes.is_empty() {
            ctx.run("skin bench", |cmd| {
                profiler.reset(cmd);
                profiler.begin(cmd, "skin");
                for (_, pass) in &passes {
                    pass.record(cmd, None);
                }
                profiler.end(cmd);
                Ok(())
            })?;
            skin_ms.push(profiler.results()?.first().map_or(0.0, |r| r.1));
        }
        let posed = scene.posed(&animations, time);
        let renderer = Renderer::new(&ctx, &posed, backend)?;
        let s = renderer.backend.stats_json();
        let ms = |key: &str| s.get(key).and_then(|v| v.as_f64()).unwrap_or(0.0);
        match backend {
            Backend::Hw => {
                blas_ms.push(ms("blas_build_ms") + ms("compact_ms"));
                tlas_ms.push(ms("tlas_build_ms"));
            }
            Backend::Bvh => {
                blas_ms.push(ms("blas_ms"));
                tlas_ms.push(ms("tlas_ms"));
            }
        }
    }
    println!(
        "{path}: {frames} frames, backend {backend:?}, {} deformed geometries, {} triangles",
        passes.len(),
        scene.triangle_count()
    );
    for (name, v) in [
        ("skin/morph pass", &mut skin_ms),
        ("BLAS rebuild", &mut blas_ms),
        ("TLAS rebuild", &mut tlas_ms),
    ] {
        if v.is_empty() {
            println!("  {name:<16} -");
            continue;
        }
        let (mean, median, max) = stats(v);
        println!("  {name:<16} mean {mean:8.3} ms  median {median:8.3} ms  max {max:8.3} ms");
    }
    Ok(())
}
