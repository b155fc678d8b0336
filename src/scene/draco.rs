//! KHR_draco_mesh_compression: primitives whose indices and attributes are one Draco stream
//! in a buffer view. Each such primitive is decoded once, before any accessor is read, into
//! a buffer of its own; new accessors describe the decoded indices and attributes and the
//! primitive is pointed at them, so the rest of the loader reads it like any other.
//!
//! The stream's header declares its face and vertex counts; they are checked against the
//! loader's budgets ([`MAX_SCENE_TRIANGLES`], [`MAX_SCENE_VERTICES`],
//! [`MAX_DECODED_BYTES`]) before the decoder allocates anything for them.

use std::collections::BTreeMap;

use ::gltf::json as gj;
use gj::accessor::{ComponentType, GenericComponentType};
use gj::validation::{Checked, USize64};
use serde::Deserialize;

use super::accessor::{self, Buffers};
use super::error::SceneError;
use super::{MAX_SCENE_TRIANGLES, MAX_SCENE_VERTICES};

/// Name of the extension.
pub const DRACO: &str = "KHR_draco_mesh_compression";

/// Most bytes the Draco primitives of one file may decode to (the same limit as the bytes
/// the loader reads for one file, [`super::MAX_READ_BYTES`]).
pub const MAX_DECODED_BYTES: u64 = super::MAX_READ_BYTES;

/// The extension object of a primitive.
#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct DracoPrimitive {
    buffer_view: usize,
    /// glTF attribute semantic → Draco attribute unique id.
    attributes: BTreeMap<String, u64>,
}

/// What a stream's header declares, read before decoding.
#[derive(Debug, PartialEq)]
struct Declared {
    faces: u64,
    /// Vertices the connectivity decoder allocates for.
    vertices: u64,
    /// Upper bound on the points (vertices after attribute seams are split) the attributes
    /// are decoded for.
    points: u64,
}

/// Decodes every primitive with KHR_draco_mesh_compression into a new buffer appended to
/// `buffers`, adds accessors and buffer views for its data and points the primitive at
/// them.
pub(crate) fn decode_primitives(
    file: &str,
    root: &mut gj::Root,
    buffers: &mut Buffers,
) -> Result<(), SceneError> {
    let mut decoded_total = 0u64;
    for m in 0..root.meshes.len() {
        for p in 0..root.meshes[m].primitives.len() {
            let Some(ext) = root.meshes[m].primitives[p]
                .extensions
                .as_ref()
                .and_then(|e| e.others.get(DRACO))
            else {
                continue;
            };
            let element = format!("mesh {m} primitive {p}");
            let err = |msg: String| SceneError::element(file, &element, format!("{DRACO}: {msg}"));
            let dp: DracoPrimitive =
                serde_json::from_value(ext.clone()).map_err(|e| err(e.to_string()))?;
            let decoded =
                decode_primitive(root, buffers, m, p, &dp, &mut decoded_total).map_err(err)?;
            install(root, buffers, m, p, decoded);
        }
    }
    Ok(())
}

/// One decoded primitive: its bytes and, per glTF semantic (`None`: the indices), the
/// accessor that reads them.
struct Decoded {
    bytes: Vec<u8>,
    parts: Vec<(Option<String>, gj::Accessor, u64)>,
}

/// Checks and decodes primitive `p` of mesh `m`.
fn decode_primitive(
    root: &gj::Root,
    buffers: &Buffers,
    m: usize,
    p: usize,
    dp: &DracoPrimitive,
    decoded_total: &mut u64,
) -> Result<Decoded, String> {
    let prim = &root.meshes[m].primitives[p];
    let stream = view_bytes(root, buffers, dp.buffer_view)?;
    // The glTF accessor of each semantic the stream carries: its type (components) and
    // normalization are the file's; the component type is what the stream decodes to.
    let mut wanted = Vec::with_capacity(dp.attributes.len());
    let mut bytes_per_point = 0u64;
    for (semantic, &id) in &dp.attributes {
        let index = prim
            .attributes
            .iter()
            .find(|(s, _)| semantic_name(s).as_deref() == Some(semantic.as_str()))
            .map(|(_, a)| a.value())
            .ok_or_else(|| {
                format!(
                    "attribute {semantic} (Draco id {id}) is not among the primitive's attributes"
                )
            })?;
        let acc = root
            .accessors
            .get(index)
            .ok_or_else(|| format!("{semantic} accessor {index} does not exist"))?;
        let Checked::Valid(ty) = acc.type_ else {
            return Err(format!("{semantic} accessor {index} has an invalid type"));
        };
        // At most 4 bytes per component once decoded.
        bytes_per_point += 4 * accessor::type_components(ty) as u64;
        wanted.push((semantic.clone(), id, acc.clone(), ty));
    }

    let declared = declared_counts(stream)?;
    if declared.faces > MAX_SCENE_TRIANGLES as u64 {
        return Err(format!(
            "the stream declares {} faces, more than rqr's limit of {MAX_SCENE_TRIANGLES} triangles",
            declared.faces
        ));
    }
    if declared.vertices > MAX_SCENE_VERTICES as u64
        || declared.points > 3 * MAX_SCENE_VERTICES as u64
    {
        return Err(format!(
            "the stream declares {} vertices, more than rqr's limit of {MAX_SCENE_VERTICES}",
            declared.vertices.max(declared.points)
        ));
    }
    let estimate = declared.faces * 12 + declared.points * bytes_per_point;
    if estimate > MAX_DECODED_BYTES.saturating_sub(*decoded_total) {
        return Err(format!(
            "{} faces and up to {} vertices of {bytes_per_point} bytes exceed rqr's limit of {MAX_DECODED_BYTES} decoded bytes per file",
            declared.faces, declared.points
        ));
    }

    // The decoder is an alpha and pure Rust: a panic on a stream its checks missed becomes
    // this element's error rather than the process's end.
    let mesh = std::panic::catch_unwind(|| draco_oxide_decoder::decode_mesh(stream))
        .map_err(|_| {
            format!(
                "the Draco stream in buffer view {} cannot be decoded (the decoder failed)",
                dp.buffer_view
            )
        })?
        .map_err(|e| {
            format!(
                "the Draco stream in buffer view {} cannot be decoded: {e}",
                dp.buffer_view
            )
        })?;

    let faces = mesh.get_faces();
    let points = mesh.get_attributes().first().map_or(0, |a| a.len());
    let mut bytes = Vec::new();
    let mut parts = Vec::with_capacity(wanted.len() + 1);
    for face in faces {
        for &v in face {
            let v = usize::from(v);
            if v >= points {
                return Err(format!(
                    "the Draco stream's face refers to point {v} of {points}"
                ));
            }
            bytes.extend_from_slice(&(v as u32).to_le_bytes());
        }
    }
    let mut indices = prim
        .indices
        .and_then(|i| root.accessors.get(i.value()).cloned())
        .unwrap_or_else(scalar_accessor);
    indices.component_type = Checked::Valid(GenericComponentType(ComponentType::U32));
    indices.type_ = Checked::Valid(gj::accessor::Type::Scalar);
    indices.normalized = false;
    indices.min = None;
    indices.max = None;
    parts.push((None, indices, faces.len() as u64 * 3));

    for (semantic, id, mut acc, ty) in wanted {
        let attr = mesh
            .get_attributes()
            .iter()
            .find(|a| a.get_id().as_usize() as u64 == id)
            .ok_or_else(|| {
                let ids: Vec<String> = mesh
                    .get_attributes()
                    .iter()
                    .map(|a| a.get_id().as_usize().to_string())
                    .collect();
                format!(
                    "attribute {semantic} names Draco attribute id {id}, which the stream does not have (ids: {})",
                    ids.join(", ")
                )
            })?;
        let comps = accessor::type_components(ty);
        if attr.get_num_components() != comps {
            return Err(format!(
                "Draco attribute {id} ({semantic}) has {} components, its accessor {}",
                attr.get_num_components(),
                comps
            ));
        }
        if attr.len() != points {
            return Err(format!(
                "Draco attribute {id} ({semantic}) covers {} points, the stream has {points}",
                attr.len()
            ));
        }
        let component = gltf_component(attr.get_component_type()).ok_or_else(|| {
            format!(
                "Draco attribute {id} ({semantic}) decodes to {:?}, which glTF cannot store",
                attr.get_component_type()
            )
        })?;
        let elem = comps * attr.get_component_type().size();
        let values = attr.get_data_as_bytes();
        align4(&mut bytes);
        let start = bytes.len();
        for point in 0..points {
            let v = usize::from(attr.get_unique_val_idx(point.into()));
            let value = values
                .get(v * elem..(v + 1) * elem)
                .ok_or_else(|| format!("Draco attribute {id} ({semantic}) has no value {v}"))?;
            bytes.extend_from_slice(value);
        }
        debug_assert_eq!(bytes.len() - start, points * elem);
        if component == ComponentType::F32 {
            acc.normalized = false;
        }
        acc.component_type = Checked::Valid(GenericComponentType(component));
        parts.push((Some(semantic), acc, points as u64));
    }
    *decoded_total += bytes.len() as u64;
    Ok(Decoded { bytes, parts })
}

/// Appends the decoded bytes as a new buffer with one view and accessor per part, and
/// points primitive `p` of mesh `m` at them.
fn install(root: &mut gj::Root, buffers: &mut Buffers, m: usize, p: usize, decoded: Decoded) {
    let buffer = buffers.data.len();
    let mut offset = 0u64;
    let mut new_accessors = Vec::with_capacity(decoded.parts.len());
    for (semantic, mut acc, count) in decoded.parts {
        let elem = accessor_elem_size(&acc);
        offset = offset.next_multiple_of(4);
        let length = count * elem;
        root.buffer_views.push(gj::buffer::View {
            buffer: gj::Index::new(buffer as u32),
            byte_length: USize64(length),
            byte_offset: Some(USize64(offset)),
            byte_stride: None,
            name: None,
            target: None,
            extensions: None,
            extras: Default::default(),
        });
        offset += length;
        acc.buffer_view = Some(gj::Index::new(root.buffer_views.len() as u32 - 1));
        acc.byte_offset = None;
        acc.count = USize64(count);
        acc.sparse = None;
        root.accessors.push(acc);
        new_accessors.push((semantic, gj::Index::new(root.accessors.len() as u32 - 1)));
    }
    buffers.data.push(decoded.bytes);
    let prim = &mut root.meshes[m].primitives[p];
    for (semantic, index) in new_accessors {
        match semantic {
            None => prim.indices = Some(index),
            Some(name) => {
                if let Some((_, a)) = prim
                    .attributes
                    .iter_mut()
                    .find(|(s, _)| semantic_name(s).as_deref() == Some(name.as_str()))
                {
                    *a = index;
                }
            }
        }
    }
    if let Some(e) = prim.extensions.as_mut() {
        e.others.remove(DRACO);
    }
}

/// Bytes of one element of an accessor built by [`decode_primitive`].
fn accessor_elem_size(acc: &gj::Accessor) -> u64 {
    let comps = match acc.type_ {
        Checked::Valid(t) => accessor::type_components(t),
        Checked::Invalid => 1,
    };
    let size = match acc.component_type {
        Checked::Valid(GenericComponentType(ComponentType::I8 | ComponentType::U8)) => 1,
        Checked::Valid(GenericComponentType(ComponentType::I16 | ComponentType::U16)) => 2,
        _ => 4,
    };
    (comps * size) as u64
}

fn align4(bytes: &mut Vec<u8>) {
    bytes.resize(bytes.len().next_multiple_of(4), 0);
}

/// An empty SCALAR accessor, for a Draco primitive without `indices` in the glTF.
fn scalar_accessor() -> gj::Accessor {
    gj::Accessor {
        buffer_view: None,
        byte_offset: None,
        count: USize64(0),
        component_type: Checked::Valid(GenericComponentType(ComponentType::U32)),
        extensions: None,
        extras: Default::default(),
        type_: Checked::Valid(gj::accessor::Type::Scalar),
        min: None,
        max: None,
        name: None,
        normalized: false,
        sparse: None,
    }
}

/// The glTF spelling of an attribute semantic (`POSITION`, `TEXCOORD_1`, `_CUSTOM`).
fn semantic_name(s: &Checked<gj::mesh::Semantic>) -> Option<String> {
    match s {
        Checked::Valid(s) => Some(s.to_string()),
        Checked::Invalid => None,
    }
}

/// The glTF component type of a decoded Draco component type.
fn gltf_component(t: draco_oxide_core::attribute::ComponentDataType) -> Option<ComponentType> {
    use draco_oxide_core::attribute::ComponentDataType as C;
    Some(match t {
        C::F32 => ComponentType::F32,
        C::U8 => ComponentType::U8,
        C::I8 => ComponentType::I8,
        C::U16 => ComponentType::U16,
        C::I16 => ComponentType::I16,
        C::U32 => ComponentType::U32,
        _ => return None,
    })
}

/// The bytes of buffer view `v`.
fn view_bytes<'a>(root: &gj::Root, buffers: &'a Buffers, v: usize) -> Result<&'a [u8], String> {
    let view = root
        .buffer_views
        .get(v)
        .ok_or_else(|| format!("buffer view {v} does not exist"))?;
    let b = view.buffer.value();
    let data = buffers
        .data
        .get(b)
        .ok_or_else(|| format!("buffer view {v}: buffer {b} does not exist"))?;
    let start = view.byte_offset.map_or(0, |o| o.0);
    start
        .checked_add(view.byte_length.0)
        .filter(|&end| end <= data.len() as u64)
        .map(|end| &data[start as usize..end as usize])
        .ok_or_else(|| {
            format!(
                "buffer view {v}: bytes {start}..+{} are outside buffer {b} ({} bytes)",
                view.byte_length.0,
                data.len()
            )
        })
}

/// A little-endian reader over a stream's header that fails on truncation.
struct HeaderReader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl HeaderReader<'_> {
    fn u8(&mut self) -> Result<u8, String> {
        let b = *self
            .bytes
            .get(self.at)
            .ok_or_else(|| format!("the Draco stream is truncated ({} bytes)", self.bytes.len()))?;
        self.at += 1;
        Ok(b)
    }

    fn skip(&mut self, n: u64) -> Result<(), String> {
        let end = (self.at as u64).saturating_add(n);
        if end > self.bytes.len() as u64 {
            return Err(format!(
                "the Draco stream is truncated ({} bytes)",
                self.bytes.len()
            ));
        }
        self.at = end as usize;
        Ok(())
    }

    /// An unsigned LEB128 varint of at most 64 bits.
    fn varint(&mut self) -> Result<u64, String> {
        let mut value = 0u64;
        for shift in (0..64).step_by(7) {
            let b = self.u8()?;
            value |= u64::from(b & 0x7f) << shift;
            if b & 0x80 == 0 {
                return Ok(value);
            }
        }
        Err("the Draco stream has a varint longer than 64 bits".into())
    }

    /// Skips one metadata block (entries, then nested blocks), as the Draco decoder reads it.
    fn skip_metadata(&mut self, depth: usize) -> Result<(), String> {
        if depth > 32 {
            return Err("the Draco stream's metadata is nested too deeply".into());
        }
        for _ in 0..self.varint()? {
            let name = self.u8()?;
            self.skip(u64::from(name))?;
            let size = self.varint()?;
            self.skip(size)?;
        }
        for _ in 0..self.varint()? {
            let name = self.u8()?;
            self.skip(u64::from(name))?;
            self.skip_metadata(depth + 1)?;
        }
        Ok(())
    }
}

/// Reads the counts a Draco mesh stream (bitstream 2.2) declares, without decoding it.
fn declared_counts(bytes: &[u8]) -> Result<Declared, String> {
    let mut r = HeaderReader { bytes, at: 0 };
    if bytes.len() < 11 || &bytes[..5] != b"DRACO" {
        return Err(format!(
            "the buffer view does not hold a Draco stream ({} bytes, no DRACO header)",
            bytes.len()
        ));
    }
    r.skip(5)?;
    let (major, minor) = (r.u8()?, r.u8()?);
    if (major, minor) != (2, 2) {
        return Err(format!(
            "Draco bitstream {major}.{minor} is not supported (only 2.2, written by Draco 1.3 and later)"
        ));
    }
    let geometry = r.u8()?;
    if geometry != 1 {
        return Err(format!(
            "the Draco stream holds geometry type {geometry}, not a triangle mesh"
        ));
    }
    let method = r.u8()?;
    let flags = u16::from(r.u8()?) | u16::from(r.u8()?) << 8;
    if flags & 0x8000 != 0 {
        for _ in 0..r.varint()? {
            r.varint()?;
            r.skip_metadata(0)?;
        }
        r.skip_metadata(0)?;
    }
    match method {
        // Sequential: face and point counts.
        0 => {
            let faces = r.varint()?;
            let points = r.varint()?;
            Ok(Declared {
                faces,
                vertices: points,
                points,
            })
        }
        // Edgebreaker: traversal type, encoded vertices, faces, attribute data count,
        // symbols, split symbols.
        1 => {
            r.u8()?;
            let encoded_vertices = r.varint()?;
            let faces = r.varint()?;
            r.u8()?;
            r.varint()?;
            let splits = r.varint()?;
            Ok(Declared {
                faces,
                vertices: encoded_vertices.saturating_add(splits),
                // Seams split vertices into at most one point per corner.
                points: faces.saturating_mul(3),
            })
        }
        other => Err(format!("unknown Draco encoder method {other}")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_counts_are_read_without_decoding() {
        // Edgebreaker stream: 1000 encoded vertices, 2000 faces, 7 split symbols.
        let mut s = b"DRACO\x02\x02\x01\x01\x00\x00".to_vec();
        s.extend_from_slice(&[0, 0xe8, 0x07, 0xd0, 0x0f, 1, 5, 7]);
        assert_eq!(
            declared_counts(&s).unwrap(),
            Declared {
                faces: 2000,
                vertices: 1007,
                points: 6000
            }
        );
        assert!(declared_counts(&s[..14]).unwrap_err().contains("truncated"));
        let mut old = s.clone();
        old[6] = 1;
        assert!(declared_counts(&old).unwrap_err().contains("bitstream 2.1"));
    }
}
