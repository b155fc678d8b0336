//! Development helper: renders the procedural Cornell scene to `out/quick.png`.
use rqr::accel::Backend;
use rqr::render::{output, RenderSettings, Renderer};
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
    let out = renderer.render_rt(&ctx, &settings, &scene.cameras[0], true)?;
    std::fs::create_dir_all("out")?;
    output::write_png(std::path::Path::new("out/quick.png"), &out)?;
    println!(
        "rays {:?} gpu {:?} validation errors {}",
        out.rays,
        out.gpu_ms,
        ctx.validation_errors().len()
    );
    Ok(())
}
