//! KHR_texture_basisu: KTX2 images holding Basis Universal texels (ETC1S with BasisLZ, or
//! UASTC raw or Zstandard-supercompressed), transcoded to RGBA8 with the file's mip levels.
//!
//! The container is checked first (the `ktx2` crate, plus the level index against the file
//! size and rqr's budgets), so a broken file is refused with the reason before any
//! transcoding allocates; the `basisu` crate (a pure-Rust port of the reference transcoder)
//! then transcodes each level. [`transcode_blocks`] transcodes a file the loader accepted again,
//! to BC7 or ASTC 4x4 blocks, when the device samples one of them (`textures.rs`).

use super::decoded::Decoded;

/// The 12-byte KTX2 file identifier.
pub(crate) const KTX2_MAGIC: [u8; 12] = [
    0xAB, b'K', b'T', b'X', b' ', b'2', b'0', 0xBB, b'\r', b'\n', 0x1A, b'\n',
];

/// KTX2 header size; the level index follows it.
const HEADER_LEN: usize = 80;
/// One level index entry: byte offset, byte length, uncompressed byte length (u64 each).
const LEVEL_INDEX_LEN: usize = 24;
/// Data Format Descriptor colour models of Basis Universal.
const MODEL_ETC1S: u8 = 163;
const MODEL_UASTC: u8 = 166;
/// Supercompression schemes rqr transcodes: none, BasisLZ (ETC1S), Zstandard (UASTC).
const SCHEME_NONE: u32 = 0;
const SCHEME_BASISLZ: u32 = 1;
const SCHEME_ZSTD: u32 = 2;

/// Whether `bytes` starts with the KTX2 identifier.
pub(crate) fn is_ktx2(bytes: &[u8]) -> bool {
    bytes.starts_with(&KTX2_MAGIC)
}

fn u32_at(b: &[u8], o: usize) -> u32 {
    u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
}

fn u64_at(b: &[u8], o: usize) -> u64 {
    u64::from(u32_at(b, o)) | (u64::from(u32_at(b, o + 4)) << 32)
}

/// Width and height from the KTX2 header, without decoding.
pub(crate) fn dimensions(bytes: &[u8]) -> Result<(u32, u32), String> {
    if !is_ktx2(bytes) {
        return Err("KTX2 header: not a KTX2 file (wrong identifier)".into());
    }
    if bytes.len() < HEADER_LEN {
        return Err(format!(
            "KTX2 header: file is {} bytes, shorter than the {HEADER_LEN}-byte header",
            bytes.len()
        ));
    }
    Ok((u32_at(bytes, 20), u32_at(bytes, 24)))
}

/// The level index, checked against the file: every level's bytes lie inside it.
fn level_ranges(bytes: &[u8], levels: usize) -> Result<Vec<(u64, u64, u64)>, String> {
    let index_end = HEADER_LEN + levels * LEVEL_INDEX_LEN;
    if index_end > bytes.len() {
        return Err(format!(
            "KTX2 level index: {levels} levels need {index_end} bytes, the file has {}",
            bytes.len()
        ));
    }
    (0..levels)
        .map(|i| {
            let o = HEADER_LEN + i * LEVEL_INDEX_LEN;
            let (offset, length, uncompressed) =
                (u64_at(bytes, o), u64_at(bytes, o + 8), u64_at(bytes, o + 16));
            match offset.checked_add(length) {
                Some(end) if end <= bytes.len() as u64 => Ok((offset, length, uncompressed)),
                _ => Err(format!(
                    "KTX2 level {i}: bytes {offset}..+{length} lie beyond the end of the file ({} bytes)",
                    bytes.len()
                )),
            }
        })
        .collect()
}

/// Decodes a KTX2 / Basis Universal image to RGBA8 with every mip level the file stores.
/// Refuses sides outside `1..=max_size`, and output larger than `max_decoded_bytes` (all
/// levels together) before allocating it.
pub(crate) fn decode(
    bytes: &[u8],
    max_size: u32,
    max_decoded_bytes: u64,
) -> Result<Decoded, String> {
    let (width, height) = dimensions(bytes)?;
    let stored_levels = u32_at(bytes, 40).max(1);
    // At most a full chain (so at most 32 levels): bounds the level index read below.
    let full_chain = 32 - width.max(height).max(1).leading_zeros();
    if stored_levels > full_chain {
        return Err(format!(
            "KTX2 header: {stored_levels} mip levels for {width}x{height} (a full chain has {full_chain})"
        ));
    }
    let ranges = level_ranges(bytes, stored_levels as usize)?;
    let reader = ::ktx2::Reader::new(bytes).map_err(|e| format!("KTX2 header: {e}"))?;
    let header = reader.header();
    if header.pixel_depth != 0 || header.layer_count > 1 || header.face_count != 1 {
        return Err(format!(
            "KTX2 header: only 2D textures are supported (depth {}, layers {}, faces {})",
            header.pixel_depth, header.layer_count, header.face_count
        ));
    }
    if width == 0 || height == 0 || width > max_size || height > max_size {
        return Err(format!(
            "{width}x{height} is outside rqr's 1..={max_size} pixel limit per side"
        ));
    }
    if let Some(f) = header.format {
        return Err(format!(
            "KTX2 vkFormat {f:?}: KHR_texture_basisu needs Basis Universal data (vkFormat UNDEFINED)"
        ));
    }
    let scheme = u32_at(bytes, 44);
    let model = reader
        .color_model()
        .map(|m| m.value())
        .ok_or("KTX2 data format descriptor: no basic block with a colour model")?;
    let uastc = match (model, scheme) {
        (MODEL_ETC1S, SCHEME_BASISLZ) => false,
        (MODEL_UASTC, SCHEME_NONE | SCHEME_ZSTD) => true,
        (MODEL_ETC1S | MODEL_UASTC, s) => {
            return Err(format!(
                "KTX2 supercompression scheme {s} is not supported for {} (rqr handles BasisLZ for ETC1S, none or Zstandard for UASTC)",
                if model == MODEL_UASTC { "UASTC" } else { "ETC1S" }
            ))
        }
        (m, _) => {
            return Err(format!(
                "KTX2 colour model {m} is not Basis Universal (ETC1S 163 or UASTC 166)"
            ))
        }
    };
    let mut total: u64 = 0;
    for (level, &(_, length, uncompressed)) in ranges.iter().enumerate() {
        let (w, h) = ((width >> level).max(1), (height >> level).max(1));
        total += u64::from(w) * u64::from(h) * 4;
        if uastc {
            // 16-byte 4x4 blocks; Zstandard levels record their decompressed size, which
            // must be exactly that (it bounds what the decompressor allocates).
            let blocks = u64::from(w.div_ceil(4)) * u64::from(h.div_ceil(4)) * 16;
            let stored = if scheme == SCHEME_ZSTD {
                uncompressed
            } else {
                length
            };
            if stored != blocks {
                return Err(format!(
                    "KTX2 level {level}: {stored} bytes of UASTC data for {w}x{h} (expected {blocks})"
                ));
            }
        }
    }
    if total > max_decoded_bytes {
        return Err(format!(
            "KTX2: {total} bytes of decoded RGBA8 exceed rqr's limit of {max_decoded_bytes}"
        ));
    }
    let transcoder =
        basisu::Transcoder::new(bytes).map_err(|e| format!("KTX2 Basis Universal data: {e:?}"))?;
    if transcoder.level_count() != stored_levels {
        return Err(format!(
            "KTX2 Basis Universal data: {} levels, the header says {stored_levels}",
            transcoder.level_count()
        ));
    }
    let mut levels = Vec::with_capacity(stored_levels as usize);
    for level in 0..stored_levels {
        let rgba = transcoder
            .transcode(
                level,
                basisu::TargetFormat::Rgba32,
                basisu::DecodeFlags::NONE,
            )
            .map_err(|e| format!("KTX2 level {level}: cannot transcode: {e:?}"))?;
        let (w, h) = ((width >> level).max(1), (height >> level).max(1));
        if rgba.len() as u64 != u64::from(w) * u64::from(h) * 4 {
            return Err(format!(
                "KTX2 level {level}: transcoded {} bytes for {w}x{h}",
                rgba.len()
            ));
        }
        levels.push(rgba);
    }
    let mut levels = levels.into_iter();
    let rgba8 = levels.next().unwrap_or_default();
    Ok(Decoded {
        width,
        height,
        rgba8,
        mips: levels.collect(),
        ktx2: None,
    })
}

/// A 4x4-block format with 16-byte blocks that Basis Universal transcodes to and GPUs sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum BlockTarget {
    /// BC7 RGBA (desktop GPUs, lavapipe).
    Bc7,
    /// ASTC 4x4 LDR RGBA (mobile GPUs).
    Astc4x4,
}

impl BlockTarget {
    /// The format's name in messages.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Self::Bc7 => "BC7",
            Self::Astc4x4 => "ASTC 4x4",
        }
    }

    fn basisu(self) -> basisu::TargetFormat {
        match self {
            Self::Bc7 => basisu::TargetFormat::Bc7Rgba,
            Self::Astc4x4 => basisu::TargetFormat::Astc4x4Rgba,
        }
    }
}

/// Bytes of one 4x4 block of a [`BlockTarget`].
pub(crate) const BLOCK_BYTES: u64 = 16;

/// Bytes of a `width` x `height` level in 4x4 blocks of 16 bytes (a level smaller than a
/// block still takes a whole block).
pub(crate) fn block_level_bytes(width: u32, height: u32) -> u64 {
    u64::from(width.div_ceil(4)) * u64::from(height.div_ceil(4)) * BLOCK_BYTES
}

/// Transcodes every level of the KTX2 file `bytes` to `target` blocks: level `l` holds
/// [`block_level_bytes`] of `max(1, width >> l)` x `max(1, height >> l)`. The file must
/// be `width` x `height` with `levels` levels, as the loader recorded it.
pub(crate) fn transcode_blocks(
    bytes: &[u8],
    target: BlockTarget,
    (width, height): (u32, u32),
    levels: u32,
) -> Result<Vec<Vec<u8>>, String> {
    let name = target.name();
    let transcoder =
        basisu::Transcoder::new(bytes).map_err(|e| format!("KTX2 Basis Universal data: {e:?}"))?;
    if transcoder.base_dimensions() != (width, height) || transcoder.level_count() != levels {
        let (w, h) = transcoder.base_dimensions();
        return Err(format!(
            "KTX2 data is {w}x{h} with {} levels, the loaded image {width}x{height} with {levels}",
            transcoder.level_count()
        ));
    }
    if !transcoder.supports(target.basisu()) {
        return Err(format!(
            "KTX2 {:?} data cannot be transcoded to {name}",
            transcoder.source_format()
        ));
    }
    (0..levels)
        .map(|level| {
            let blocks = transcoder
                .transcode(level, target.basisu(), basisu::DecodeFlags::NONE)
                .map_err(|e| format!("KTX2 level {level}: cannot transcode to {name}: {e:?}"))?;
            let (w, h) = ((width >> level).max(1), (height >> level).max(1));
            let expected = block_level_bytes(w, h);
            if blocks.len() as u64 != expected {
                return Err(format!(
                    "KTX2 level {level}: transcoded {} bytes of {name} for {w}x{h} (expected {expected})",
                    blocks.len()
                ));
            }
            Ok(blocks)
        })
        .collect()
}
