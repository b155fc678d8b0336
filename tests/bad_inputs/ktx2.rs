//! Broken KHR_texture_basisu textures: damaged KTX2 headers and level indexes, unsupported
//! supercompression and formats, KTX2 data the block transcode refuses at upload, and random
//! byte flips and cuts of real files; each fails naming the file and the image, never a panic.

use rqr::scene::textures::GpuTextures;
use serde_json::json;

use crate::support;
use crate::support::ktx2::{self, device_blocks, ktx2_quad, load, picture, textured_quad};
use crate::support::scene_files::asset;

/// Side of the test picture.
const SIZE: u32 = 64;

/// A valid UASTC KTX2 file with `edit` applied.
fn broken_uastc(edit: impl Fn(&mut Vec<u8>)) -> Vec<u8> {
    let mut ktx = ktx2::encode(&picture(16, 16), 16, 16, true, true);
    edit(&mut ktx);
    ktx
}

#[test]
fn broken_ktx2_files_name_the_file_and_image() {
    let put32 =
        |k: &mut Vec<u8>, at: usize, v: u32| k[at..at + 4].copy_from_slice(&v.to_le_bytes());
    let cases: Vec<(Vec<u8>, &str)> = vec![
        (
            broken_uastc(|k| k[1] = b'X'),
            "KTX2 header: not a KTX2 file (wrong identifier)",
        ),
        (
            broken_uastc(|k| k.truncate(60)),
            "shorter than the 80-byte header",
        ),
        // Level 0's byte length (level index entry 0, bytes 88..96) far beyond the file.
        (
            broken_uastc(|k| k[88..96].copy_from_slice(&(1u64 << 40).to_le_bytes())),
            "KTX2 level 0: bytes",
        ),
        // Supercompression 3 (ZLIB) is defined by KTX2 but not used by Basis Universal.
        (
            broken_uastc(|k| put32(k, 44, 3)),
            "KTX2 supercompression scheme 3 is not supported for UASTC",
        ),
        (
            broken_uastc(|k| put32(k, 44, 77)),
            "KTX2 supercompression scheme 77",
        ),
        (broken_uastc(|k| put32(k, 12, 37)), "KTX2 vkFormat"),
        (
            broken_uastc(|k| put32(k, 20, 1 << 20)),
            "outside rqr's 1..=16384 pixel limit",
        ),
        (broken_uastc(|k| put32(k, 40, 40)), "40 mip levels"),
        (
            broken_uastc(|k| put32(k, 40, 6)),
            "KTX2 header: 6 mip levels for 16x16 (a full chain has 5)",
        ),
        (broken_uastc(|k| put32(k, 32, 6)), "only 2D textures"),
    ];
    for (ktx, want) in cases {
        let e = load(&ktx2_quad(&ktx)).expect_err(want);
        assert!(
            e.starts_with("ktx.gltf: ") && e.contains("image 0") && e.contains(want),
            "want '{want}' in '{e}'"
        );
    }
    // A KTX2 texture without an image index.
    let doc = textured_quad(
        json!([]),
        json!([{"extensions": {"KHR_texture_basisu": {}}}]),
        &["KHR_texture_basisu"],
        true,
    );
    let e = load(&doc).unwrap_err();
    assert!(e.contains("texture 0: KHR_texture_basisu: `source`"), "{e}");
}

#[test]
fn ktx2_that_fails_the_block_transcode_names_file_and_image() {
    let ctx = support::gpu();
    device_blocks(&ctx);
    let ktx = ktx2::encode(&picture(SIZE, SIZE), SIZE, SIZE, true, true);
    let loaded = load(&ktx2_quad(&ktx)).unwrap();
    let cases: Vec<(Vec<u8>, &str)> = vec![
        (ktx[..200].to_vec(), "KTX2 Basis Universal data"),
        (
            ktx2::encode(&picture(16, 16), 16, 16, true, true),
            "KTX2 data is 16x16 with 5 levels, the loaded image 64x64 with 7",
        ),
    ];
    for (bytes, want) in cases {
        let mut s = loaded.clone();
        s.images[0].ktx2 = Some(bytes.into());
        let e = GpuTextures::upload(&ctx, &s)
            .err()
            .unwrap_or_else(|| panic!("{want}: uploaded"))
            .to_string();
        assert!(
            e.starts_with("ktx.gltf: image 0: ")
                && e.contains(want)
                && e.contains("--texture-format rgba8"),
            "want '{want}' in '{e}'"
        );
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn mutated_ktx2_files_fail_cleanly() {
    // Byte flips and cuts of both real files (ETC1S codebooks and Huffman tables, UASTC with
    // Zstandard frames): each either loads or fails naming the file and image, and never
    // reaches the loader's panic guard around the decoder threads.
    let mut rng = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        rng
    };
    // Each mutant that loads also uploads as blocks, or fails naming the file and image.
    let ctx = support::gpu();
    device_blocks(&ctx);
    let (mut loaded, mut failed, mut upload_failed) = (0, 0, 0);
    for name in [
        "StainedGlassLamp_hardware_basecolor.ktx2",
        "StainedGlassLamp_bulbs_occlusion-rough-metal.ktx2",
    ] {
        let original = std::fs::read(asset(&format!("StainedGlassLamp_KTX/{name}"))).unwrap();
        for i in 0..150 {
            let mut ktx = original.clone();
            if i % 10 == 9 {
                ktx.truncate(next() as usize % ktx.len());
            } else {
                for _ in 0..1 + next() % 4 {
                    let at = next() as usize % ktx.len();
                    ktx[at] ^= 1 << (next() % 8);
                }
            }
            match load(&ktx2_quad(&ktx)) {
                Ok(s) => {
                    loaded += 1;
                    if let Err(e) = GpuTextures::upload(&ctx, &s) {
                        let e = e.to_string();
                        assert!(
                            e.starts_with("ktx.gltf: image 0: "),
                            "{name} mutation {i}: {e}"
                        );
                        assert!(!e.contains("panicked"), "{name} mutation {i}: {e}");
                        upload_failed += 1;
                    }
                }
                Err(e) => {
                    assert!(
                        e.starts_with("ktx.gltf: image 0"),
                        "{name} mutation {i}: {e}"
                    );
                    assert!(!e.contains("panicked"), "{name} mutation {i}: {e}");
                    failed += 1;
                }
            }
        }
    }
    eprintln!(
        "mutated KTX2 files: {loaded} loaded ({upload_failed} of them refused by the block upload), {failed} refused"
    );
    support::assert_validation_clean(&ctx);
}
