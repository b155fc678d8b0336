//! Writing images: tonemapped PNG, linear EXR and per-AOV EXRs.

use std::path::{Path, PathBuf};

use image::{ImageBuffer, Rgb, Rgba};

use crate::render::{Aov, RenderOutput};

/// Output failures (path and reason).
#[derive(Debug, thiserror::Error)]
#[error("cannot write '{path}': {reason}")]
pub struct OutputError {
    /// The file.
    pub path: PathBuf,
    /// Why.
    pub reason: String,
}

fn err(path: &Path, e: impl std::fmt::Display) -> OutputError {
    OutputError {
        path: path.to_path_buf(),
        reason: e.to_string(),
    }
}

/// AOV names accepted by `--aov`.
pub const AOV_NAMES: [&str; 6] = [
    "depth",
    "normal",
    "instance",
    "primitive",
    "barycentrics",
    "position",
];

/// Writes the tonemapped image as PNG.
pub fn write_png(path: &Path, out: &RenderOutput) -> Result<(), OutputError> {
    let img: ImageBuffer<Rgba<u8>, _> =
        ImageBuffer::from_raw(out.width, out.height, out.rgba8.clone())
            .ok_or_else(|| err(path, "pixel buffer size mismatch"))?;
    img.save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| err(path, e))
}

/// Writes the linear HDR colour as 32-bit float EXR.
pub fn write_exr(path: &Path, out: &RenderOutput) -> Result<(), OutputError> {
    let data: Vec<f32> = out
        .color
        .iter()
        .flat_map(|c| [c[0], c[1], c[2], c[3]])
        .collect();
    let img: ImageBuffer<Rgba<f32>, _> = ImageBuffer::from_raw(out.width, out.height, data)
        .ok_or_else(|| err(path, "pixel buffer size mismatch"))?;
    img.save_with_format(path, image::ImageFormat::OpenExr)
        .map_err(|e| err(path, e))
}

/// The three float channels of one AOV for a pixel (scalars repeated in R, G and B).
pub fn aov_value(a: &Aov, name: &str) -> [f32; 3] {
    match name {
        "depth" => [a.depth(); 3],
        "normal" => [a.normal_depth[0], a.normal_depth[1], a.normal_depth[2]],
        "instance" => [a.position_inst[3]; 3],
        "primitive" => [a.bary_prim[2]; 3],
        "barycentrics" => [a.bary_prim[0], a.bary_prim[1], 0.0],
        _ => [a.position_inst[0], a.position_inst[1], a.position_inst[2]],
    }
}

/// `out.png` + `depth` → `out.depth.exr`.
pub fn aov_path(base: &Path, name: &str) -> PathBuf {
    let stem = base
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    base.with_file_name(format!("{stem}.{name}.exr"))
}

/// Writes one 32-bit float EXR per requested AOV next to `base`.
pub fn write_aovs(
    base: &Path,
    out: &RenderOutput,
    names: &[String],
) -> Result<Vec<PathBuf>, OutputError> {
    let mut written = Vec::new();
    for name in names {
        let path = aov_path(base, name);
        let data: Vec<f32> = out.aov.iter().flat_map(|a| aov_value(a, name)).collect();
        let img: ImageBuffer<Rgb<f32>, _> = ImageBuffer::from_raw(out.width, out.height, data)
            .ok_or_else(|| err(&path, "AOVs were not rendered"))?;
        img.save_with_format(&path, image::ImageFormat::OpenExr)
            .map_err(|e| err(&path, e))?;
        written.push(path);
    }
    Ok(written)
}
