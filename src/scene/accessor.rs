//! Reading glTF accessors (strided, sparse, normalized or quantized) with every offset and
//! length checked against the buffers first, so malformed files produce errors, not panics.

use gj::accessor::{ComponentType, Type};
use gj::validation::Checked;
use gltf::json as gj;

/// Upper bound on an accessor's element count. A count is otherwise only bounded by the
/// buffer it reads (a file).
pub(crate) const MAX_ACCESSOR_COUNT: u64 = 1 << 27;

/// Upper bound for accessors without a buffer view (zeros plus sparse values): nothing in
/// the file backs their size, so this cap alone keeps their allocation sane.
pub(crate) const MAX_UNBACKED_COUNT: u64 = 1 << 24;

/// The resolved bytes of every glTF buffer, indexed like `root.buffers`.
pub(crate) struct Buffers {
    pub(crate) data: Vec<Vec<u8>>,
}

/// Bytes per component.
fn component_size(ct: ComponentType) -> usize {
    match ct {
        ComponentType::I8 | ComponentType::U8 => 1,
        ComponentType::I16 | ComponentType::U16 => 2,
        ComponentType::U32 | ComponentType::F32 => 4,
    }
}

/// Components per element.
pub(crate) fn type_components(t: Type) -> usize {
    match t {
        Type::Scalar => 1,
        Type::Vec2 => 2,
        Type::Vec3 => 3,
        Type::Vec4 | Type::Mat2 => 4,
        Type::Mat3 => 9,
        Type::Mat4 => 16,
    }
}

/// Name of a component type for messages.
pub(crate) fn component_name(ct: ComponentType) -> &'static str {
    match ct {
        ComponentType::I8 => "BYTE",
        ComponentType::U8 => "UNSIGNED_BYTE",
        ComponentType::I16 => "SHORT",
        ComponentType::U16 => "UNSIGNED_SHORT",
        ComponentType::U32 => "UNSIGNED_INT",
        ComponentType::F32 => "FLOAT",
    }
}

/// One accessor's elements, converted per component.
pub(crate) struct Elements<T> {
    /// Components per element.
    pub comps: usize,
    /// `count * comps` values.
    pub values: Vec<T>,
}

impl<T: Copy> Elements<T> {
    /// Number of elements.
    pub fn count(&self) -> usize {
        self.values.len().checked_div(self.comps).unwrap_or(0)
    }
}

/// A checked view into a buffer: `len` bytes starting at `offset`, elements `stride` apart.
struct Span<'a> {
    bytes: &'a [u8],
    stride: usize,
}

/// Resolves buffer view `view_index` and checks that `count` elements of `elem` bytes,
/// starting `extra_offset` bytes into it, fit in the view and the view in its buffer.
fn span<'a>(
    root: &gj::Root,
    buffers: &'a Buffers,
    view_index: usize,
    extra_offset: u64,
    count: u64,
    elem: usize,
    allow_stride: bool,
) -> Result<Span<'a>, String> {
    let view = root.buffer_views.get(view_index).ok_or_else(|| {
        format!(
            "buffer view {view_index} does not exist ({} buffer views)",
            root.buffer_views.len()
        )
    })?;
    let buffer_index = view.buffer.value();
    let buffer = buffers.data.get(buffer_index).ok_or_else(|| {
        format!(
            "buffer view {view_index}: buffer {buffer_index} does not exist ({} buffers)",
            buffers.data.len()
        )
    })?;
    let view_offset = view.byte_offset.map_or(0, |o| o.0);
    let view_len = view.byte_length.0;
    let view_end = view_offset
        .checked_add(view_len)
        .filter(|&end| end <= buffer.len() as u64)
        .ok_or_else(|| {
            format!(
                "buffer view {view_index} (offset {view_offset}, length {view_len}) exceeds buffer {buffer_index} ({} bytes)",
                buffer.len()
            )
        })?;
    let stride = match view.byte_stride {
        Some(s) if allow_stride => {
            if s.0 < elem {
                return Err(format!(
                    "buffer view {view_index}: byteStride {} is smaller than the {elem}-byte element",
                    s.0
                ));
            }
            s.0
        }
        _ => elem,
    };
    if extra_offset > view_len {
        return Err(format!(
            "offset {extra_offset} is past the end of buffer view {view_index} ({view_len} bytes)"
        ));
    }
    if count > 0 {
        // Only the last element needs to end inside the view; strides past it do not.
        let needed = (count - 1)
            .checked_mul(stride as u64)
            .and_then(|n| n.checked_add(elem as u64))
            .and_then(|n| n.checked_add(extra_offset));
        match needed {
            Some(n) if n <= view_len => {}
            _ => {
                return Err(format!(
                    "buffer view {view_index} is {view_len} bytes but {count} elements of {elem} bytes (stride {stride}) at offset {extra_offset} need {}",
                    needed.map_or_else(|| "more than 2^64".to_string(), |n| n.to_string())
                ))
            }
        }
    }
    let start = (view_offset + extra_offset) as usize;
    Ok(Span {
        bytes: &buffer[start..view_end as usize],
        stride,
    })
}

fn checked_type(acc: &gj::Accessor) -> Result<(ComponentType, Type), String> {
    let ct = match acc.component_type {
        Checked::Valid(gj::accessor::GenericComponentType(ct)) => ct,
        Checked::Invalid => return Err("invalid componentType".into()),
    };
    let ty = match acc.type_ {
        Checked::Valid(t) => t,
        Checked::Invalid => return Err("invalid type".into()),
    };
    Ok((ct, ty))
}

/// Reads accessor `index`, converting each component with `decode` (which gets the
/// component's little-endian bytes).
fn read<T: Copy + Default>(
    root: &gj::Root,
    buffers: &Buffers,
    index: usize,
    decode: impl Fn(&[u8]) -> T,
) -> Result<Elements<T>, String> {
    let acc = root
        .accessors
        .get(index)
        .ok_or_else(|| format!("does not exist ({} accessors)", root.accessors.len()))?;
    let (ct, ty) = checked_type(acc)?;
    // MAT4 of FLOAT (inverse bind matrices) has no column padding; other matrices may.
    let unpadded = ty == Type::Mat4 && ct == ComponentType::F32;
    if matches!(ty, Type::Mat2 | Type::Mat3 | Type::Mat4) && !unpadded {
        return Err("matrix accessors are only supported as MAT4 of FLOAT".into());
    }
    let comps = type_components(ty);
    let csize = component_size(ct);
    let elem = comps * csize;
    let count = acc.count.0;
    if count > MAX_ACCESSOR_COUNT {
        return Err(format!(
            "count {count} exceeds rqr's limit of {MAX_ACCESSOR_COUNT} elements"
        ));
    }
    if acc.buffer_view.is_none() && count > MAX_UNBACKED_COUNT {
        return Err(format!(
            "count {count} without a buffer view exceeds rqr's limit of {MAX_UNBACKED_COUNT} elements"
        ));
    }
    let count_us = count as usize;
    let mut values = Vec::with_capacity(count_us * comps);
    match acc.buffer_view {
        Some(view) => {
            let offset = acc.byte_offset.map_or(0, |o| o.0);
            let s = span(root, buffers, view.value(), offset, count, elem, true)?;
            for i in 0..count_us {
                let e = &s.bytes[i * s.stride..i * s.stride + elem];
                for c in 0..comps {
                    values.push(decode(&e[c * csize..(c + 1) * csize]));
                }
            }
        }
        None => values.resize(count_us * comps, T::default()),
    }
    if let Some(sparse) = &acc.sparse {
        let n = sparse.count.0;
        if n > count {
            return Err(format!(
                "sparse count {n} exceeds the accessor count {count}"
            ));
        }
        let ict = match sparse.indices.component_type {
            Checked::Valid(gj::accessor::IndexComponentType(ct)) => ct,
            Checked::Invalid => return Err("sparse indices: invalid componentType".into()),
        };
        let isize = component_size(ict);
        let is = span(
            root,
            buffers,
            sparse.indices.buffer_view.value(),
            sparse.indices.byte_offset.0,
            n,
            isize,
            false,
        )
        .map_err(|e| format!("sparse indices: {e}"))?;
        let vs = span(
            root,
            buffers,
            sparse.values.buffer_view.value(),
            sparse.values.byte_offset.0,
            n,
            elem,
            false,
        )
        .map_err(|e| format!("sparse values: {e}"))?;
        for k in 0..n as usize {
            let target = read_uint(&is.bytes[k * isize..(k + 1) * isize], ict) as usize;
            if target >= count_us {
                return Err(format!(
                    "sparse index {target} out of range ({count} elements)"
                ));
            }
            let e = &vs.bytes[k * elem..(k + 1) * elem];
            for c in 0..comps {
                values[target * comps + c] = decode(&e[c * csize..(c + 1) * csize]);
            }
        }
    }
    Ok(Elements { comps, values })
}

fn read_uint(b: &[u8], ct: ComponentType) -> u32 {
    match ct {
        ComponentType::I8 | ComponentType::U8 => u32::from(b[0]),
        ComponentType::I16 | ComponentType::U16 => u32::from(u16::from_le_bytes([b[0], b[1]])),
        ComponentType::U32 | ComponentType::F32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
    }
}

/// Reads an accessor as f32 components. Normalized integers map to [0, 1] / [-1, 1] as the
/// glTF spec defines (`max(c / 127, -1)` etc.); other integers convert to their value.
pub(crate) fn read_f32(
    root: &gj::Root,
    buffers: &Buffers,
    index: usize,
) -> Result<Elements<f32>, String> {
    let acc = root
        .accessors
        .get(index)
        .ok_or_else(|| format!("does not exist ({} accessors)", root.accessors.len()))?;
    let (ct, _) = checked_type(acc)?;
    let n = acc.normalized;
    match ct {
        ComponentType::F32 => read(root, buffers, index, |b| {
            f32::from_le_bytes([b[0], b[1], b[2], b[3]])
        }),
        ComponentType::I8 => read(root, buffers, index, |b| {
            let v = f32::from(b[0] as i8);
            if n {
                (v / 127.0).max(-1.0)
            } else {
                v
            }
        }),
        ComponentType::U8 => read(root, buffers, index, |b| {
            let v = f32::from(b[0]);
            if n {
                v / 255.0
            } else {
                v
            }
        }),
        ComponentType::I16 => read(root, buffers, index, |b| {
            let v = f32::from(i16::from_le_bytes([b[0], b[1]]));
            if n {
                (v / 32767.0).max(-1.0)
            } else {
                v
            }
        }),
        ComponentType::U16 => read(root, buffers, index, |b| {
            let v = f32::from(u16::from_le_bytes([b[0], b[1]]));
            if n {
                v / 65535.0
            } else {
                v
            }
        }),
        ComponentType::U32 => read(root, buffers, index, |b| {
            let v = u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32;
            if n {
                v / u32::MAX as f32
            } else {
                v
            }
        }),
    }
}

/// Reads an index accessor (SCALAR of UNSIGNED_BYTE / SHORT / INT).
pub(crate) fn read_indices(
    root: &gj::Root,
    buffers: &Buffers,
    index: usize,
) -> Result<Vec<u32>, String> {
    let acc = root
        .accessors
        .get(index)
        .ok_or_else(|| format!("does not exist ({} accessors)", root.accessors.len()))?;
    let (ct, ty) = checked_type(acc)?;
    if ty != Type::Scalar {
        return Err("indices must be SCALAR".into());
    }
    if !matches!(
        ct,
        ComponentType::U8 | ComponentType::U16 | ComponentType::U32
    ) {
        return Err(format!(
            "indices must be UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT, not {}",
            component_name(ct)
        ));
    }
    Ok(read(root, buffers, index, |b| read_uint(b, ct))?.values)
}
