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
