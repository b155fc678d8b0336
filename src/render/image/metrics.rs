//! Image comparison: NVIDIA FLIP (via `nv-flip`, the reference implementation) and PSNR/RMSE.

use serde::Serialize;

/// Differences between a reference and a test image of the same size.
#[derive(Clone, Debug, Serialize)]
pub struct ImageDiff {
    /// Mean FLIP error (0 = identical, 1 = maximal).
    pub flip_mean: f32,
    /// Median FLIP error.
    pub flip_p50: f32,
    /// 95th percentile FLIP error.
    pub flip_p95: f32,
    /// 99th percentile FLIP error.
    pub flip_p99: f32,
    /// Largest FLIP error.
    pub flip_max: f32,
    /// PSNR of the 8-bit sRGB images in dB (infinite when identical).
    pub psnr_db: f64,
    /// RMSE of the 8-bit sRGB images on a 0..1 scale.
    pub rmse: f64,
    /// FLIP error map coloured with the magma LUT, RGB8.
    #[serde(skip)]
    pub heatmap: Vec<u8>,
    /// FLIP error per pixel.
    #[serde(skip)]
    pub error_map: Vec<f32>,
}

fn rgb(rgba: &[u8]) -> Vec<u8> {
    rgba.chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect()
}

/// PSNR and RMSE of two RGB(A) 8-bit images (alpha ignored), on a 0..1 scale.
pub fn psnr_rmse(reference_rgba: &[u8], test_rgba: &[u8]) -> (f64, f64) {
    let (a, b) = (rgb(reference_rgba), rgb(test_rgba));
    let se: f64 = a
        .iter()
        .zip(&b)
        .map(|(&x, &y)| {
            let d = (f64::from(x) - f64::from(y)) / 255.0;
            d * d
        })
        .sum();
    let mse = se / a.len().max(1) as f64;
    let psnr = if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (1.0 / mse).log10()
    };
    (psnr, mse.sqrt())
}

/// Compares two RGBA8 sRGB images of `width`×`height` (panics on a size mismatch: a caller bug).
pub fn compare(width: u32, height: u32, reference_rgba: &[u8], test_rgba: &[u8]) -> ImageDiff {
    assert_eq!(reference_rgba.len(), test_rgba.len(), "image sizes differ");
    let reference = nv_flip::FlipImageRgb8::with_data(width, height, &rgb(reference_rgba));
    let test = nv_flip::FlipImageRgb8::with_data(width, height, &rgb(test_rgba));
    let error = nv_flip::flip(reference, test, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    let mut pool = nv_flip::FlipPool::from_image(&error);
    let heatmap = error.apply_color_lut(&nv_flip::magma_lut()).to_vec();
    let (psnr_db, rmse) = psnr_rmse(reference_rgba, test_rgba);
    ImageDiff {
        flip_mean: pool.mean(),
        flip_p50: pool.get_percentile(0.50, false),
        flip_p95: pool.get_percentile(0.95, false),
        flip_p99: pool.get_percentile(0.99, false),
        flip_max: pool.max_value(),
        psnr_db,
        rmse,
        heatmap,
        error_map: error.to_vec(),
    }
}

/// Mean over pixels of `f` applied to each channel pair of two linear images, clamped to
/// [0, 1] (as a display shows them: an HDR difference is dominated by a few bright pixels).
fn display_mean(a: &[[f32; 4]], b: &[[f32; 4]], f: impl Fn(f64) -> f64) -> f64 {
    let sum: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| {
            (0..3)
                .map(|c| f(f64::from(x[c].clamp(0.0, 1.0)) - f64::from(y[c].clamp(0.0, 1.0))))
                .sum::<f64>()
                / 3.0
        })
        .sum();
    sum / a.len().max(1) as f64
}

/// Mean squared error of two linear colour images clamped to [0, 1] (denoiser benchmarks and
/// tests).
pub fn display_mse(a: &[[f32; 4]], b: &[[f32; 4]]) -> f64 {
    display_mean(a, b, |d| d * d)
}

/// Mean absolute difference of two linear colour images clamped to [0, 1] (frame-to-frame
/// stability).
pub fn display_mean_abs_diff(a: &[[f32; 4]], b: &[[f32; 4]]) -> f64 {
    display_mean(a, b, f64::abs)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_errors_clamp_to_the_displayed_range() {
        let a = [[0.5, 0.5, 0.5, 1.0], [2.0, 0.0, 1.0, 1.0]];
        let b = [[1.5, 0.5, 0.0, 1.0], [1.0, 0.0, 1.0, 1.0]];
        // Pixel 0: 1.5 clamps to 1 (d 0.5), 0 against 0.5 (d 0.5); pixel 1: 2 clamps to 1.
        assert!((display_mse(&a, &b) - (0.25 + 0.25) / 3.0 / 2.0).abs() < 1e-12);
        assert!((display_mean_abs_diff(&a, &b) - 1.0 / 3.0 / 2.0).abs() < 1e-12);
        assert_eq!(display_mse(&[], &[]), 0.0);
    }

    fn checker(w: u32, h: u32, invert_at: Option<(u32, u32)>) -> Vec<u8> {
        let mut v = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let mut on = (x / 4 + y / 4) % 2 == 0;
                if invert_at == Some((x, y)) {
                    on = !on;
                }
                let c = if on { 200 } else { 30 };
                v.extend_from_slice(&[c, c, c, 255]);
            }
        }
        v
    }

    #[test]
    fn identical_images_have_zero_error() {
        let a = checker(32, 32, None);
        let d = compare(32, 32, &a, &a);
        assert_eq!(d.flip_mean, 0.0);
        assert!(d.psnr_db.is_infinite());
        assert_eq!(d.rmse, 0.0);
        assert_eq!(d.heatmap.len(), 32 * 32 * 3);
    }

    #[test]
    fn a_changed_pixel_is_found() {
        let a = checker(32, 32, None);
        let b = checker(32, 32, Some((10, 10)));
        let d = compare(32, 32, &a, &b);
        assert!(
            d.flip_mean > 0.0 && d.flip_max > 0.1,
            "mean {} max {}",
            d.flip_mean,
            d.flip_max
        );
        let worst = d
            .error_map
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .unwrap()
            .0;
        assert_eq!(worst, 10 * 32 + 10);
        assert!(d.psnr_db.is_finite() && d.psnr_db > 20.0);
    }
}
