//! Helpers for scene tests: crafting small glTF / GLB files in memory, and reading the
//! copied sample models under `assets/gltf/`.

use std::path::{Path, PathBuf};

use serde_json::{json, Value};

/// `assets/gltf/<rel>`.
pub fn asset(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets/gltf")
        .join(rel)
}

/// Loads the sample model `assets/gltf/<rel>`, panicking with the loader's message.
pub fn load_asset(rel: &str) -> rqr::scene::Scene {
    rqr::scene::load(&asset(rel), &rqr::scene::LoadOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
}

/// One row of `assets/gltf/INDEX.tsv` (a copy of the sample models' index).
pub struct IndexRow {
    pub name: String,
    pub main_file: String,
    pub tris_unique: usize,
    pub tris_instanced: usize,
}

pub fn index_rows() -> Vec<IndexRow> {
    let text = std::fs::read_to_string(asset("INDEX.tsv")).expect("assets/gltf/INDEX.tsv");
    text.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            IndexRow {
                name: f[0].to_string(),
                main_file: f[1].to_string(),
                tris_unique: f[3].parse().unwrap(),
                tris_instanced: f[4].parse().unwrap(),
            }
        })
        .collect()
}

pub fn base64(data: &[u8]) -> String {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in data.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(T[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// Builds one binary buffer with views and accessors, then a glTF document around it.
#[derive(Default)]
pub struct Builder {
    pub bin: Vec<u8>,
    pub views: Vec<Value>,
    pub accessors: Vec<Value>,
}

impl Builder {
    /// Appends bytes as a new buffer view (4-byte aligned); returns its index.
    pub fn view(&mut self, bytes: &[u8]) -> usize {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()}));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    pub fn accessor(&mut self, acc: Value) -> usize {
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    /// A FLOAT accessor of `ty` (VEC2/VEC3/VEC4); VEC3 ones get min/max.
    pub fn floats(&mut self, data: &[f32], ty: &str) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let comps = match ty {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            _ => 4,
        };
        let v = self.view(&bytes);
        let mut acc = json!({"bufferView": v, "componentType": 5126, "count": data.len() / comps, "type": ty});
        if comps == 3 {
            let mut min = [f32::INFINITY; 3];
            let mut max = [f32::NEG_INFINITY; 3];
            for p in data.chunks(3) {
                for k in 0..3 {
                    min[k] = min[k].min(p[k]);
                    max[k] = max[k].max(p[k]);
                }
            }
            acc["min"] = json!(min);
            acc["max"] = json!(max);
        }
        self.accessor(acc)
    }

    /// An UNSIGNED_SHORT index accessor.
    pub fn indices_u16(&mut self, data: &[u16]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let v = self.view(&bytes);
        self.accessor(
            json!({"bufferView": v, "componentType": 5123, "count": data.len(), "type": "SCALAR"}),
        )
    }

    /// The full document: `doc` supplies meshes/nodes/scenes/...; buffers, views and
    /// accessors come from the builder (buffer 0 as a data URI).
    pub fn document(&self, mut doc: Value) -> Value {
        doc["asset"] = json!({"version": "2.0"});
        doc["buffers"] = json!([{
            "byteLength": self.bin.len(),
            "uri": format!("data:application/octet-stream;base64,{}", base64(&self.bin)),
        }]);
        doc["bufferViews"] = json!(self.views);
        doc["accessors"] = json!(self.accessors);
        doc
    }

    /// The same as a GLB: buffer 0 is the BIN chunk.
    pub fn glb(&self, mut doc: Value) -> Vec<u8> {
        doc["asset"] = json!({"version": "2.0"});
        doc["buffers"] = json!([{"byteLength": self.bin.len()}]);
        doc["bufferViews"] = json!(self.views);
        doc["accessors"] = json!(self.accessors);
        glb(&serde_json::to_vec(&doc).unwrap(), Some(&self.bin))
    }
}

/// Assembles a GLB container.
pub fn glb(json: &[u8], bin: Option<&[u8]>) -> Vec<u8> {
    let pad = |v: &mut Vec<u8>, b: u8| {
        while v.len() % 4 != 0 {
            v.push(b);
        }
    };
    let mut j = json.to_vec();
    pad(&mut j, b' ');
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    if let Some(bin) = bin {
        let mut b = bin.to_vec();
        pad(&mut b, 0);
        out.extend_from_slice(&(b.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&b);
    }
    let len = out.len() as u32;
    out[8..12].copy_from_slice(&len.to_le_bytes());
    out
}

/// A unit quad in the XY plane (4 vertices, 2 triangles) as one mesh/node/scene, with the
/// given extra primitive fields (e.g. "mode", "material") merged in.
pub fn quad_doc(b: &mut Builder, prim_extra: Value) -> Value {
    let pos = b.floats(
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0],
        "VEC3",
    );
    let idx = b.indices_u16(&[0, 1, 2, 0, 2, 3]);
    let mut prim = json!({"attributes": {"POSITION": pos}, "indices": idx});
    if let Value::Object(extra) = prim_extra {
        for (k, v) in extra {
            prim[k] = v;
        }
    }
    json!({
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [prim]}],
    })
}

/// Serialises a JSON document.
pub fn bytes(doc: &Value) -> Vec<u8> {
    serde_json::to_vec(doc).unwrap()
}

/// A tiny PNG (RGBA8) with the given pixels.
pub fn png(width: u32, height: u32, rgba: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    image::RgbaImage::from_raw(width, height, rgba.to_vec())
        .unwrap()
        .write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)
        .unwrap();
    out
}

/// Decodes what [`base64`] encodes.
pub fn unbase64(s: &str) -> Vec<u8> {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = Vec::new();
    let (mut acc, mut bits) = (0u32, 0);
    for c in s.bytes().take_while(|&c| c != b'=') {
        acc = (acc << 6) | T.iter().position(|&t| t == c).unwrap() as u32;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    out
}

/// A PNG whose header claims `width` x `height`, with an empty pixel stream (decoders
/// notice the missing pixels only after reading the header).
pub fn png_header(width: u32, height: u32) -> Vec<u8> {
    fn crc32(data: &[u8]) -> u32 {
        let mut c = 0xFFFF_FFFFu32;
        for &b in data {
            c ^= u32::from(b);
            for _ in 0..8 {
                c = if c & 1 != 0 {
                    0xEDB8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
            }
        }
        !c
    }
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut chunk = |kind: &[u8], data: &[u8]| {
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let mut body = kind.to_vec();
        body.extend_from_slice(data);
        out.extend_from_slice(&body);
        out.extend_from_slice(&crc32(&body).to_be_bytes());
    };
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&width.to_be_bytes());
    ihdr.extend_from_slice(&height.to_be_bytes());
    ihdr.extend_from_slice(&[8, 6, 0, 0, 0]);
    chunk(b"IHDR", &ihdr);
    chunk(b"IDAT", &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01]);
    chunk(b"IEND", &[]);
    out
}

/// A quad with three materials (white default, red, green) and variants "Red" and "Green"
/// mapping to them; `mapping_variants` is the Green mapping's variant list.
pub fn variants_quad(mapping_variants: serde_json::Value) -> Vec<u8> {
    let mut b = Builder::default();
    let mut doc = quad_doc(
        &mut b,
        json!({"material": 0, "extensions": {"KHR_materials_variants": {"mappings": [
            {"material": 1, "variants": [0]},
            {"material": 2, "variants": mapping_variants},
        ]}}}),
    );
    let colour = |c: [f32; 4]| json!({"pbrMetallicRoughness": {"baseColorFactor": c}});
    doc["materials"] = json!([
        colour([1.0, 1.0, 1.0, 1.0]),
        colour([1.0, 0.0, 0.0, 1.0]),
        colour([0.0, 1.0, 0.0, 1.0]),
    ]);
    doc["extensionsUsed"] = json!(["KHR_materials_variants"]);
    doc["extensions"] =
        json!({"KHR_materials_variants": {"variants": [{"name": "Red"}, {"name": "Green"}]}});
    bytes(&b.document(doc))
}

/// Loads `doc` as `variants.gltf` with `variant` chosen; the error as text.
pub fn load_variant(doc: &[u8], variant: Option<&str>) -> Result<rqr::scene::Scene, String> {
    let opts = rqr::scene::LoadOptions {
        variant: variant.map(str::to_string),
        ..Default::default()
    };
    rqr::scene::load_slice(doc, None, "variants.gltf", &opts).map_err(|e| e.to_string())
}
