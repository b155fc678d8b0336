//! Importance sampling of an environment map by luminance × solid angle: the tables the GPU
//! samples from (`shaders/common/env_sampling.glsl`), and the same sampler on the host as its
//! reference. The renderer's table is built on the GPU at load
//! (`shaders/environment/env_sampling_rows.comp` and `env_sampling_marginal.comp`, from
//! `environment::gpu`); [`SamplingTables::new`] builds the same table on the host, in f64,
//! for the tests and the host sampler.
//!
//! The density is piecewise constant over the map's texels: texel `(x, y)` gets
//! `lum(x, y) · sin θ_y`, normalised. A direction is drawn by inverting the marginal CDF of the
//! rows, then the chosen row's conditional CDF, linearly within the bin; its solid-angle density
//! is `p_uv / (2π² sin θ)`, where `p_uv` is the density over `(u, v) ∈ [0, 1)²`. A map that is
//! black everywhere samples uniformly over `(u, v)`.

use glam::Vec3;

use super::{direction_to_uv, uv_to_direction, EnvironmentMap};

/// Rec. 709 luminance.
pub fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// The CDFs of a map of `width` × `height` texels, as one `(width + 1) × (height + 1)` table:
/// row `y < height` holds the conditional CDF of row `y` (`width + 1` entries, 0 to 1), row
/// `height` the marginal CDF of the rows (`height + 1` entries, then zeros).
#[derive(Clone, Debug)]
pub struct SamplingTables {
    /// Texels per row of the map.
    pub width: u32,
    /// Rows of the map.
    pub height: u32,
    /// `(width + 1) * (height + 1)` values, row-major.
    pub table: Vec<f32>,
}

impl SamplingTables {
    /// Builds the tables of `map` on the host (accumulated in f64, stored as f32): the
    /// reference of the GPU's table (`GpuEnvironment`'s `EnvTexture::Sampling`).
    pub fn new(map: &EnvironmentMap) -> Self {
        let (w, h) = (map.width as usize, map.height as usize);
        let stride = w + 1;
        let mut table = vec![0.0f32; stride * (h + 1)];
        let mut row_sums = vec![0.0f64; h];
        for y in 0..h {
            let sin = (std::f64::consts::PI * (y as f64 + 0.5) / h as f64).sin();
            let mut acc = 0.0f64;
            let row: Vec<f64> = (0..w)
                .map(|x| f64::from(luminance(map.texels[y * w + x]).max(0.0)) * sin)
                .collect();
            let sum: f64 = row.iter().sum();
            for (x, f) in row.iter().enumerate() {
                acc += f;
                table[y * stride + x + 1] = if sum > 0.0 {
                    (acc / sum) as f32
                } else {
                    (x + 1) as f32 / w as f32
                };
            }
            table[y * stride + w] = 1.0;
            row_sums[y] = sum;
        }
        let total: f64 = row_sums.iter().sum();
        let mut acc = 0.0f64;
        for (y, s) in row_sums.iter().enumerate() {
            acc += s;
            table[h * stride + y + 1] = if total > 0.0 {
                (acc / total) as f32
            } else {
                (y + 1) as f32 / h as f32
            };
        }
        table[h * stride + h] = 1.0;
        Self {
            width: map.width,
            height: map.height,
            table,
        }
    }

    fn at(&self, x: usize, row: usize) -> f32 {
        self.table[row * (self.width as usize + 1) + x]
    }

    /// The bin `i` of a CDF of `n` bins in `row` with `cdf[i] <= u < cdf[i + 1]` (a bin of zero
    /// width is never chosen), and where `u` falls in it.
    fn find(&self, row: usize, n: usize, u: f32) -> (usize, f32, f32) {
        let (mut lo, mut hi) = (0usize, n);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if self.at(mid, row) <= u {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let (c0, c1) = (self.at(lo, row), self.at(lo + 1, row));
        let t = if c1 > c0 {
            ((u - c0) / (c1 - c0)).clamp(0.0, 1.0)
        } else {
            0.5
        };
        (lo, t, c1 - c0)
    }

    /// A direction for `u ∈ [0, 1)²` in the map's frame, and its solid-angle density.
    pub fn sample(&self, u: [f32; 2]) -> (Vec3, f32) {
        let (w, h) = (self.width as usize, self.height as usize);
        let (y, ty, py) = self.find(h, h, u[1]);
        let (x, tx, px) = self.find(y, w, u[0]);
        let uv = [(x as f32 + tx) / w as f32, (y as f32 + ty) / h as f32];
        let d = uv_to_direction(uv[0], uv[1]);
        let p_uv = py * h as f32 * px * w as f32;
        (d, p_uv / solid_angle_jacobian(d))
    }

    /// The solid-angle density of direction `d` (map frame, unit length).
    pub fn pdf(&self, d: Vec3) -> f32 {
        let (w, h) = (self.width as usize, self.height as usize);
        let (u, v) = direction_to_uv(d);
        let x = ((u * w as f32) as usize).min(w - 1);
        let y = ((v * h as f32) as usize).min(h - 1);
        let py = self.at(y + 1, h) - self.at(y, h);
        let px = self.at(x + 1, y) - self.at(x, y);
        py * h as f32 * px * w as f32 / solid_angle_jacobian(d)
    }
}

/// dω / (du dv) = 2π² sin θ at direction `d` (sin θ from `d.y`, as the shader computes it).
fn solid_angle_jacobian(d: Vec3) -> f32 {
    2.0 * std::f32::consts::PI * std::f32::consts::PI * (1.0 - d.y * d.y).max(0.0).sqrt().max(1e-6)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_and_pdf_agree_and_the_pdf_integrates_to_one() {
        let map = EnvironmentMap::from_fn(64, |d| {
            let sun = if d.dot(Vec3::new(0.3, 0.8, 0.5).normalize()) > 0.995 {
                500.0
            } else {
                0.0
            };
            [0.2 + d.y.max(0.0) + sun, 0.3 + sun, 0.4]
        });
        let t = SamplingTables::new(&map);
        for k in 0..1000 {
            let u = [(k as f32 * 0.618_034) % 1.0, (k as f32 + 0.5) / 1000.0];
            let (d, p) = t.sample(u);
            let q = t.pdf(d);
            assert!((p - q).abs() <= 1e-3 * p.max(q), "{u:?}: {p} vs {q}");
        }
        let (n_u, n_v) = (512, 256);
        let mut integral = 0.0f64;
        for j in 0..n_v {
            for i in 0..n_u {
                let (u, v) = ((i as f32 + 0.5) / n_u as f32, (j as f32 + 0.5) / n_v as f32);
                let d_omega =
                    solid_angle_jacobian(uv_to_direction(u, v)) as f64 / (n_u * n_v) as f64;
                integral += t.pdf(uv_to_direction(u, v)) as f64 * d_omega;
            }
        }
        assert!((integral - 1.0).abs() < 1e-3, "{integral}");
    }
}
