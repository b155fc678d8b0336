//! Equirectangular HDR environment maps on the host: Radiance `.hdr` and OpenEXR files, checked
//! and cleaned before anything reaches the GPU, and the area-weighted mip chain the GPU
//! prefilters from.

use std::io::{BufReader, Read};
use std::path::Path;

use super::EnvironmentError;

/// Largest map width accepted (a 16384×8192 map is 2 GiB as RGBA32F with its mips).
pub const MAX_WIDTH: u32 = 16384;

/// A linear-radiance equirectangular map: `width == 2 * height`, row 0 at the zenith, texel
/// `(x, y)` at `u = (x + 0.5) / width`, `v = (y + 0.5) / height` (see [`super::direction_to_uv`]).
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentMap {
    /// Texels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Linear RGB radiance, row-major, row 0 = zenith.
    pub texels: Vec<[f32; 3]>,
}

impl EnvironmentMap {
    /// A map of one radiance everywhere (furnace tests, `--background`-like studios).
    pub fn constant(width: u32, radiance: [f32; 3]) -> Self {
        let height = (width / 2).max(1);
        Self {
            width: height * 2,
            height,
            texels: vec![radiance; (height * 2 * height) as usize],
        }
    }

    /// A map whose texels are `f(direction of the texel centre)`.
    pub fn from_fn(width: u32, f: impl Fn(glam::Vec3) -> [f32; 3]) -> Self {
        let height = (width / 2).max(1);
        let width = height * 2;
        let mut texels = Vec::with_capacity((width * height) as usize);
        for y in 0..height {
            for x in 0..width {
                let u = (x as f32 + 0.5) / width as f32;
                let v = (y as f32 + 0.5) / height as f32;
                texels.push(f(super::uv_to_direction(u, v)));
            }
        }
        Self {
            width,
            height,
            texels,
        }
    }

    /// Checks the shape and clamps texels that are negative, NaN or infinite to 0, returning
    /// how many were clamped.
    pub fn validate(&mut self, file: &str) -> Result<usize, EnvironmentError> {
        check_size(file, self.width, self.height)?;
        if self.texels.len() != (self.width as usize) * (self.height as usize) {
            return Err(EnvironmentError::format(
                file,
                format!(
                    "{} texels for a {}x{} map",
                    self.texels.len(),
                    self.width,
                    self.height
                ),
            ));
        }
        let mut clamped = 0;
        for t in &mut self.texels {
            for c in t.iter_mut() {
                if !(c.is_finite() && *c >= 0.0) {
                    *c = 0.0;
                    clamped += 1;
                }
            }
        }
        Ok(clamped)
    }

    /// Bytes of the map as RGBA32F with its full mip chain on the GPU.
    pub fn device_bytes(&self) -> u64 {
        mip_chain_texels(self.width, self.height) * 16
    }

    /// Bilinear lookup at `(u, v)` with the GPU sampler's conventions (u repeats, v clamps,
    /// texel centres at half-integers): the host reference for tests.
    pub fn bilinear(&self, u: f32, v: f32) -> [f32; 3] {
        let (w, h) = (self.width as i64, self.height as i64);
        let x = u * w as f32 - 0.5;
        let y = (v * h as f32 - 0.5).clamp(0.0, (h - 1) as f32);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let at = |xi: i64, yi: i64| {
            let xi = xi.rem_euclid(w);
            let yi = yi.clamp(0, h - 1);
            self.texels[(yi * w + xi) as usize]
        };
        let (x0, y0) = (x0 as i64, y0 as i64);
        let mut out = [0.0; 3];
        for (c, o) in out.iter_mut().enumerate() {
            let top = at(x0, y0)[c] * (1.0 - fx) + at(x0 + 1, y0)[c] * fx;
            let bottom = at(x0, y0 + 1)[c] * (1.0 - fx) + at(x0 + 1, y0 + 1)[c] * fx;
            *o = top * (1.0 - fy) + bottom * fy;
        }
        out
    }

    /// The mip chain down to 1×1, each level averaging 2×2 texels weighted by their rows'
    /// solid angle (sin θ), so every level integrates to the same irradiance as the map.
    /// Level 0 is the map itself; texels as RGBA (alpha 1), level after level.
    pub fn mip_chain(&self) -> Vec<Vec<[f32; 4]>> {
        let mut levels = vec![self
            .texels
            .iter()
            .map(|t| [t[0], t[1], t[2], 1.0])
            .collect::<Vec<_>>()];
        let (mut w, mut h) = (self.width, self.height);
        while w > 1 || h > 1 {
            let prev = levels.last().unwrap();
            let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
            let row_weight = |y: u32| {
                (std::f32::consts::PI * (y as f32 + 0.5) / h as f32)
                    .sin()
                    .max(1e-6)
            };
            let mut next = Vec::with_capacity((nw * nh) as usize);
            for y in 0..nh {
                for x in 0..nw {
                    let mut sum = [0.0f32; 3];
                    let mut weight = 0.0f32;
                    for dy in 0..(h / nh) {
                        let sy = y * (h / nh) + dy;
                        let wy = row_weight(sy);
                        for dx in 0..(w / nw) {
                            let sx = x * (w / nw) + dx;
                            let t = prev[(sy * w + sx) as usize];
                            for c in 0..3 {
                                sum[c] += t[c] * wy;
                            }
                            weight += wy;
                        }
                    }
                    next.push([sum[0] / weight, sum[1] / weight, sum[2] / weight, 1.0]);
                }
            }
            levels.push(next);
            (w, h) = (nw, nh);
        }
        levels
    }
}

/// Texels of a full mip chain of a `width`×`height` image.
pub fn mip_chain_texels(width: u32, height: u32) -> u64 {
    let (mut w, mut h, mut sum) = (u64::from(width), u64::from(height), 0u64);
    loop {
        sum += w * h;
        if w == 1 && h == 1 {
            return sum;
        }
        (w, h) = ((w / 2).max(1), (h / 2).max(1));
    }
}

fn check_size(file: &str, width: u32, height: u32) -> Result<(), EnvironmentError> {
    if width == 0 || height == 0 {
        return Err(EnvironmentError::format(
            file,
            format!("the map is {width}x{height}"),
        ));
    }
    if u64::from(width) != 2 * u64::from(height) {
        return Err(EnvironmentError::format(
            file,
            format!(
                "the map is {width}x{height}; an equirectangular map is twice as wide as it is high"
            ),
        ));
    }
    if width > MAX_WIDTH {
        return Err(EnvironmentError::format(
            file,
            format!(
                "the map is {width}x{height}, larger than the {MAX_WIDTH}x{} limit",
                MAX_WIDTH / 2
            ),
        ));
    }
    Ok(())
}

/// Loads a `.hdr` or `.exr` file (chosen by its first bytes, not its name), with the size
/// checked from the header before any texel is decoded. Texels that are negative, NaN or
/// infinite are clamped to 0 and counted in the second value.
pub fn load(path: &Path) -> Result<(EnvironmentMap, usize), EnvironmentError> {
    let file = path.display().to_string();
    let io = |source| EnvironmentError::Io {
        file: file.clone(),
        source,
    };
    if path.is_dir() {
        return Err(EnvironmentError::format(
            &file,
            "is a directory, not an image file",
        ));
    }
    let bytes = std::fs::read(path).map_err(io)?;
    let mut map = decode(&file, &bytes)?;
    let clamped = map.validate(&file)?;
    Ok((map, clamped))
}

/// Decodes `.hdr` or `.exr` bytes (see [`load`]); `file` names them in errors.
pub fn decode(file: &str, bytes: &[u8]) -> Result<EnvironmentMap, EnvironmentError> {
    if bytes.starts_with(b"#?") {
        decode_hdr(file, bytes)
    } else if bytes.starts_with(&EXR_MAGIC) {
        decode_exr(file, bytes)
    } else {
        Err(EnvironmentError::format(
            file,
            "not a Radiance .hdr (no \"#?\" signature) or an OpenEXR file (no magic number)",
        ))
    }
}

fn decode_hdr(file: &str, bytes: &[u8]) -> Result<EnvironmentMap, EnvironmentError> {
    let decoder = image::codecs::hdr::HdrDecoder::new(BufReader::new(bytes))
        .map_err(|e| EnvironmentError::format(file, format!("invalid Radiance header: {e}")))?;
    let meta = decoder.metadata();
    check_size(file, meta.width, meta.height)?;
    let image = image::DynamicImage::from_decoder(decoder)
        .map_err(|e| EnvironmentError::format(file, format!("invalid Radiance pixels: {e}")))?;
    into_map(file, image)
}

const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// What the OpenEXR header says about the parts rqr checks before decoding.
#[derive(Debug, Default)]
struct ExrHeader {
    compression: Option<u8>,
    channels: Vec<String>,
    data_window: Option<[i32; 4]>,
}

/// Reads the attributes of the (first part's) OpenEXR header.
fn exr_header(file: &str, bytes: &[u8]) -> Result<ExrHeader, EnvironmentError> {
    let bad = |m: &str| EnvironmentError::format(file, format!("invalid OpenEXR header: {m}"));
    let mut r = bytes.get(8..).ok_or_else(|| bad("truncated"))?;
    let mut header = ExrHeader::default();
    let cstr = |r: &mut &[u8]| -> Result<String, EnvironmentError> {
        let end = r
            .iter()
            .position(|&b| b == 0)
            .ok_or_else(|| bad("truncated"))?;
        let s = String::from_utf8_lossy(&r[..end]).into_owned();
        *r = &r[end + 1..];
        Ok(s)
    };
    loop {
        let name = cstr(&mut r)?;
        if name.is_empty() {
            return Ok(header);
        }
        let _ty = cstr(&mut r)?;
        let mut size = [0u8; 4];
        r.read_exact(&mut size).map_err(|_| bad("truncated"))?;
        let size = i32::from_le_bytes(size);
        let value = usize::try_from(size)
            .ok()
            .and_then(|n| r.get(..n))
            .ok_or_else(|| bad("truncated attribute"))?;
        match name.as_str() {
            "compression" => header.compression = value.first().copied(),
            "dataWindow" if value.len() == 16 => {
                let v = |i: usize| i32::from_le_bytes(value[i * 4..i * 4 + 4].try_into().unwrap());
                header.data_window = Some([v(0), v(1), v(2), v(3)]);
            }
            "channels" => {
                let mut c = value;
                while let Some(end) = c.iter().position(|&b| b == 0) {
                    if end == 0 {
                        break;
                    }
                    header
                        .channels
                        .push(String::from_utf8_lossy(&c[..end]).into_owned());
                    c = c.get(end + 1 + 16..).unwrap_or(&[]);
                }
            }
            _ => {}
        }
        r = &r[value.len()..];
    }
}

fn decode_exr(file: &str, bytes: &[u8]) -> Result<EnvironmentMap, EnvironmentError> {
    let header = exr_header(file, bytes)?;
    match header.compression {
        Some(8 | 9) => {
            return Err(EnvironmentError::format(
                file,
                "DWAA/DWAB-compressed OpenEXR is not supported; convert it to ZIP or PIZ \
                 (OpenImageIO: `oiiotool in.exr --compression zip -o out.exr`) or to \
                 Radiance .hdr",
            ))
        }
        Some(c) if c > 9 => {
            return Err(EnvironmentError::format(
                file,
                format!("unknown OpenEXR compression {c}"),
            ))
        }
        _ => {}
    }
    let has = |c: &str| {
        header
            .channels
            .iter()
            .any(|n| n == c || n.ends_with(&format!(".{c}")))
    };
    if !(has("R") && has("G") && has("B")) {
        return Err(EnvironmentError::format(
            file,
            format!(
                "the OpenEXR file has no R, G and B channels (it has: {})",
                if header.channels.is_empty() {
                    "none".to_string()
                } else {
                    header.channels.join(", ")
                }
            ),
        ));
    }
    if let Some([x0, y0, x1, y1]) = header.data_window {
        let w = i64::from(x1) - i64::from(x0) + 1;
        let h = i64::from(y1) - i64::from(y0) + 1;
        let (w, h) = (
            u32::try_from(w.max(0)).unwrap_or(u32::MAX),
            u32::try_from(h.max(0)).unwrap_or(u32::MAX),
        );
        check_size(file, w, h)?;
    }
    let decoder = image::codecs::openexr::OpenExrDecoder::new(std::io::Cursor::new(bytes))
        .map_err(|e| EnvironmentError::format(file, format!("invalid OpenEXR file: {e}")))?;
    let image = image::DynamicImage::from_decoder(decoder)
        .map_err(|e| EnvironmentError::format(file, format!("invalid OpenEXR pixels: {e}")))?;
    into_map(file, image)
}

fn into_map(file: &str, image: image::DynamicImage) -> Result<EnvironmentMap, EnvironmentError> {
    let rgb = image.to_rgb32f();
    let (width, height) = rgb.dimensions();
    check_size(file, width, height)?;
    let texels = rgb.pixels().map(|p| p.0).collect();
    Ok(EnvironmentMap {
        width,
        height,
        texels,
    })
}

/// Encodes `map` as a Radiance `.hdr` (run-length scanlines), for tests and tools.
pub fn encode_hdr(map: &EnvironmentMap) -> Vec<u8> {
    let mut out = Vec::new();
    let pixels: Vec<image::Rgb<f32>> = map.texels.iter().map(|t| image::Rgb(*t)).collect();
    image::codecs::hdr::HdrEncoder::new(&mut out)
        .encode(&pixels, map.width as usize, map.height as usize)
        .expect("encoding to memory cannot fail");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mips_keep_the_integral() {
        let map = EnvironmentMap::from_fn(64, |d| [d.y.max(0.0) * 3.0, 1.0, (d.x * 4.0).exp()]);
        let chain = map.mip_chain();
        assert_eq!(chain.len(), 7, "64x32 down to 1x1");
        // Level 1 weights each texel by the solid angle of its two child rows, so summing it
        // with those weights gives the map's own solid-angle sum.
        let sin = |y: u32, h: u32| (std::f64::consts::PI * (y as f64 + 0.5) / h as f64).sin();
        let mut base = 0.0;
        for y in 0..32 {
            for x in 0..64 {
                base += chain[0][(y * 64 + x) as usize][2] as f64 * sin(y, 32);
            }
        }
        let mut level1 = 0.0;
        for y in 0..16 {
            let w = sin(2 * y, 32) + sin(2 * y + 1, 32);
            for x in 0..32 {
                level1 += chain[1][(y * 32 + x) as usize][2] as f64 * w * 2.0;
            }
        }
        assert!((level1 / base - 1.0).abs() < 1e-4, "{level1} vs {base}");
    }

    #[test]
    fn hdr_round_trip_and_shape_errors() {
        let map = EnvironmentMap::from_fn(16, |d| [d.x.abs() + 0.1, d.y.abs() + 0.2, 0.5]);
        let bytes = encode_hdr(&map);
        let back = decode("t.hdr", &bytes).unwrap();
        assert_eq!((back.width, back.height), (16, 8));
        for (a, b) in back.texels.iter().zip(&map.texels) {
            for c in 0..3 {
                // RGBE: every channel shares the largest one's exponent (8-bit mantissas).
                let largest = b.iter().fold(0.0f32, |m, &v| m.max(v));
                assert!((a[c] - b[c]).abs() <= largest / 128.0, "{a:?} vs {b:?}");
            }
        }
        let square = EnvironmentMap {
            width: 8,
            height: 8,
            texels: vec![[1.0; 3]; 64],
        };
        let err = decode("sq.hdr", &encode_hdr(&square))
            .unwrap_err()
            .to_string();
        assert!(err.contains("twice as wide"), "{err}");
    }

    #[test]
    fn exr_round_trip() {
        let map = EnvironmentMap::from_fn(16, |d| [d.x.abs() * 40.0, d.y.abs(), 0.5]);
        let mut bytes = std::io::Cursor::new(Vec::new());
        let flat: Vec<f32> = map.texels.iter().flatten().copied().collect();
        image::ImageBuffer::<image::Rgb<f32>, _>::from_raw(16, 8, flat)
            .unwrap()
            .write_to(&mut bytes, image::ImageFormat::OpenExr)
            .unwrap();
        let back = decode("t.exr", bytes.get_ref()).unwrap();
        assert_eq!(back, map, "float EXR is lossless");
    }

    #[test]
    fn bad_texels_are_clamped_and_counted() {
        let mut map = EnvironmentMap::constant(8, [1.0; 3]);
        map.texels[3] = [f32::NAN, -1.0, f32::INFINITY];
        map.texels[5][1] = -0.5;
        assert_eq!(map.validate("x").unwrap(), 4);
        assert_eq!(map.texels[3], [0.0; 3]);
    }
}
