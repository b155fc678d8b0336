//! KHR_texture_basisu (KTX2 / Basis Universal) and EXT_texture_webp: textures the test also
//! keeps uncompressed decode within the codec's tolerance, with the file's mip levels; real
//! KTX2 files of StainedGlassLamp decode (broken ones are in the bad-input binary, `ktx2`);
//! a KTX2 texture renders like the same texels from a PNG; KTX2 textures upload as the BC7
//! blocks the transcoder makes, with the file's levels, and render like their RGBA8 upload.

use crate::support;
use crate::support::ktx2::{
    self, data_uri, device_blocks, ktx2_quad, load, picture, textured_quad,
};
use crate::support::readback;

use crate::support::scene_files::{asset, png, quad_doc, Builder};
use readback::read_level;
use rqr::render::image::metrics;
use rqr::scene::textures::GpuTextures;
use rqr::scene::{self, LoadOptions, Scene, TextureFormat};
use rqr::vk::vk;
use serde_json::json;
use support::render_alike::assert_renders_alike;

const SIZE: u32 = 64;

/// Box-filters an RGBA8 image to half size (each side at least 1).
fn half(w: u32, h: u32, rgba: &[u8]) -> Vec<u8> {
    let (hw, hh) = ((w / 2).max(1), (h / 2).max(1));
    let mut out = Vec::with_capacity((hw * hh * 4) as usize);
    for y in 0..hh {
        for x in 0..hw {
            for c in 0..4 {
                let mut sum = 0u32;
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let (sx, sy) = ((2 * x + dx).min(w - 1), (2 * y + dy).min(h - 1));
                    sum += u32::from(rgba[((sy * w + sx) * 4 + c) as usize]);
                }
                out.push(((sum + 2) / 4) as u8);
            }
        }
    }
    out
}

/// [`load`] with `--texture-format rgba8`.
fn load_rgba8(doc: &[u8]) -> Scene {
    let opts = LoadOptions {
        texture_format: TextureFormat::Rgba8,
        ..Default::default()
    };
    scene::load_slice(doc, None, "ktx.gltf", &opts).unwrap()
}

fn psnr(a: &[u8], b: &[u8]) -> f64 {
    metrics::psnr_rmse(a, b).0
}

#[test]
fn basisu_textures_decode_within_codec_tolerance() {
    let original = picture(SIZE, SIZE);
    // The same texels uncompressed: a PNG loads bit-exact.
    let png_scene = load(&textured_quad(
        json!([data_uri("image/png", &png(SIZE, SIZE, &original))]),
        json!([{"source": 0}]),
        &[],
        false,
    ))
    .unwrap();
    assert_eq!(png_scene.images[0].rgba8, original);
    assert!(
        png_scene.images[0].mips.is_empty(),
        "PNG: rqr generates the mips"
    );
    // Lower bounds below the measured PSNR (printed), at what each codec keeps: ETC1S is a
    // low-bit-rate codec (about 1-2 bits per texel), UASTC a high-quality 8-bit one.
    for (uastc, name, min_db) in [(false, "ETC1S", 28.0), (true, "UASTC", 38.0)] {
        let ktx = ktx2::encode(&original, SIZE, SIZE, uastc, true);
        let s = load(&ktx2_quad(&ktx)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(s.extensions_unsupported.is_empty());
        let img = &s.images[0];
        assert_eq!((img.width, img.height), (SIZE, SIZE), "{name}");
        assert!(img.srgb, "{name}: base colour samples as sRGB");
        // 64 → 1: seven levels, all from the file.
        assert_eq!(img.mips.len(), 6, "{name}: mip levels from the file");
        let level0 = psnr(&original, &img.rgba8);
        // Level 1 against the original halved; smaller levels against their decoded
        // predecessor halved (the encoder's own mip filter, a windowed sinc in linear light,
        // drifts away from a box filter in sRGB bytes as the levels shrink).
        let level1 = psnr(&half(SIZE, SIZE, &original), &img.mips[0]);
        let mut chain = Vec::new();
        let mut w = SIZE / 2;
        for l in 1..3 {
            let expected = half(w, w, &img.mips[l - 1]);
            w /= 2;
            assert_eq!(
                img.mips[l].len() as u32,
                w * w * 4,
                "{name}: level {}",
                l + 1
            );
            chain.push(psnr(&expected, &img.mips[l]));
        }
        eprintln!(
            "{name}: PSNR level 0 {level0:.2} dB, level 1 {level1:.2} dB, levels 2-3 vs their predecessor halved {chain:.2?} dB"
        );
        assert!(level0 >= min_db, "{name}: level 0 PSNR {level0:.2} dB");
        assert!(
            level1 >= min_db - 6.0,
            "{name}: level 1 PSNR {level1:.2} dB"
        );
        for (l, db) in chain.iter().enumerate() {
            assert!(*db >= 18.0, "{name}: level {} PSNR {db:.2} dB", l + 2);
        }
    }
}

/// Each level of a real file looks like its predecessor halved: the level chain decodes as
/// one picture, not as noise or as a shifted copy.
fn check_level_chain(name: &str, width: u32, levels: usize, min_db: f64) {
    let ktx = std::fs::read(asset(&format!("StainedGlassLamp_KTX/{name}"))).unwrap();
    let s = load(&ktx2_quad(&ktx)).unwrap_or_else(|e| panic!("{name}: {e}"));
    let img = &s.images[0];
    assert_eq!((img.width, img.height), (width, width), "{name}");
    assert_eq!(img.mips.len() + 1, levels, "{name}: levels");
    let mut prev = img.rgba8.clone();
    let mut w = width;
    let mut dbs = Vec::new();
    for mip in img.mips.iter().take(4) {
        let expected = half(w, w, &prev);
        w /= 2;
        dbs.push(psnr(&expected, mip));
        prev = mip.clone();
    }
    eprintln!("{name}: level n+1 vs level n halved: {dbs:.2?} dB");
    assert!(dbs.iter().all(|&d| d >= min_db), "{name}: {dbs:?}");
    // Not a flat colour.
    let first = &img.rgba8[..4];
    assert!(img.rgba8.chunks(4).any(|p| p != first), "{name}: flat");
}

#[test]
fn stained_glass_lamp_ktx2_files_decode() {
    // ETC1S with BasisLZ (512², 10 levels) and UASTC with Zstandard (256², 9 levels).
    check_level_chain("StainedGlassLamp_hardware_basecolor.ktx2", 512, 10, 24.0);
    check_level_chain(
        "StainedGlassLamp_bulbs_occlusion-rough-metal.ktx2",
        256,
        9,
        24.0,
    );
}

#[test]
fn webp_texture_wins_over_its_png_fallback() {
    let original = picture(SIZE, SIZE);
    let mut webp = Vec::new();
    image::codecs::webp::WebPEncoder::new_lossless(&mut webp)
        .encode(&original, SIZE, SIZE, image::ExtendedColorType::Rgba8)
        .unwrap();
    let grey = vec![128u8; (SIZE * SIZE * 4) as usize];
    let doc = textured_quad(
        json!([
            data_uri("image/png", &png(SIZE, SIZE, &grey)),
            data_uri("image/webp", &webp)
        ]),
        json!([{"source": 0, "extensions": {"EXT_texture_webp": {"source": 1}}}]),
        &["EXT_texture_webp"],
        false,
    );
    let s = load(&doc).unwrap();
    assert!(s.extensions_unsupported.is_empty());
    assert_eq!(s.images.len(), 1);
    assert_eq!(s.images[0].rgba8, original, "lossless WebP decodes exactly");
}

#[test]
fn ktx2_texture_renders_like_its_png() {
    let ctx = support::gpu();
    let original = picture(SIZE, SIZE);
    let from_png = load(&textured_quad(
        json!([data_uri("image/png", &png(SIZE, SIZE, &original))]),
        json!([{"source": 0}]),
        &[],
        false,
    ))
    .unwrap();
    let from_ktx2 = load(&ktx2_quad(&ktx2::encode(&original, SIZE, SIZE, true, true))).unwrap();
    assert_renders_alike(
        &ctx,
        &from_png,
        &from_ktx2,
        SIZE,
        0.02,
        "PNG vs UASTC KTX2 quad",
    );
    support::assert_validation_clean(&ctx);
}

#[test]
fn ktx2_textures_upload_as_blocks_with_the_files_levels() {
    let ctx = support::gpu();
    let (target, srgb_format, _) = device_blocks(&ctx);
    let original = picture(SIZE, SIZE);
    for (uastc, name) in [(true, "UASTC"), (false, "ETC1S")] {
        let ktx = ktx2::encode(&original, SIZE, SIZE, uastc, true);
        let doc = ktx2_quad(&ktx);
        let s = load(&doc).unwrap();
        let tex = GpuTextures::upload(&ctx, &s).unwrap();
        let image = &tex.images()[0];
        assert_eq!(image.format, srgb_format, "{name}");
        assert_eq!(image.mip_levels, 7, "{name}: the file's 7 levels");
        // Every uploaded level holds exactly the transcoder's blocks, down to the 2x2 and
        // 1x1 levels that take one whole 4x4 block each.
        let transcoder = basisu::Transcoder::new(&ktx).unwrap();
        for level in [0, 3, 5, 6] {
            let blocks = transcoder
                .transcode(level, target, basisu::DecodeFlags::NONE)
                .unwrap();
            let side = (SIZE >> level) as usize;
            assert_eq!(
                blocks.len(),
                side.div_ceil(4).pow(2) * 16,
                "{name} level {level}"
            );
            let uploaded = read_level(&ctx, &tex, 0, level, blocks.len());
            assert!(
                uploaded == blocks,
                "{name}: level {level} differs from the transcoder's blocks"
            );
        }
        // --texture-format rgba8: the RGBA8 decoded at load, with the file's levels.
        let s = load_rgba8(&doc);
        assert!(
            s.images[0].ktx2.is_none(),
            "{name}: rgba8 keeps no KTX2 file"
        );
        let tex = GpuTextures::upload(&ctx, &s).unwrap();
        assert_eq!(tex.images()[0].format, vk::Format::R8G8B8A8_SRGB, "{name}");
        assert_eq!(tex.images()[0].mip_levels, 7, "{name}");
        assert_eq!(
            read_level(&ctx, &tex, 0, 6, 4),
            s.images[0].mips[5],
            "{name}: 1x1 level"
        );
    }
    // A file with level 0 alone keeps RGBA8, whose chain the upload generates (block formats
    // cannot be blitted).
    let single = ktx2::encode_with(&original, SIZE, SIZE, true, true, false);
    let s = load(&ktx2_quad(&single)).unwrap();
    assert!(s.images[0].mips.is_empty() && s.images[0].ktx2.is_some());
    let tex = GpuTextures::upload(&ctx, &s).unwrap();
    assert_eq!(tex.images()[0].format, vk::Format::R8G8B8A8_SRGB);
    assert_eq!(tex.images()[0].mip_levels, 7, "generated chain");
    support::assert_validation_clean(&ctx);
}

/// A quad whose base colour and metallic-roughness come from StainedGlassLamp's two KTX2
/// files (ETC1S 512², UASTC 256²), the second as linear data.
fn lamp_textures_quad() -> Vec<u8> {
    let file = |name: &str| {
        std::fs::read(asset(&format!(
            "StainedGlassLamp_KTX/StainedGlassLamp_{name}.ktx2"
        )))
        .unwrap()
    };
    let mut b = Builder::default();
    let mut doc = quad_doc(&mut b, json!({"material": 0}));
    let uv = b.floats(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0], "VEC2");
    doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(uv);
    doc["materials"] = json!([{"pbrMetallicRoughness": {
        "baseColorTexture": {"index": 0},
        "metallicRoughnessTexture": {"index": 1},
    }}]);
    doc["images"] = json!([
        data_uri("image/ktx2", &file("hardware_basecolor")),
        data_uri("image/ktx2", &file("bulbs_occlusion-rough-metal")),
    ]);
    doc["textures"] = json!([
        {"extensions": {"KHR_texture_basisu": {"source": 0}}},
        {"extensions": {"KHR_texture_basisu": {"source": 1}}},
    ]);
    doc["extensionsUsed"] = json!(["KHR_texture_basisu"]);
    doc["extensionsRequired"] = json!(["KHR_texture_basisu"]);
    serde_json::to_vec(&b.document(doc)).unwrap()
}

#[test]
fn stained_glass_lamp_textures_render_alike_as_blocks_and_rgba8() {
    let ctx = support::gpu();
    let (_, srgb_format, unorm_format) = device_blocks(&ctx);
    let doc = lamp_textures_quad();
    let blocks = load(&doc).unwrap();
    let rgba8 = load_rgba8(&doc);
    let tex = GpuTextures::upload(&ctx, &blocks).unwrap();
    let formats: Vec<_> = tex
        .images()
        .iter()
        .map(|i| (i.format, i.mip_levels))
        .collect();
    assert_eq!(formats, [(srgb_format, 10), (unorm_format, 9)]);
    drop(tex);
    assert_renders_alike(
        &ctx,
        &rgba8,
        &blocks,
        128,
        0.02,
        "StainedGlassLamp textures, RGBA8 vs block upload",
    );
    support::assert_validation_clean(&ctx);
}

/// lavapipe's measured sampling times with BC7 faster, or RGBA8 faster (its real ordering).
fn sampling_times(bc7_faster: bool) -> rqr::device_select::autotune::Measurement {
    let (block, rgba8) = if bc7_faster { (1.0, 2.0) } else { (86.5, 1.3) };
    rqr::device_select::autotune::Measurement {
        rt_hw_ms: Some(2.0),
        rt_bvh_ms: 1.0,
        visibility_graphics_ms: 1.0,
        visibility_compute_ms: 2.0,
        bvh_host_build_ms: 1.0,
        bvh_gpu_build_ms: 2.0,
        texture_block_ms: Some(block),
        texture_rgba8_ms: rgba8,
    }
}

#[test]
fn texture_format_flag_chooses_the_upload() {
    let dir = std::env::temp_dir().join(format!("rqr-test-ktx2-flag-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let gltf = dir.join("lamp_quad.gltf");
    std::fs::write(&gltf, lamp_textures_quad()).unwrap();
    // An isolated autotune cache, holding the outcome each `auto` run is to follow.
    let cache = dir.join("cache");
    let list =
        rqr::vk::describe_devices(&rqr::vk::DeviceSelector::Auto).expect(support::INSTALL_HINT);
    let device = list.devices[list.selected].clone();
    let inject = |bc7_faster: bool| {
        rqr::device_select::autotune::store(
            &cache.join("rqr").join("autotune.json"),
            &rqr::device_select::autotune::cache_key(&device),
            &sampling_times(bc7_faster),
        )
        .unwrap()
    };
    let render = |format: &str, name: &str, autotune: &str| {
        let png = dir.join(format!("{name}.png"));
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_rqr"))
            .env("RQR_VALIDATION", "1")
            .env("RQR_NO_AUTOTUNE", autotune)
            .env("XDG_CACHE_HOME", &cache)
            .env("RUST_LOG", "rqr=info")
            .args([
                "render",
                "--width",
                "48",
                "--height",
                "48",
                "--texture-format",
                format,
            ])
            .arg(&gltf)
            .arg("-o")
            .arg(&png)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(out.status.success(), "{name}: {stderr}");
        assert!(!stderr.contains("VUID"), "{name}: validation: {stderr}");
        (image::open(&png).unwrap().to_rgba8().into_raw(), stderr)
    };
    let as_blocks = "2 of 2 images uploaded as BC7 blocks";
    let (block, block_log) = render("block", "block", "1");
    let (rgba8, rgba8_log) = render("rgba8", "rgba8", "1");
    assert!(block_log.contains(as_blocks), "{block_log}");
    assert!(!rgba8_log.contains("uploaded as"), "{rgba8_log}");
    let d = metrics::compare(48, 48, &rgba8, &block);
    eprintln!(
        "rqr render --texture-format rgba8 vs block: FLIP mean {:.5}",
        d.flip_mean
    );
    assert!(d.flip_mean < 0.02, "FLIP {}", d.flip_mean);
    // `auto` follows the measurement: BC7 where it sampled faster...
    inject(true);
    let (auto, log) = render("auto", "auto-bc7", "0");
    assert!(log.contains(as_blocks), "{log}");
    assert!(
        log.contains("KTX2 textures: block (auto (measured)"),
        "{log}"
    );
    assert_eq!(auto, block, "auto uploads exactly what block does");
    // ...RGBA8 where that sampled faster (lavapipe's own ordering).
    inject(false);
    let (auto, log) = render("auto", "auto-rgba8", "0");
    assert!(!log.contains("uploaded as"), "{log}");
    assert!(
        log.contains("KTX2 textures: rgba8 (auto (measured)"),
        "{log}"
    );
    assert_eq!(auto, rgba8, "auto uploads exactly what rgba8 does");
    // Without measurements, the rule: a CPU device decodes BC7 in software.
    let (auto, log) = render("auto", "auto-rule", "1");
    assert!(!log.contains("uploaded as"), "{log}");
    assert!(
        log.contains("a CPU device decodes BC7 in software"),
        "{log}"
    );
    assert_eq!(auto, rgba8);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_rqr"))
        .args(["render", "--texture-format", "bc9"])
        .arg(&gltf)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && stderr.contains("auto, rgba8, block"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Writes the fuzz target's KTX2 and WebP seeds (`fuzz/seeds/quad_ktx2_*.glb`,
/// `quad_webp.glb`): run with `--ignored` after changing them; `scene_extensions`'s
/// `fuzz_seeds_load` checks that every seed loads.
#[test]
#[ignore]
fn write_fuzz_seeds() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds");
    let pixels = picture(32, 32);
    let mut webp = Vec::new();
    image::codecs::webp::WebPEncoder::new_lossless(&mut webp)
        .encode(&pixels, 32, 32, image::ExtendedColorType::Rgba8)
        .unwrap();
    let seeds = [
        (
            "quad_ktx2_etc1s.glb",
            ktx2::encode(&pixels, 32, 32, false, true),
            "image/ktx2",
            "KHR_texture_basisu",
        ),
        (
            "quad_ktx2_uastc.glb",
            ktx2::encode(&pixels, 32, 32, true, true),
            "image/ktx2",
            "KHR_texture_basisu",
        ),
        ("quad_webp.glb", webp, "image/webp", "EXT_texture_webp"),
    ];
    for (name, image, mime, ext) in seeds {
        let mut b = Builder::default();
        let mut doc = quad_doc(&mut b, json!({"material": 0}));
        let uv = b.floats(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0], "VEC2");
        doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(uv);
        let view = b.view(&image);
        doc["images"] = json!([{"bufferView": view, "mimeType": mime}]);
        doc["textures"] = json!([{"extensions": {ext: {"source": 0}}}]);
        doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
        doc["extensionsUsed"] = json!([ext]);
        doc["extensionsRequired"] = json!([ext]);
        let glb = b.glb(doc);
        scene::load_slice(&glb, None, name, &LoadOptions::default()).unwrap();
        std::fs::write(dir.join(name), glb).unwrap();
    }
}
