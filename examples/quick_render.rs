//! Development helper: renders the procedural Cornell scene with both paths to `out/`.
use rqr::accel::Backend;
use rqr::render::image::output;
use rqr::render::passes::draw_list;
use rqr::render::{RenderSettings, Renderer};
use rqr::vk::{Context, ContextOptions};

fn main() -> anyhow::Result<()> {
    env_logger::init();
    let ctx = Context::new(&ContextOptions {
        validation: Some(true),
        ..Default::default()
    })?;
    let scene = rqr::scene::procedural::cornell();
    let backend = if std::env::args().any(|a| a == "bvh") {
        Backend::Bvh
    } else {
        Backend::Hw
    };
    let renderer = Renderer::new(&ctx, &scene, backend)?;
    let settings = RenderSettings {
        width: 256,
        height: 256,
        ..Default::default()
    };
    std::fs::create_dir_all("out")?;
    let rt = renderer.render_rt(&ctx, &settings, &scene.cameras[0], true)?;
    output::write_png(std::path::Path::new("out/quick_rt.png"), &rt)?;
    let draws = draw_list::draws(&scene);
    let t0 = std::time::Instant::now();
    let hy = renderer.render_hybrid(&ctx, &draws, &settings, &scene.cameras[0], true)?;
    println!("hybrid wall {:?}", t0.elapsed());
    output::write_png(std::path::Path::new("out/quick_hybrid.png"), &hy)?;
    let mut se = 0.0f64;
    let mut id_mismatch = 0;
    for (i, (a, b)) in rt.color.iter().zip(&hy.color).enumerate() {
        for c in 0..3 {
            let d = (a[c].min(1.0) - b[c].min(1.0)) as f64;
            se += d * d;
        }
        if rt.aov[i].instance() != hy.aov[i].instance()
            || rt.aov[i].primitive() != hy.aov[i].primitive()
        {
            id_mismatch += 1;
        }
    }
    let mse = se / (rt.color.len() * 3) as f64;
    println!(
        "psnr {:.2} dB, id mismatches {id_mismatch}",
        10.0 * (1.0 / mse).log10()
    );
    println!("rt rays {:?} gpu {:?}", rt.rays, rt.gpu_ms);
    println!("hy rays {:?} gpu {:?}", hy.rays, hy.gpu_ms);
    println!("validation errors {}", ctx.validation_errors().len());
    Ok(())
}
