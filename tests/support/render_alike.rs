//! Cross-checks of two scenes that should look the same (a compressed copy and its source).

use rqr::accel::Backend;
use rqr::render::image::metrics;
use rqr::render::{RenderSettings, Renderer};
use rqr::scene::{self, Scene};
use rqr::vk::Context;

/// Renders `a` and `b` (ray traced, from the camera that frames `a`) at `size`² on every
/// backend the device has, and asserts a mean FLIP below `max_flip` between them on each.
pub fn assert_renders_alike(
    ctx: &Context,
    a: &Scene,
    b: &Scene,
    size: u32,
    max_flip: f32,
    label: &str,
) {
    let camera = scene::auto_camera(&a.bounds, 1.0);
    let settings = RenderSettings {
        width: size,
        height: size,
        ..Default::default()
    };
    let mut backends = vec![Backend::Bvh];
    if ctx.features().ray_query {
        backends.insert(0, Backend::Hw);
    }
    for backend in backends {
        let render = |s: &Scene| {
            Renderer::new(ctx, s, backend)
                .unwrap()
                .render_rt(ctx, &settings, &camera, false)
                .unwrap()
                .rgba8
        };
        let d = metrics::compare(size, size, &render(a), &render(b));
        eprintln!(
            "{label}, {}: FLIP mean {:.5}, PSNR {:.2} dB",
            backend.as_str(),
            d.flip_mean,
            d.psnr_db
        );
        assert!(
            d.flip_mean < max_flip,
            "{label}, {}: FLIP {} (bound {max_flip})",
            backend.as_str(),
            d.flip_mean
        );
    }
}
