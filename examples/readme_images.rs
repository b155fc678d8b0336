//! Renders the README pictures into `docs/images/` (run with `cargo run --release --example
//! readme_images`): the built-in scene at recursion depths 1, 2, 3 and 5, and zoomed crops of
//! an edge under every sampling mode.
use rqr::accel::BackendChoice;
use rqr::render::image::label;
use rqr::render::{RenderSettings, Renderer, SamplerKind};
use rqr::vk::{Context, ContextOptions};

fn save(path: &str, c: label::Canvas) -> anyhow::Result<()> {
    image::RgbImage::from_raw(c.width, c.height, c.rgb)
        .unwrap()
        .save(path)?;
    println!("wrote {path}");
    Ok(())
}

/// Crops `size`² at (x, y) from an RGBA8 image and scales it `zoom`× with nearest neighbour.
fn crop_zoom(rgba: &[u8], width: u32, x: u32, y: u32, size: u32, zoom: u32) -> Vec<u8> {
    let mut out = Vec::with_capacity((size * zoom * size * zoom * 4) as usize);
    for oy in 0..size * zoom {
        for ox in 0..size * zoom {
            let (sx, sy) = (x + ox / zoom, y + oy / zoom);
            let i = ((sy * width + sx) * 4) as usize;
            out.extend_from_slice(&rgba[i..i + 4]);
        }
    }
    out
}

fn main() -> anyhow::Result<()> {
    env_logger::init();
    let ctx = Context::new(&ContextOptions::default())?;
    let scene = rqr::scene::load_default()?;
    let camera = scene.cameras[0];
    let backend = BackendChoice::Auto.resolve(ctx.info())?.0;
    let renderer = Renderer::new(&ctx, &scene, backend)?;
    std::fs::create_dir_all("docs/images")?;

    let size = 256;
    let mut depth_images = Vec::new();
    for depth in [1, 2, 3, 5] {
        let s = RenderSettings {
            width: size,
            height: size,
            max_depth: depth,
            spp: 4,
            sampler: SamplerKind::Grid,
            ..Default::default()
        };
        let out = renderer.render_rt(&ctx, &s, &camera, false)?;
        depth_images.push((format!("DEPTH {depth}"), out.rgba8));
    }
    let panels: Vec<(&str, &[u8], usize)> = depth_images
        .iter()
        .map(|(n, p)| (n.as_str(), p.as_slice(), 4))
        .collect();
    save(
        "docs/images/depths.png",
        label::side_by_side(size, size, &panels),
    )?;

    // Sampling modes: a 32-pixel crop around the box top-right corner, zoomed 5x.
    let full = 384;
    let (cx, cy, crop, zoom) = (158, 172, 32, 5);
    let modes = [
        ("CENTER 1", SamplerKind::Center, 1),
        ("GRID 16", SamplerKind::Grid, 16),
        ("JITTER 16", SamplerKind::Jitter, 16),
        ("HALTON 16", SamplerKind::Halton, 16),
        ("SOBOL 16", SamplerKind::Sobol, 16),
        ("BLUE 16", SamplerKind::Bluenoise, 16),
        ("ADAPTIVE", SamplerKind::Adaptive, 1),
    ];
    let mut crops = Vec::new();
    for (name, sampler, spp) in modes {
        let s = RenderSettings {
            width: full,
            height: full,
            spp,
            sampler,
            adaptive_depth: 3,
            ..Default::default()
        };
        let out = renderer.render_rt(&ctx, &s, &camera, false)?;
        let label = if sampler == SamplerKind::Adaptive {
            format!("ADAPT {:.1}", out.mean_spp())
        } else {
            name.to_string()
        };
        crops.push((label, crop_zoom(&out.rgba8, full, cx, cy, crop, zoom)));
        if sampler == SamplerKind::Center {
            let mut c = label::Canvas::new(full, full, [0, 0, 0]);
            c.blit(0, 0, full, full, &out.rgba8, 4);
            save("docs/images/builtin.png", c)?;
        }
    }
    let panels: Vec<(&str, &[u8], usize)> = crops
        .iter()
        .map(|(n, p)| (n.as_str(), p.as_slice(), 4))
        .collect();
    save(
        "docs/images/sampling.png",
        label::side_by_side(crop * zoom, crop * zoom, &panels),
    )?;
    Ok(())
}
