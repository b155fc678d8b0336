//! URIs (data URIs, percent-encoded relative paths) and image decoding to RGBA8.

use std::io::Cursor;

use image::{ImageFormat, ImageReader, Limits};

use super::decoded::Decoded;

/// Largest image side rqr accepts (before any device limit applies).
pub const MAX_IMAGE_SIZE: u32 = 16384;

/// Splits a `data:` URI into its media type and decoded payload. `None`: not a data URI.
pub(crate) fn parse_data_uri(uri: &str) -> Option<Result<(String, Vec<u8>), String>> {
    let rest = uri.strip_prefix("data:")?;
    let Some((header, payload)) = rest.split_once(',') else {
        return Some(Err("data URI without ','".into()));
    };
    let (mime, base64) = match header.strip_suffix(";base64") {
        Some(m) => (m, true),
        None => (header, false),
    };
    let mime = mime.split(';').next().unwrap_or("").to_string();
    Some(if base64 {
        decode_base64(payload).map(|b| (mime, b))
    } else {
        Ok((mime, percent_decode(payload).into_bytes()))
    })
}

/// Standard base64 (RFC 4648, `+/`), padding optional, ASCII whitespace ignored.
pub(crate) fn decode_base64(s: &str) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(s.len() / 4 * 3);
    let mut acc: u32 = 0;
    let mut bits = 0;
    for (i, c) in s.bytes().enumerate() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            b'=' => break,
            b' ' | b'\n' | b'\r' | b'\t' => continue,
            _ => return Err(format!("invalid base64 character at offset {i}")),
        };
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Ok(out)
}

/// Decodes `%XX` escapes (relative URIs in glTF are percent-encoded); invalid escapes stay.
pub(crate) fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            let hex = std::str::from_utf8(&b[i + 1..i + 3])
                .ok()
                .and_then(|h| u8::from_str_radix(h, 16).ok());
            if let Some(v) = hex {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// PNG, JPEG or WebP (EXT_texture_webp), from the magic bytes, else from `mime`.
fn format_of(bytes: &[u8], mime: Option<&str>) -> Result<ImageFormat, String> {
    let guessed = ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| format!("cannot read: {e}"))?
        .format();
    match guessed.or_else(|| mime.and_then(ImageFormat::from_mime_type)) {
        Some(f @ (ImageFormat::Png | ImageFormat::Jpeg | ImageFormat::WebP)) => Ok(f),
        Some(f) => Err(format!(
            "{f:?} images are not supported (rqr reads PNG, JPEG, WebP and KTX2)"
        )),
        None => Err(format!(
            "not a PNG, JPEG, WebP or KTX2 image (mimeType {})",
            mime.unwrap_or("absent")
        )),
    }
}

/// Width and height from the image header, without decoding the pixels.
pub(crate) fn dimensions(bytes: &[u8], mime: Option<&str>) -> Result<(u32, u32), String> {
    if super::ktx2::is_ktx2(bytes) {
        return super::ktx2::dimensions(bytes);
    }
    ImageReader::with_format(Cursor::new(bytes), format_of(bytes, mime)?)
        .into_dimensions()
        .map_err(|e| format!("cannot decode: {e}"))
}

/// Decodes a PNG, JPEG, WebP (format from the magic bytes, else from `mime`) or KTX2 /
/// Basis Universal image to RGBA8, refusing images wider or taller than `max_size` before
/// decoding them.
pub(crate) fn decode(bytes: &[u8], mime: Option<&str>, max_size: u32) -> Result<Decoded, String> {
    if super::ktx2::is_ktx2(bytes) {
        // A full chain of the largest image, the same bound as 8-bit RGBA below.
        let budget = u64::from(max_size) * u64::from(max_size) * 8;
        let mut decoded = super::ktx2::decode(bytes, max_size, budget)?;
        decoded.ktx2 = Some(bytes.into());
        return Ok(decoded);
    }
    if mime == Some("image/ktx2") {
        return Err("KTX2 header: not a KTX2 file (wrong identifier)".into());
    }
    let format = format_of(bytes, mime)?;
    let (w, h) = ImageReader::with_format(Cursor::new(bytes), format)
        .into_dimensions()
        .map_err(|e| format!("cannot decode: {e}"))?;
    if w == 0 || h == 0 || w > max_size || h > max_size {
        return Err(format!(
            "{w}x{h} is outside rqr's 1..={max_size} pixel limit per side"
        ));
    }
    let mut reader = ImageReader::with_format(Cursor::new(bytes), format);
    let mut limits = Limits::default();
    limits.max_image_width = Some(max_size);
    limits.max_image_height = Some(max_size);
    // 16-bit RGBA at the largest size, plus decoder scratch.
    limits.max_alloc = Some(u64::from(max_size) * u64::from(max_size) * 8 + (64 << 20));
    reader.limits(limits);
    let img = reader.decode().map_err(|e| format!("cannot decode: {e}"))?;
    Ok(Decoded {
        width: w,
        height: h,
        rgba8: img.to_rgba8().into_raw(),
        mips: Vec::new(),
        ktx2: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trip() {
        assert_eq!(decode_base64("aGVsbG8=").unwrap(), b"hello");
        assert_eq!(decode_base64("aGVsbG8").unwrap(), b"hello");
        assert_eq!(decode_base64("").unwrap(), b"");
        assert!(decode_base64("aGV*").is_err());
    }

    #[test]
    fn data_uris() {
        let (mime, data) = parse_data_uri("data:application/octet-stream;base64,AAEC")
            .unwrap()
            .unwrap();
        assert_eq!(mime, "application/octet-stream");
        assert_eq!(data, vec![0, 1, 2]);
        assert!(parse_data_uri("file.bin").is_none());
        assert!(parse_data_uri("data:nocomma").unwrap().is_err());
    }

    #[test]
    fn percent() {
        assert_eq!(percent_decode("a%20b%2"), "a b%2");
        assert_eq!(percent_decode("%41%zz"), "A%zz");
    }
}
