//! Writing images: tonemapped PNG, linear EXR or PFM colour, and per-AOV EXR or PFM files.
//!
//! PFM (the portable float map) is what Intel Open Image Denoise's `oidnDenoise` reads; EXR is
//! what everything else reads. Both hold the same 32-bit floats.

use std::io::Write;
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

/// AOV names accepted by `--aov` and batch manifests.
pub const AOV_NAMES: [&str; 8] = [
    "depth",
    "normal",
    "geometric_normal",
    "albedo",
    "instance",
    "primitive",
    "barycentrics",
    "position",
];

/// Float image formats of the linear colour and the AOVs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FloatFormat {
    /// OpenEXR, 32-bit float, uncompressed.
    Exr,
    /// Portable float map (`PF`, little-endian, rows bottom to top): `oidnDenoise`'s input.
    Pfm,
}

impl FloatFormat {
    /// The file extension (without the dot).
    pub fn extension(self) -> &'static str {
        match self {
            FloatFormat::Exr => "exr",
            FloatFormat::Pfm => "pfm",
        }
    }
}

/// Writes the tonemapped image as PNG.
pub fn write_png(path: &Path, out: &RenderOutput) -> Result<(), OutputError> {
    let img: ImageBuffer<Rgba<u8>, _> =
        ImageBuffer::from_raw(out.width, out.height, out.rgba8.clone())
            .ok_or_else(|| err(path, "pixel buffer size mismatch"))?;
    img.save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| err(path, e))
}

/// Writes the linear HDR colour as 32-bit float EXR (RGBA).
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

/// Writes the linear HDR colour (RGB) as PFM.
pub fn write_color_pfm(path: &Path, out: &RenderOutput) -> Result<(), OutputError> {
    let rgb: Vec<f32> = out.color.iter().flat_map(|c| [c[0], c[1], c[2]]).collect();
    write_pfm(path, out.width, out.height, &rgb)
}

/// Writes `rgb` (3 floats per pixel, rows top to bottom) as a colour PFM: header `PF`, the
/// size, scale -1 (little-endian), then the rows bottom to top as the format orders them.
pub fn write_pfm(path: &Path, width: u32, height: u32, rgb: &[f32]) -> Result<(), OutputError> {
    let row = width as usize * 3;
    if rgb.len() != row * height as usize {
        return Err(err(path, "pixel buffer size mismatch"));
    }
    let mut bytes = format!("PF\n{width} {height}\n-1.0\n").into_bytes();
    bytes.reserve(rgb.len() * 4);
    for line in rgb.chunks_exact(row.max(1)).rev() {
        for v in line {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    let mut file = std::fs::File::create(path).map_err(|e| err(path, e))?;
    file.write_all(&bytes).map_err(|e| err(path, e))
}

/// The three float channels of one AOV for a pixel (scalars repeated in R, G and B; ids as
/// floats, -1 on a miss: exact below 2^24, for images; the integer ids are in [`Aov`]).
pub fn aov_value(a: &Aov, name: &str) -> [f32; 3] {
    match name {
        "depth" => [a.depth(); 3],
        "normal" => a.shading_normal().to_array(),
        "geometric_normal" => a.geometric_normal().to_array(),
        "albedo" => a.albedo_rgb().to_array(),
        "instance" => [a.instance() as f32; 3],
        "primitive" => [a.primitive() as f32; 3],
        "barycentrics" => [a.bary[0], a.bary[1], 0.0],
        _ => a.world_position().to_array(),
    }
}

/// `out.png` + `depth` → `out.depth.exr` (or `.pfm` with [`FloatFormat::Pfm`]).
pub fn aov_path(base: &Path, name: &str, format: FloatFormat) -> PathBuf {
    let stem = base
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    base.with_file_name(format!("{stem}.{name}.{}", format.extension()))
}

/// Writes one 32-bit float RGB image of AOV `name` to `path`.
pub fn write_aov(
    path: &Path,
    out: &RenderOutput,
    name: &str,
    format: FloatFormat,
) -> Result<(), OutputError> {
    let data: Vec<f32> = out.aov.iter().flat_map(|a| aov_value(a, name)).collect();
    if data.len() != out.width as usize * out.height as usize * 3 {
        return Err(err(path, "AOVs were not rendered"));
    }
    match format {
        FloatFormat::Pfm => write_pfm(path, out.width, out.height, &data),
        FloatFormat::Exr => {
            let img: ImageBuffer<Rgb<f32>, _> = ImageBuffer::from_raw(out.width, out.height, data)
                .ok_or_else(|| err(path, "pixel buffer size mismatch"))?;
            img.save_with_format(path, image::ImageFormat::OpenExr)
                .map_err(|e| err(path, e))
        }
    }
}

/// Writes one 32-bit float file per requested AOV next to `base`, in `format`.
pub fn write_aovs(
    base: &Path,
    out: &RenderOutput,
    names: &[String],
    format: FloatFormat,
) -> Result<Vec<PathBuf>, OutputError> {
    let mut written = Vec::new();
    for name in names {
        let path = aov_path(base, name, format);
        write_aov(&path, out, name, format)?;
        written.push(path);
    }
    Ok(written)
}

/// Reads a colour PFM (`PF`, either byte order) back: (width, height, RGB rows top to bottom).
/// For tests and tools that check what [`write_pfm`] wrote.
pub fn read_pfm(path: &Path) -> Result<(u32, u32, Vec<f32>), OutputError> {
    let bytes = std::fs::read(path).map_err(|e| err(path, e))?;
    // Four whitespace-separated header tokens (magic, width, height, scale), one whitespace
    // byte, then the data.
    let mut tokens = Vec::with_capacity(4);
    let mut at = 0;
    while tokens.len() < 4 {
        while bytes.get(at).is_some_and(|b| b.is_ascii_whitespace()) {
            at += 1;
        }
        let start = at;
        while bytes.get(at).is_some_and(|b| !b.is_ascii_whitespace()) {
            at += 1;
        }
        if start == at {
            return Err(err(path, "truncated PFM header"));
        }
        tokens.push(String::from_utf8_lossy(&bytes[start..at]).into_owned());
    }
    at += 1;
    if tokens[0] != "PF" {
        return Err(err(
            path,
            format!("not a colour PFM (magic '{}')", tokens[0]),
        ));
    }
    let number = |t: &str| {
        t.parse::<u32>()
            .map_err(|_| err(path, format!("bad PFM size '{t}'")))
    };
    let (width, height) = (number(&tokens[1])?, number(&tokens[2])?);
    let scale: f32 = tokens[3]
        .parse()
        .map_err(|_| err(path, format!("bad PFM scale '{}'", tokens[3])))?;
    let row = width as usize * 3;
    let n = row * height as usize;
    let data = bytes
        .get(at..at + n * 4)
        .ok_or_else(|| err(path, "truncated PFM data"))?;
    let floats: Vec<f32> = data
        .chunks_exact(4)
        .map(|b| {
            let b = [b[0], b[1], b[2], b[3]];
            if scale < 0.0 {
                f32::from_le_bytes(b)
            } else {
                f32::from_be_bytes(b)
            }
        })
        .collect();
    let rgb = floats
        .chunks_exact(row.max(1))
        .rev()
        .flatten()
        .copied()
        .collect();
    Ok((width, height, rgb))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("rqr-output-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir.join(name)
    }

    #[test]
    fn pfm_has_the_header_oidn_reads_and_rows_bottom_to_top() {
        // 2x2: top row (0, 1, 2) (3, 4, 5), bottom row (6, 7, 8) (9, 10, 11).
        let rgb: Vec<f32> = (0..12).map(|v| v as f32).collect();
        let path = tmp("order.pfm");
        write_pfm(&path, 2, 2, &rgb).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let header = b"PF\n2 2\n-1.0\n";
        assert_eq!(&bytes[..header.len()], header);
        assert_eq!(bytes.len(), header.len() + 12 * 4);
        // The first stored row is the image's bottom row.
        let first = f32::from_le_bytes(bytes[header.len()..header.len() + 4].try_into().unwrap());
        assert_eq!(first, 6.0);
        let (w, h, back) = read_pfm(&path).unwrap();
        assert_eq!((w, h), (2, 2));
        assert_eq!(back, rgb);
    }

    #[test]
    fn pfm_round_trips_floats_exactly_and_rejects_bad_files() {
        let rgb = [1.5e-8, -0.75, 3.4e38, 0.1, f32::MIN_POSITIVE, 65504.0];
        let path = tmp("exact.pfm");
        write_pfm(&path, 2, 1, &rgb).unwrap();
        assert_eq!(read_pfm(&path).unwrap().2, rgb);
        assert!(write_pfm(&path, 3, 1, &rgb)
            .unwrap_err()
            .to_string()
            .contains("size mismatch"));
        std::fs::write(&path, b"Pf\n1 1\n-1.0\n\0\0\0\0").unwrap();
        assert!(read_pfm(&path)
            .unwrap_err()
            .to_string()
            .contains("not a colour PFM"));
        std::fs::write(&path, b"PF\n4 4\n-1.0\n\0\0\0\0").unwrap();
        assert!(read_pfm(&path)
            .unwrap_err()
            .to_string()
            .contains("truncated"));
    }

    #[test]
    fn aov_files_take_the_output_format_extension() {
        let base = Path::new("/x/frame.pfm");
        assert_eq!(
            aov_path(base, "albedo", FloatFormat::Pfm),
            Path::new("/x/frame.albedo.pfm")
        );
        assert_eq!(
            aov_path(Path::new("/x/frame.png"), "normal", FloatFormat::Exr),
            Path::new("/x/frame.normal.exr")
        );
    }

    #[test]
    fn aov_values_read_the_record_fields() {
        let a = Aov {
            normal_depth: [0.0, 1.0, 0.0, 2.5],
            geometric_samples: [0.0, 0.0, 1.0, 4.0],
            position: [1.0, 2.0, 3.0, 0.0],
            albedo: [0.2, 0.4, 0.6, 1.0],
            bary: [0.25, 0.5],
            instance: 7,
            primitive: 9,
        };
        assert_eq!(aov_value(&a, "depth"), [2.5; 3]);
        assert_eq!(aov_value(&a, "normal"), [0.0, 1.0, 0.0]);
        assert_eq!(aov_value(&a, "geometric_normal"), [0.0, 0.0, 1.0]);
        assert_eq!(aov_value(&a, "albedo"), [0.2, 0.4, 0.6]);
        assert_eq!(aov_value(&a, "instance"), [7.0; 3]);
        assert_eq!(aov_value(&a, "primitive"), [9.0; 3]);
        assert_eq!(aov_value(&a, "barycentrics"), [0.25, 0.5, 0.0]);
        assert_eq!(aov_value(&a, "position"), [1.0, 2.0, 3.0]);
        let miss = Aov {
            instance: crate::interface::AOV_NO_ID,
            primitive: crate::interface::AOV_NO_ID,
            ..Default::default()
        };
        assert_eq!(aov_value(&miss, "instance"), [-1.0; 3]);
        assert_eq!(aov_value(&miss, "primitive"), [-1.0; 3]);
        // Every documented name has its own arm (position is the fallback arm).
        for name in AOV_NAMES {
            let v = aov_value(&a, name);
            assert!(name == "position" || v != [1.0, 2.0, 3.0], "{name}");
        }
    }
}
