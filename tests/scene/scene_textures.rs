//! Texture upload: every image once, with mips, sRGB vs UNORM, one sampler per distinct
//! state, validation clean (oversized images are in the bad-input binary, `images`).

use crate::support::readback;
use crate::support::scene_files;

use crate::support::{assert_validation_clean, gpu};
use rqr::scene::textures::{mip_levels, GpuTextures};
use rqr::scene::{self, ImageData, LoadOptions, Sampler, Scene, Texture};
use rqr::vk::{vk, Context};

/// Copies mip `level` of uploaded image `index` back to the host (RGBA8).
fn read_mip(ctx: &Context, tex: &GpuTextures, index: usize, level: u32) -> Vec<u8> {
    let image = &tex.images()[index];
    let w = (image.extent.width >> level).max(1);
    let h = (image.extent.height >> level).max(1);
    readback::read_level(ctx, tex, index, level, (w * h * 4) as usize)
}

fn two_texel_scene() -> Scene {
    // A 2x1 image, black and white, once as sRGB colour and once as linear data.
    let black_white = vec![0, 0, 0, 255, 255, 255, 255, 255];
    let mut s = Scene::default();
    for srgb in [true, false] {
        s.images.push(ImageData {
            width: 2,
            height: 1,
            rgba8: black_white.clone(),
            mips: Vec::new(),
            srgb,
            ktx2: None,
        });
    }
    s.textures.push(Texture {
        image: 0,
        sampler: Sampler::default(),
    });
    s.textures.push(Texture {
        image: 1,
        sampler: Sampler::default(),
    });
    s.textures.push(Texture {
        image: 1,
        sampler: Sampler {
            mipmaps: false,
            ..Default::default()
        },
    });
    s
}

#[test]
fn mips_average_srgb_in_linear_space() {
    let ctx = gpu();
    let s = two_texel_scene();
    let tex = GpuTextures::upload(&ctx, &s).unwrap();
    assert_eq!(tex.images()[0].format, vk::Format::R8G8B8A8_SRGB);
    assert_eq!(tex.images()[1].format, vk::Format::R8G8B8A8_UNORM);
    assert_eq!(tex.images()[0].mip_levels, 2);
    assert_eq!(tex.sampler_count(), 2);
    let d = tex.descriptors();
    assert_eq!(d.len(), 3);
    assert_eq!(d[1].0, d[2].0, "same image view");
    assert_ne!(d[1].1, d[2].1, "different samplers");
    assert_eq!(d[0].1, d[1].1, "equal sampler states share one sampler");

    assert_eq!(
        read_mip(&ctx, &tex, 0, 0),
        s.images[0].rgba8,
        "mip 0 is the image"
    );
    // Half of linear 1.0 is sRGB 188; a UNORM average is 127 or 128.
    let srgb = read_mip(&ctx, &tex, 0, 1);
    assert!((186..=190).contains(&srgb[0]), "sRGB mip 1: {srgb:?}");
    assert_eq!(srgb[3], 255);
    let unorm = read_mip(&ctx, &tex, 1, 1);
    assert!((126..=129).contains(&unorm[0]), "UNORM mip 1: {unorm:?}");
    assert_validation_clean(&ctx);
}

#[test]
fn sample_model_textures_upload_validation_clean() {
    let ctx = gpu();
    let s = scene::load(
        &scene_files::asset("TextureTransformTest/TextureTransformTest.gltf"),
        &LoadOptions::default(),
    )
    .unwrap();
    let tex = GpuTextures::upload(&ctx, &s).unwrap();
    assert_eq!(tex.len(), s.textures.len());
    assert_eq!(tex.images().len(), s.images.len());
    for (gpu_img, img) in tex.images().iter().zip(&s.images) {
        assert_eq!(gpu_img.mip_levels, mip_levels(img.width, img.height));
        assert_eq!(
            (gpu_img.extent.width, gpu_img.extent.height),
            (img.width, img.height)
        );
    }
    // Two distinct sampler states: the file's clamp/no-mip sampler and the default.
    assert_eq!(tex.sampler_count(), 2);
    // Non-square, non-power-of-two mip chains read back at their smallest level.
    let last = tex.images()[0].mip_levels - 1;
    assert_eq!(read_mip(&ctx, &tex, 0, last).len(), 4);

    let default = scene::load_default().unwrap();
    let tex = GpuTextures::upload(&ctx, &default).unwrap();
    assert_eq!(tex.descriptors().len(), 1);
    drop(tex);
    assert_validation_clean(&ctx);
}
