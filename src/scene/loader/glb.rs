//! The GLB container: header and chunks.

/// Splits a GLB container into its JSON chunk and optional BIN chunk.
pub(super) fn split_glb(bytes: &[u8]) -> Result<(&[u8], Option<&[u8]>), String> {
    let u32_at = |o: usize| -> Option<u32> {
        bytes
            .get(o..o + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let (Some(version), Some(length)) = (u32_at(4), u32_at(8)) else {
        return Err(format!(
            "truncated GLB: {} bytes, shorter than the 12-byte header",
            bytes.len()
        ));
    };
    if version != 2 {
        return Err(format!("GLB version {version} is not supported (only 2)"));
    }
    let length = length as usize;
    if length > bytes.len() {
        return Err(format!(
            "truncated GLB: header says {length} bytes, file has {}",
            bytes.len()
        ));
    }
    if length < 20 {
        return Err(format!(
            "malformed GLB: length {length} leaves no JSON chunk"
        ));
    }
    let mut offset = 12;
    let mut json = None;
    let mut bin = None;
    while offset + 8 <= length {
        let (Some(chunk_len), Some(kind)) = (u32_at(offset), u32_at(offset + 4)) else {
            break;
        };
        let start = offset + 8;
        let end = start
            .checked_add(chunk_len as usize)
            .filter(|&e| e <= length)
            .ok_or_else(|| {
                format!(
                    "truncated GLB: chunk at offset {offset} claims {chunk_len} bytes, only {} remain",
                    length - start
                )
            })?;
        let data = &bytes[start..end];
        match &kind.to_le_bytes() {
            b"JSON" if json.is_none() && offset == 12 => json = Some(data),
            b"JSON" => return Err("malformed GLB: unexpected second JSON chunk".into()),
            b"BIN\0" if json.is_some() && bin.is_none() => bin = Some(data),
            b"BIN\0" => return Err("malformed GLB: misplaced BIN chunk".into()),
            _ if offset == 12 => return Err("malformed GLB: the first chunk is not JSON".into()),
            // Unknown chunks after the JSON chunk are allowed and ignored.
            _ => {}
        }
        // Chunks are 4-byte aligned; a misaligned length is tolerated.
        offset = end.div_ceil(4) * 4;
    }
    let json = json.ok_or_else(|| "malformed GLB: no JSON chunk".to_string())?;
    Ok((json, bin))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glb_split_rejects_truncation() {
        assert!(split_glb(b"glTF").unwrap_err().contains("truncated"));
        let mut glb = Vec::new();
        glb.extend_from_slice(b"glTF");
        glb.extend_from_slice(&2u32.to_le_bytes());
        glb.extend_from_slice(&40u32.to_le_bytes());
        glb.extend_from_slice(&100u32.to_le_bytes());
        glb.extend_from_slice(b"JSON");
        glb.resize(40, b' ');
        assert!(split_glb(&glb).unwrap_err().contains("claims 100 bytes"));
    }
}
