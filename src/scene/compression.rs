//! EXT_meshopt_compression: buffer views whose bytes are meshoptimizer-encoded in another
//! buffer. Each such view is decoded once, before any accessor reads it, into a buffer of
//! its own, and the view is pointed there; accessors then read it like any other view.
//!
//! Every parameter is checked before the `meshopt` crate's decoders (meshoptimizer's C++)
//! see it: they assert on sizes they do not support, and the decoded size (count × stride)
//! is checked against [`MAX_DECODED_BYTES`] and the file's other buffers before allocating.

use ::gltf::json as gj;
use serde::Deserialize;

use super::accessor::Buffers;
use super::error::SceneError;

/// Name of the extension.
pub const MESHOPT: &str = "EXT_meshopt_compression";

/// Most bytes all meshopt views of one file may decode to (the loader's limit on the bytes
/// it reads for one file, [`super::MAX_READ_BYTES`], applies to encoded and decoded bytes
/// alike).
pub const MAX_DECODED_BYTES: u64 = super::MAX_READ_BYTES;

/// The extension object of a buffer view.
#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct MeshoptView {
    buffer: usize,
    #[serde(default)]
    byte_offset: u64,
    byte_length: u64,
    byte_stride: u64,
    count: u64,
    mode: String,
    #[serde(default)]
    filter: Option<String>,
}

/// Whether buffer `b` is a meshopt fallback buffer (no data of its own is needed: every view
/// into it is decoded from another buffer).
pub(crate) fn is_fallback(b: &gj::Buffer) -> bool {
    b.extensions
        .as_ref()
        .and_then(|e| e.others.get(MESHOPT))
        .and_then(|m| m.get("fallback"))
        .and_then(serde_json::Value::as_bool)
        .unwrap_or(false)
}

/// Decodes every buffer view with EXT_meshopt_compression into a new buffer appended to
/// `buffers` and points the view at it.
pub(crate) fn decode_views(
    file: &str,
    root: &mut gj::Root,
    buffers: &mut Buffers,
) -> Result<(), SceneError> {
    let mut decoded_total = 0u64;
    for v in 0..root.buffer_views.len() {
        let Some(ext) = root.buffer_views[v]
            .extensions
            .as_ref()
            .and_then(|e| e.others.get(MESHOPT))
        else {
            continue;
        };
        let element = format!("buffer view {v}");
        let err = |m: String| SceneError::element(file, &element, format!("{MESHOPT}: {m}"));
        let mv: MeshoptView =
            serde_json::from_value(ext.clone()).map_err(|e| err(e.to_string()))?;
        let size = mv
            .count
            .checked_mul(mv.byte_stride)
            .filter(|&n| n <= MAX_DECODED_BYTES.saturating_sub(decoded_total))
            .ok_or_else(|| {
                err(format!(
                    "{} elements of {} bytes exceed rqr's limit of {MAX_DECODED_BYTES} decoded bytes per file",
                    mv.count, mv.byte_stride
                ))
            })?;
        let source = buffers
            .data
            .get(mv.buffer)
            .ok_or_else(|| err(format!("buffer {} does not exist", mv.buffer)))?;
        let encoded = mv
            .byte_offset
            .checked_add(mv.byte_length)
            .filter(|&end| end <= source.len() as u64)
            .map(|end| &source[mv.byte_offset as usize..end as usize])
            .ok_or_else(|| {
                err(format!(
                    "bytes {}..+{} are outside buffer {} ({} bytes)",
                    mv.byte_offset,
                    mv.byte_length,
                    mv.buffer,
                    source.len()
                ))
            })?;
        let out = decode(&mv, encoded, size as usize).map_err(err)?;
        decoded_total += size;
        buffers.data.push(out);
        let view = &mut root.buffer_views[v];
        view.buffer = gj::Index::new((buffers.data.len() - 1) as u32);
        view.byte_offset = None;
        view.byte_length = gj::validation::USize64(size);
        if mv.mode == "ATTRIBUTES" {
            view.byte_stride = Some(gj::buffer::Stride(mv.byte_stride as usize));
        }
    }
    Ok(())
}

/// Decodes one view: checks mode, filter and stride, then runs meshoptimizer.
fn decode(mv: &MeshoptView, encoded: &[u8], size: usize) -> Result<Vec<u8>, String> {
    let count = mv.count as usize;
    let stride = mv.byte_stride as usize;
    let filter = mv.filter.as_deref().unwrap_or("NONE");
    // Words, so that the filters' 16- and 32-bit accesses are aligned.
    let mut words = vec![0u32; size.div_ceil(4)];
    let out: &mut [u8] = &mut bytemuck::cast_slice_mut(&mut words)[..size];
    let code = match mv.mode.as_str() {
        "ATTRIBUTES" => {
            if stride == 0 || stride > 256 || stride % 4 != 0 {
                return Err(format!(
                    "byteStride {stride} of ATTRIBUTES must be a multiple of 4 in 4..=256"
                ));
            }
            match (filter, stride) {
                ("NONE", _) | ("OCTAHEDRAL", 4 | 8) | ("QUATERNION", 8) | ("EXPONENTIAL", _) => {}
                ("OCTAHEDRAL" | "QUATERNION", _) => {
                    return Err(format!(
                        "filter {filter} does not allow byteStride {stride}"
                    ))
                }
                (other, _) => return Err(format!("unknown filter '{other}'")),
            }
            // SAFETY: `out` holds count × stride bytes, the size meshoptimizer writes for
            // `count` vertices of `stride` bytes; `encoded` is a valid slice. The decoder
            // validates the encoded bytes itself (it is documented as safe on untrusted
            // input) and the stride was checked above against what it asserts.
            unsafe {
                meshopt::ffi::meshopt_decodeVertexBuffer(
                    out.as_mut_ptr().cast(),
                    count,
                    stride,
                    encoded.as_ptr(),
                    encoded.len(),
                )
            }
        }
        "TRIANGLES" | "INDICES" => {
            if filter != "NONE" {
                return Err(format!(
                    "filter {filter} is not allowed with mode {}",
                    mv.mode
                ));
            }
            if stride != 2 && stride != 4 {
                return Err(format!("byteStride {stride} of {} must be 2 or 4", mv.mode));
            }
            if mv.mode == "TRIANGLES" && count % 3 != 0 {
                return Err(format!("count {count} of TRIANGLES is not a multiple of 3"));
            }
            let decoder = if mv.mode == "TRIANGLES" {
                meshopt::ffi::meshopt_decodeIndexBuffer
            } else {
                meshopt::ffi::meshopt_decodeIndexSequence
            };
            // SAFETY: as above; `out` holds count indices of `stride` (2 or 4) bytes.
            unsafe {
                decoder(
                    out.as_mut_ptr().cast(),
                    count,
                    stride,
                    encoded.as_ptr(),
                    encoded.len(),
                )
            }
        }
        other => return Err(format!("unknown mode '{other}'")),
    };
    if code != 0 {
        return Err(format!(
            "the {} data cannot be decoded (meshoptimizer error {code})",
            mv.mode
        ));
    }
    let filter_fn = match filter {
        "OCTAHEDRAL" => meshopt::ffi::meshopt_decodeFilterOct,
        "QUATERNION" => meshopt::ffi::meshopt_decodeFilterQuat,
        "EXPONENTIAL" => meshopt::ffi::meshopt_decodeFilterExp,
        _ => return Ok(out.to_vec()),
    };
    // SAFETY: `out` holds `count` elements of `stride` bytes, 4-byte aligned, and the stride
    // is one the filter accepts (checked above); filters work in place.
    unsafe { filter_fn(out.as_mut_ptr().cast(), count, stride) };
    Ok(out.to_vec())
}
