//! KTX2 files for the tests: Basis Universal data from the reference encoder (the
//! `basis-universal` crate writes `.basis` files) rewrapped into the KTX2 container that
//! KHR_texture_basisu requires, so a test can encode the texels it also keeps uncompressed.

use basis_universal::{BasisTextureFormat, ColorSpace, Compressor, CompressorParams};
use rqr::scene::{self, LoadOptions, Scene};
use rqr::vk::{vk, Context};
use serde_json::{json, Value};

use super::scene_files::{base64, quad_doc, Builder};

/// The 12-byte KTX2 identifier.
pub const MAGIC: [u8; 12] = [
    0xAB, b'K', b'T', b'X', b' ', b'2', b'0', 0xBB, b'\r', b'\n', 0x1A, b'\n',
];

fn rd(b: &[u8], o: usize, n: usize) -> u64 {
    (0..n).fold(0u64, |acc, i| acc | (u64::from(b[o + i]) << (8 * i)))
}

/// One slice of a `.basis` file: level, alpha flag, byte range.
struct Slice {
    level: u32,
    alpha: bool,
    offset: usize,
    size: usize,
}

/// Encodes `rgba` (width × height, 4 channels) with Basis Universal, mipmapped, as ETC1S
/// (`uastc` false) or UASTC, and returns the KTX2 file (BasisLZ for ETC1S, no
/// supercompression for UASTC).
pub fn encode(rgba: &[u8], width: u32, height: u32, uastc: bool, srgb: bool) -> Vec<u8> {
    encode_with(rgba, width, height, uastc, srgb, true)
}

/// [`encode`], with or without the mip chain (`mipmaps` false: level 0 alone).
pub fn encode_with(
    rgba: &[u8],
    width: u32,
    height: u32,
    uastc: bool,
    srgb: bool,
    mipmaps: bool,
) -> Vec<u8> {
    let mut params = CompressorParams::new();
    params.set_basis_format(if uastc {
        BasisTextureFormat::UASTC4x4
    } else {
        BasisTextureFormat::ETC1S
    });
    params.set_generate_mipmaps(mipmaps);
    params.set_color_space(if srgb {
        ColorSpace::Srgb
    } else {
        ColorSpace::Linear
    });
    params.set_print_status_to_stdout(false);
    params.source_image_mut(0).init(rgba, width, height, 4);
    let mut compressor = Compressor::new(2);
    // SAFETY: the parameters come from the crate's setters (format, mipmaps, colour space, one
    // 4-channel image of width*height texels); `params` outlives `init` and `process`.
    unsafe {
        assert!(compressor.init(&params), "basisu init");
        compressor.process().expect("basisu encode");
    }
    basis_to_ktx2(compressor.basis_file(), width, height, srgb)
}

/// Rewraps a single-image `.basis` file (ETC1S or UASTC) as KTX2.
pub fn basis_to_ktx2(basis: &[u8], width: u32, height: u32, srgb: bool) -> Vec<u8> {
    assert_eq!(rd(basis, 0, 2), 0x4273, ".basis signature");
    assert_eq!(rd(basis, 4, 2), 77, ".basis header size");
    let total_slices = rd(basis, 14, 3) as usize;
    let uastc = basis[20] == 1;
    let slice_desc = rd(basis, 65, 4) as usize;
    let slices: Vec<Slice> = (0..total_slices)
        .map(|i| {
            let s = slice_desc + i * 23;
            Slice {
                level: u32::from(basis[s + 3]),
                alpha: basis[s + 4] & 1 != 0,
                offset: rd(basis, s + 13, 4) as usize,
                size: rd(basis, s + 17, 4) as usize,
            }
        })
        .collect();
    let levels = slices.iter().map(|s| s.level + 1).max().unwrap();
    let has_alpha = slices.iter().any(|s| s.alpha);
    // Per level: its bytes (ETC1S: rgb slice then alpha slice) and the alpha slice's offset.
    let mut level_data: Vec<(Vec<u8>, usize, usize, usize)> = Vec::new();
    for l in 0..levels {
        let rgb = slices.iter().find(|s| s.level == l && !s.alpha).unwrap();
        let mut data = basis[rgb.offset..rgb.offset + rgb.size].to_vec();
        let (mut a_off, mut a_len) = (0, 0);
        if let Some(a) = slices.iter().find(|s| s.level == l && s.alpha) {
            a_off = data.len();
            a_len = a.size;
            data.extend_from_slice(&basis[a.offset..a.offset + a.size]);
        }
        level_data.push((data, rgb.size, a_off, a_len));
    }
    // Supercompression global data (BasisLZ): counts, sizes, one image descriptor per level,
    // then the codebooks and Huffman tables as the .basis file stores them.
    let mut sgd = Vec::new();
    if !uastc {
        let ep = (rd(basis, 41, 4) as usize, rd(basis, 45, 3) as usize);
        let sel = (rd(basis, 50, 4) as usize, rd(basis, 54, 3) as usize);
        let tables = (rd(basis, 57, 4) as usize, rd(basis, 61, 4) as usize);
        sgd.extend_from_slice(&(rd(basis, 39, 2) as u16).to_le_bytes());
        sgd.extend_from_slice(&(rd(basis, 48, 2) as u16).to_le_bytes());
        for len in [ep.1, sel.1, tables.1, 0] {
            sgd.extend_from_slice(&(len as u32).to_le_bytes());
        }
        for (_, rgb_len, a_off, a_len) in &level_data {
            for v in [0, 0, *rgb_len, *a_off, *a_len] {
                sgd.extend_from_slice(&(v as u32).to_le_bytes());
            }
        }
        for (o, n) in [ep, sel, tables] {
            sgd.extend_from_slice(&basis[o..o + n]);
        }
    }
    let dfd = dfd(uastc, has_alpha, srgb);
    let index_end = 80 + 24 * levels as usize;
    let dfd_offset = index_end;
    let mut sgd_offset = dfd_offset + dfd.len();
    sgd_offset = sgd_offset.next_multiple_of(8);
    let mut data_start = sgd_offset + sgd.len();
    // Levels are stored smallest first; each 16-byte aligned (UASTC's block size).
    let mut offsets = vec![0usize; levels as usize];
    for l in (0..levels as usize).rev() {
        data_start = data_start.next_multiple_of(16);
        offsets[l] = data_start;
        data_start += level_data[l].0.len();
    }
    let mut out = vec![0u8; data_start];
    out[..12].copy_from_slice(&MAGIC);
    let scheme = if uastc { 0 } else { 1 };
    for (i, v) in [0u32, 1, width, height, 0, 0, 1, levels, scheme]
        .iter()
        .enumerate()
    {
        out[12 + 4 * i..16 + 4 * i].copy_from_slice(&v.to_le_bytes());
    }
    out[48..52].copy_from_slice(&(dfd_offset as u32).to_le_bytes());
    out[52..56].copy_from_slice(&(dfd.len() as u32).to_le_bytes());
    if !sgd.is_empty() {
        out[64..72].copy_from_slice(&(sgd_offset as u64).to_le_bytes());
        out[72..80].copy_from_slice(&(sgd.len() as u64).to_le_bytes());
    }
    for (l, (data, ..)) in level_data.iter().enumerate() {
        let o = 80 + 24 * l;
        let uncompressed = if uastc { data.len() as u64 } else { 0 };
        for (k, v) in [offsets[l] as u64, data.len() as u64, uncompressed]
            .iter()
            .enumerate()
        {
            out[o + 8 * k..o + 8 * k + 8].copy_from_slice(&v.to_le_bytes());
        }
        out[offsets[l]..offsets[l] + data.len()].copy_from_slice(data);
    }
    out[dfd_offset..dfd_offset + dfd.len()].copy_from_slice(&dfd);
    out[sgd_offset..sgd_offset + sgd.len()].copy_from_slice(&sgd);
    out
}

/// The Data Format Descriptor of Basis Universal data: colour model ETC1S (163) or UASTC
/// (166), BT.709 primaries, sRGB or linear transfer, 4x4 blocks, one sample (ETC1S: two
/// with alpha).
fn dfd(uastc: bool, alpha: bool, srgb: bool) -> Vec<u8> {
    let samples: Vec<(u16, u8, u8)> = match (uastc, alpha) {
        (true, false) => vec![(0, 127, 0)],
        (true, true) => vec![(0, 127, 3)],
        (false, false) => vec![(0, 63, 0)],
        (false, true) => vec![(0, 63, 0), (64, 63, 15)],
    };
    let block = 24 + 16 * samples.len() as u32;
    let mut d = Vec::new();
    d.extend_from_slice(&(block + 4).to_le_bytes());
    d.extend_from_slice(&0u32.to_le_bytes());
    d.extend_from_slice(&(2 | (block << 16)).to_le_bytes());
    d.extend_from_slice(&[
        if uastc { 166 } else { 163 },
        1,
        if srgb { 2 } else { 1 },
        0,
    ]);
    d.extend_from_slice(&[3, 3, 0, 0]);
    d.extend_from_slice(&[if uastc { 16 } else { 0 }, 0, 0, 0, 0, 0, 0, 0]);
    for (offset, bits, channel) in samples {
        d.extend_from_slice(&offset.to_le_bytes());
        d.extend_from_slice(&[bits, channel]);
        d.extend_from_slice(&[0, 0, 0, 0]);
        d.extend_from_slice(&0u32.to_le_bytes());
        d.extend_from_slice(&u32::MAX.to_le_bytes());
    }
    d
}

/// An opaque test picture: smooth colour ramps with a soft disc (what block codecs keep well)
/// plus one hard edge (what they blur).
pub fn picture(w: u32, h: u32) -> Vec<u8> {
    let mut out = Vec::with_capacity((w * h * 4) as usize);
    for y in 0..h {
        for x in 0..w {
            let (u, v) = (x as f32 / w as f32, y as f32 / h as f32);
            let d = ((u - 0.6).powi(2) + (v - 0.4).powi(2)).sqrt();
            let disc = (1.0 - d * 3.0).clamp(0.0, 1.0);
            let edge = if x > w * 3 / 4 { 0.25 } else { 0.0 };
            out.extend_from_slice(&[
                (255.0 * (0.8 * u + 0.2 * disc)) as u8,
                (255.0 * (0.3 + 0.5 * v * (1.0 - edge))) as u8,
                (255.0 * (0.9 * disc + 0.1)) as u8,
                255,
            ]);
        }
    }
    out
}

/// A textured unit quad whose base colour samples texture 0; `images` and `textures` as
/// given, `extensions` goes to extensionsUsed (and extensionsRequired when `required`).
pub fn textured_quad(
    images: Value,
    textures: Value,
    extensions: &[&str],
    required: bool,
) -> Vec<u8> {
    let mut b = Builder::default();
    let mut doc = quad_doc(&mut b, json!({"material": 0}));
    let uv = b.floats(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0], "VEC2");
    doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(uv);
    doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0}}]);
    doc["images"] = images;
    doc["textures"] = textures;
    doc["extensionsUsed"] = json!(extensions);
    if required {
        doc["extensionsRequired"] = json!(extensions);
    }
    serde_json::to_vec(&b.document(doc)).unwrap()
}

/// A glTF image of `bytes` as a base64 data URI of type `mime`.
pub fn data_uri(mime: &str, bytes: &[u8]) -> Value {
    json!({"uri": format!("data:{mime};base64,{}", base64(bytes)), "mimeType": mime})
}

/// The quad with a KTX2 image as its only (required) texture source.
pub fn ktx2_quad(ktx: &[u8]) -> Vec<u8> {
    textured_quad(
        json!([data_uri("image/ktx2", ktx)]),
        json!([{"extensions": {"KHR_texture_basisu": {"source": 0}}}]),
        &["KHR_texture_basisu"],
        true,
    )
}

/// Loads a glTF document as `ktx.gltf` (the name errors start with); the error as text.
pub fn load(doc: &[u8]) -> Result<Scene, String> {
    scene::load_slice(doc, None, "ktx.gltf", &LoadOptions::default()).map_err(|e| e.to_string())
}

/// The block format this device uploads KTX2 textures as: BC7 on lavapipe and desktop GPUs.
/// A device with neither BC7 nor ASTC 4x4 fails the block tests (not skipped).
pub fn device_blocks(ctx: &Context) -> (basisu::TargetFormat, vk::Format, vk::Format) {
    let f = ctx.features();
    if ctx.info().driver_name.contains("llvmpipe") {
        assert!(f.bc7_textures, "lavapipe samples BC7");
    }
    if f.bc7_textures {
        (
            basisu::TargetFormat::Bc7Rgba,
            vk::Format::BC7_SRGB_BLOCK,
            vk::Format::BC7_UNORM_BLOCK,
        )
    } else if f.astc_4x4_textures {
        (
            basisu::TargetFormat::Astc4x4Rgba,
            vk::Format::ASTC_4X4_SRGB_BLOCK,
            vk::Format::ASTC_4X4_UNORM_BLOCK,
        )
    } else {
        panic!("{} samples neither BC7 nor ASTC 4x4", ctx.info().name)
    }
}
