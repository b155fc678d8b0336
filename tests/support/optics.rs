//! Closed-form and quadrature references shared by the lighting tests.

use glam::Vec3;
use rqr::scene::Scene;

/// Directional albedo of GGX (height-correlated Smith, F = 1) by midpoint quadrature over
/// the hemisphere: the host reference of the split-sum table's A + B.
pub fn ggx_albedo(n_dot_v: f64, roughness: f64) -> f64 {
    let alpha = (roughness * roughness).max(1e-3);
    let a2 = alpha * alpha;
    let v = [(1.0 - n_dot_v * n_dot_v).sqrt(), 0.0, n_dot_v];
    let (nt, np) = (400, 800);
    let mut sum = 0.0;
    for i in 0..nt {
        let theta = (i as f64 + 0.5) / nt as f64 * std::f64::consts::FRAC_PI_2;
        let (st, ct) = theta.sin_cos();
        for j in 0..np {
            let phi = (j as f64 + 0.5) / np as f64 * std::f64::consts::TAU;
            let l = [st * phi.cos(), st * phi.sin(), ct];
            let h = [v[0] + l[0], v[1] + l[1], v[2] + l[2]];
            let len = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
            let n_dot_h = h[2] / len;
            let d = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
            let dist = a2 / (std::f64::consts::PI * d * d);
            let gv = ct * (n_dot_v * n_dot_v * (1.0 - a2) + a2).sqrt();
            let gl = n_dot_v * (ct * ct * (1.0 - a2) + a2).sqrt();
            let vis = 0.5 / (gv + gl);
            let d_omega = st
                * (std::f64::consts::FRAC_PI_2 / nt as f64)
                * (std::f64::consts::TAU / np as f64);
            sum += dist * vis * ct * d_omega;
        }
    }
    sum
}

/// KHR_materials_sheen's Charlie distribution at `n_dot_h`, as `d_charlie` in brdf.glsl.
pub fn d_charlie(sheen_roughness: f64, n_dot_h: f64) -> f64 {
    let alpha = (sheen_roughness * sheen_roughness).max(1e-6);
    let sin2h = (1.0 - n_dot_h * n_dot_h).max(0.0);
    (2.0 + 1.0 / alpha) * sin2h.powf(0.5 / alpha) / std::f64::consts::TAU
}

fn sheen_lambda(cos_theta: f64, alpha: f64) -> f64 {
    let fit = |x: f64| {
        let k = (1.0 - alpha) * (1.0 - alpha);
        let mix = |a: f64, b: f64| a + (b - a) * k;
        mix(21.5473, 25.3245) / (1.0 + mix(3.82987, 3.32435) * x.powf(mix(0.19823, 0.16801)))
            + mix(-1.97760, -1.27393) * x
            + mix(-4.32054, -4.85967)
    };
    if cos_theta.abs() < 0.5 {
        fit(cos_theta).exp()
    } else {
        (2.0 * fit(0.5) - fit(1.0 - cos_theta)).exp()
    }
}

/// The sheen visibility (Estevez & Kulla's fitted Λ), as `v_sheen` in brdf.glsl.
pub fn v_sheen(n_dot_l: f64, n_dot_v: f64, sheen_roughness: f64) -> f64 {
    let alpha = (sheen_roughness * sheen_roughness).max(1e-6);
    let s = (1.0 + sheen_lambda(n_dot_v, alpha) + sheen_lambda(n_dot_l, alpha))
        * (4.0 * n_dot_v * n_dot_l);
    (1.0 / s).clamp(0.0, 1.0)
}

/// Directional albedo of the sheen lobe, ∫ D_charlie V_sheen (n·l) dl, by midpoint quadrature
/// over the light directions (polar angle × azimuth, the azimuth over half the circle by
/// symmetry): the host reference of the BRDF table's `.b`, drawn on the GPU from half vectors.
pub fn sheen_albedo(n_dot_v: f64, sheen_roughness: f64) -> f64 {
    let v = [(1.0 - n_dot_v * n_dot_v).sqrt(), 0.0, n_dot_v];
    let (nt, np) = (240, 240);
    let d_theta = std::f64::consts::FRAC_PI_2 / nt as f64;
    let d_phi = std::f64::consts::PI / np as f64;
    let mut sum = 0.0;
    for i in 0..nt {
        let (st, ct) = ((i as f64 + 0.5) * d_theta).sin_cos();
        let vis = v_sheen(ct, n_dot_v, sheen_roughness);
        for j in 0..np {
            let phi = (j as f64 + 0.5) * d_phi;
            let h = [v[0] + st * phi.cos(), v[1] + st * phi.sin(), v[2] + ct];
            let n_dot_h = h[2] / (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
            sum += d_charlie(sheen_roughness, n_dot_h) * vis * ct * st;
        }
    }
    2.0 * sum * d_theta * d_phi
}

/// The camera ray through the centre of pixel (x, y) of a `size`² image.
pub fn camera_dir(scene: &Scene, x: u32, y: u32, size: u32) -> Vec3 {
    let cam = scene.cameras[0];
    let rqr::scene::Projection::Perspective { yfov, .. } = cam.projection else {
        unreachable!()
    };
    let t = (yfov * 0.5).tan();
    let ndc_x = (x as f32 + 0.5) / size as f32 * 2.0 - 1.0;
    let ndc_y = 1.0 - (y as f32 + 0.5) / size as f32 * 2.0;
    cam.camera_to_world
        .transform_vector3(Vec3::new(ndc_x * t, ndc_y * t, -1.0))
        .normalize()
}
