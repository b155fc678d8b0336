//! Bad-input cases of images (missing, corrupt, empty, absurd sizes, bad data URIs, formats
//! rqr does not read) and of glTF extensions it does not support; beside the corpus, images
//! beyond the device's limit or with fewer bytes than their size at upload.

use rqr::scene::textures::GpuTextures;
use rqr::scene::{ImageData, Scene};
use rqr::vk::VkError;
use serde_json::{json, Value};

use super::corpus::{
    case, embedded_glb, fails, gltf, quad_gltf, textured, textured_in, Case, Expect,
};
use crate::support::scene_files::{base64, bytes, png, png_header, quad_doc, Builder};
use crate::support::{assert_validation_clean, gpu};

/// Images: missing, corrupt, empty, absurd sizes, bad data URIs; extensions.
pub fn cases(out: &mut Vec<Case>) {
    let with_image = |name: &str, image: Value, extra: Vec<(String, Vec<u8>)>, expect: Expect| {
        let (b, doc) = textured(image);
        let mut files = vec![("scene.gltf".to_string(), bytes(&b.document(doc)))];
        files.extend(extra);
        Case {
            name: name.to_string(),
            files,
            expect,
        }
    };
    let embedded = |name: &str, data: Vec<u8>, expect: Expect| {
        case(name, "scene.glb", embedded_glb(&data), expect)
    };
    out.push(with_image(
        "image_missing_file",
        json!({"uri": "missing.png"}),
        vec![],
        fails(&["image 0 (missing.png): cannot read"]),
    ));
    out.push(with_image(
        "image_zero_bytes",
        json!({"uri": "empty.png"}),
        vec![("empty.png".into(), Vec::new())],
        fails(&["image 0 (empty.png): not a PNG, JPEG, WebP or KTX2 image"]),
    ));
    out.push(with_image(
        "image_garbage",
        json!({"uri": "garbage.png"}),
        vec![("garbage.png".into(), b"definitely not an image".to_vec())],
        fails(&["image 0 (garbage.png): not a PNG, JPEG, WebP or KTX2 image"]),
    ));
    let good = png(4, 4, &[200; 64]);
    out.push(embedded(
        "image_truncated_png",
        good[..good.len() - 20].to_vec(),
        fails(&["image 0: cannot decode"]),
    ));
    out.push(embedded(
        "image_header_0x0",
        png_header(0, 0),
        fails(&["image 0: "]),
    ));
    out.push(embedded(
        "image_header_20000",
        png_header(20000, 20000),
        fails(&["image 0: 20000x20000 is outside rqr's 1..=16384 pixel limit per side"]),
    ));
    out.push(embedded(
        "image_header_16k_without_pixels",
        png_header(16384, 16384),
        fails(&["image 0: cannot decode"]),
    ));
    // Five 16k² headers: more texels than a scene may hold, refused before any decoding.
    let mut b = Builder::default();
    let header = b.view(&png_header(16384, 16384));
    let mut doc = textured_in(
        &mut b,
        json!({"bufferView": header, "mimeType": "image/png"}),
    );
    doc["images"] = json!((0..5)
        .map(|_| json!({"bufferView": header, "mimeType": "image/png"}))
        .collect::<Vec<_>>());
    doc["textures"] = json!((0..5).map(|i| json!({"source": i})).collect::<Vec<_>>());
    doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}},
        "emissiveTexture": {"index": 1}, "normalTexture": {"index": 2},
        "occlusionTexture": {"index": 3},
        "extensions": {"KHR_materials_transmission": {"transmissionTexture": {"index": 4}}}}]);
    doc["extensionsUsed"] = json!(["KHR_materials_transmission"]);
    out.push(case(
        "images_beyond_texel_budget",
        "scene.glb",
        b.glb(doc),
        fails(&["exceed rqr's limit of 1073741824 texels"]),
    ));
    out.push(with_image(
        "image_data_uri_bad_base64",
        json!({"uri": "data:image/png;base64,iVBOR!!!!"}),
        vec![],
        fails(&["image 0: invalid base64"]),
    ));
    out.push(with_image(
        "image_data_uri_not_an_image",
        json!({"uri": format!("data:image/png;base64,{}", base64(b"hello"))}),
        vec![],
        fails(&["image 0: cannot decode"]),
    ));
    out.push(with_image(
        "image_remote_uri",
        json!({"uri": "http://example.com/a.png"}),
        vec![],
        fails(&["image 0 (http://example.com/a.png): URI scheme 'http:' is not supported"]),
    ));
    let mut b = Builder::default();
    let bmp = b.view(b"BM\0\0\0\0\0\0\0\0\0\0\0\0");
    let mut doc = quad_doc(&mut b, json!({"material": 0}));
    doc["images"] = json!([{"bufferView": bmp, "mimeType": "image/bmp"}]);
    doc["textures"] = json!([{"source": 0}]);
    doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    out.push(gltf(
        "image_bmp",
        &b.document(doc),
        fails(&["image 0: Bmp images are not supported"]),
    ));

    let mut d = quad_gltf();
    d["extensionsUsed"] = json!(["KHR_materials_diffuse_transmission"]);
    d["extensionsRequired"] = json!(["KHR_materials_diffuse_transmission"]);
    out.push(gltf(
        "extension_required_unsupported",
        &d,
        fails(&[
            "requires glTF extension(s) rqr does not support: KHR_materials_diffuse_transmission",
        ]),
    ));
    let mut d = quad_gltf();
    d["extensionsUsed"] = json!(["KHR_materials_iridescence"]);
    out.push(gltf(
        "extension_optional_unsupported",
        &d,
        Expect::Loads {
            warning: Some("ignoring unsupported glTF extension(s): KHR_materials_iridescence"),
            render: true,
        },
    ));
}

#[test]
fn images_beyond_the_device_limit_fail_clearly() {
    let ctx = gpu();
    let limit = ctx.info().max_image_dimension_2d;
    let mut s = Scene {
        source: "big.gltf".into(),
        ..Default::default()
    };
    s.images.push(ImageData {
        width: limit + 1,
        height: 1,
        rgba8: Vec::new(),
        mips: Vec::new(),
        srgb: false,
        ktx2: None,
    });
    let err = GpuTextures::upload(&ctx, &s).err().expect("must fail");
    assert!(
        matches!(err, rqr::Error::Vk(VkError::Limit { needed, available, .. }) if needed == u64::from(limit) + 1 && available == u64::from(limit)),
        "{err:?}"
    );
    let msg = err.to_string();
    assert!(
        msg.contains("big.gltf") && msg.contains("image 0") && msg.contains("maxImageDimension2D"),
        "{msg}"
    );

    s.images[0] = ImageData {
        width: 4,
        height: 4,
        rgba8: vec![0; 12],
        mips: Vec::new(),
        srgb: false,
        ktx2: None,
    };
    let msg = GpuTextures::upload(&ctx, &s)
        .err()
        .expect("must fail")
        .to_string();
    assert!(msg.contains("12 bytes"), "{msg}");
    assert_validation_clean(&ctx);
}
