//! Bad-input cases of the material extensions rqr reads (KHR_materials_specular, _clearcoat,
//! _sheen, the volume's thickness texture) and of texture coordinate sets; beside the corpus,
//! bad layer factors and KHR_materials_variants names and mappings through the loader.

use serde_json::json;

use super::corpus::{Case, Expect};
use rqr::scene::{self, LoadOptions};

use crate::support::scene_files::{
    asset, bytes, glb, load_variant, quad_doc, variants_quad, Builder,
};

fn material_case(name: &str, material: serde_json::Value, needles: &[&'static str]) -> Case {
    let mut b = Builder::default();
    let mut doc = quad_doc(&mut b, json!({"material": 0}));
    doc["materials"] = json!([material]);
    Case {
        name: name.to_string(),
        files: vec![("scene.gltf".into(), bytes(&b.document(doc)))],
        expect: Expect::Fails(needles.to_vec()),
    }
}

/// `BoxTextured_meshopt.glb` (EXT_meshopt_compression) with view `view`'s extension field
/// `field` set to `value`.
fn meshopt_case(
    name: &str,
    view: usize,
    field: &str,
    value: serde_json::Value,
    needles: &[&'static str],
) -> Case {
    let data = std::fs::read(asset("BoxTextured_meshopt/BoxTextured_meshopt.glb")).unwrap();
    let json_len = u32::from_le_bytes(data[12..16].try_into().unwrap()) as usize;
    let mut doc: serde_json::Value = serde_json::from_slice(&data[20..20 + json_len]).unwrap();
    let bin = 20 + json_len;
    let bin_len = u32::from_le_bytes(data[bin..bin + 4].try_into().unwrap()) as usize;
    doc["bufferViews"][view]["extensions"]["EXT_meshopt_compression"][field] = value;
    Case {
        name: name.to_string(),
        files: vec![(
            "scene.glb".into(),
            glb(&bytes(&doc), Some(&data[bin + 8..bin + 8 + bin_len])),
        )],
        expect: Expect::Fails(needles.to_vec()),
    }
}

/// `CesiumMan_Draco` (KHR_draco_mesh_compression), without its texture, with `edit`
/// applied to its JSON and its buffer.
fn draco_case(
    name: &str,
    edit: impl Fn(&mut serde_json::Value, &mut Vec<u8>),
    needles: &[&'static str],
) -> Case {
    let dir = asset("CesiumMan_Draco");
    let mut doc: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("CesiumMan.gltf")).unwrap()).unwrap();
    let mut bin = std::fs::read(dir.join("CesiumMan_data.bin")).unwrap();
    doc.as_object_mut().unwrap().remove("images");
    doc.as_object_mut().unwrap().remove("textures");
    doc["materials"] = json!([{}]);
    edit(&mut doc, &mut bin);
    Case {
        name: name.to_string(),
        files: vec![
            ("scene.gltf".into(), bytes(&doc)),
            ("CesiumMan_data.bin".into(), bin),
        ],
        expect: Expect::Fails(needles.to_vec()),
    }
}

/// A quad whose base colour is `tex.ktx2` (KHR_texture_basisu, required): StainedGlassLamp's
/// ETC1S hardware texture with `edit` applied.
fn ktx2_case(name: &str, edit: impl Fn(&mut Vec<u8>), expect: Expect) -> Case {
    let mut ktx = std::fs::read(asset(
        "StainedGlassLamp_KTX/StainedGlassLamp_hardware_basecolor.ktx2",
    ))
    .unwrap();
    edit(&mut ktx);
    let mut b = Builder::default();
    let mut doc = quad_doc(&mut b, json!({"material": 0}));
    let uv = b.floats(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0], "VEC2");
    doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(uv);
    doc["images"] = json!([{"uri": "tex.ktx2", "mimeType": "image/ktx2"}]);
    doc["textures"] = json!([{"extensions": {"KHR_texture_basisu": {"source": 0}}}]);
    doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    doc["extensionsUsed"] = json!(["KHR_texture_basisu"]);
    doc["extensionsRequired"] = json!(["KHR_texture_basisu"]);
    Case {
        name: name.to_string(),
        files: vec![
            ("scene.gltf".into(), bytes(&b.document(doc))),
            ("tex.ktx2".into(), ktx),
        ],
        expect,
    }
}

/// Out-of-range factors, wrong JSON types and dangling textures in extensions; broken
/// EXT_meshopt_compression views; broken KHR_draco_mesh_compression streams; broken KTX2
/// files.
pub fn cases(out: &mut Vec<Case>) {
    let put32 =
        |k: &mut Vec<u8>, at: usize, v: u32| k[at..at + 4].copy_from_slice(&v.to_le_bytes());
    out.push(ktx2_case(
        "ktx2_etc1s",
        |_| {},
        Expect::Loads {
            warning: None,
            render: true,
        },
    ));
    out.push(ktx2_case(
        "ktx2_wrong_identifier",
        |k| k[5] = b'1',
        Expect::Fails(vec!["image 0 (tex.ktx2): KTX2 header: not a KTX2 file"]),
    ));
    out.push(ktx2_case(
        "ktx2_level_beyond_file",
        // Level 3's byte length (level index entry 3: bytes 80 + 3*24 + 8..).
        |k| k[160..168].copy_from_slice(&(1u64 << 33).to_le_bytes()),
        Expect::Fails(vec![
            "image 0 (tex.ktx2): KTX2 level 3: bytes",
            "beyond the end of the file",
        ]),
    ));
    out.push(ktx2_case(
        "ktx2_zlib_supercompression",
        |k| put32(k, 44, 3),
        Expect::Fails(vec![
            "image 0 (tex.ktx2): KTX2 supercompression scheme 3 is not supported for ETC1S",
        ]),
    ));
    out.push(ktx2_case(
        "ktx2_cut_in_codebooks",
        |k| k.truncate(400),
        Expect::Fails(vec!["image 0 (tex.ktx2): KTX2"]),
    ));
    out.push(meshopt_case(
        "meshopt_bad_filter",
        1,
        "filter",
        json!("WAVELET"),
        &["buffer view 1: EXT_meshopt_compression: unknown filter 'WAVELET'"],
    ));
    out.push(meshopt_case(
        "meshopt_bad_mode",
        4,
        "mode",
        json!("STRIPS"),
        &["buffer view 4: EXT_meshopt_compression: unknown mode 'STRIPS'"],
    ));
    out.push(meshopt_case(
        "meshopt_truncated",
        4,
        "byteLength",
        json!(5),
        &["buffer view 4: EXT_meshopt_compression: the TRIANGLES data cannot be decoded"],
    ));
    out.push(meshopt_case(
        "meshopt_huge_count",
        2,
        "count",
        json!(1u64 << 40),
        &["buffer view 2: EXT_meshopt_compression", "decoded bytes"],
    ));
    out.push(draco_case(
        "draco_truncated",
        |d, _| d["bufferViews"][4]["byteLength"] = json!(1000),
        &["mesh 0 primitive 0: KHR_draco_mesh_compression: the Draco stream in buffer view 4 cannot be decoded"],
    ));
    out.push(draco_case(
        "draco_buffer_cut",
        |_, bin| bin.truncate(41344 + 2000),
        &["buffer 0 (CesiumMan_data.bin): byteLength is 89512 but only 43344 bytes are available"],
    ));
    out.push(draco_case(
        "draco_attribute_id_missing",
        |d, _| {
            d["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]
                ["attributes"]["NORMAL"] = json!(17)
        },
        &["mesh 0 primitive 0: KHR_draco_mesh_compression: attribute NORMAL names Draco attribute id 17, which the stream does not have"],
    ));
    out.push(draco_case(
        "draco_garbage_stream",
        |_, bin| {
            // Keep the header, scramble the connectivity and attributes.
            let mut x = 0x9e37_79b9u32;
            for b in &mut bin[41344 + 24..] {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                *b = x as u8;
            }
        },
        &["mesh 0 primitive 0: KHR_draco_mesh_compression: the Draco stream in buffer view 4 cannot be decoded"],
    ));
    out.push(material_case(
        "specular_factor_out_of_range",
        json!({"extensions": {"KHR_materials_specular": {"specularFactor": -1}}}),
        &[
            "material 0",
            "KHR_materials_specular specularFactor -1 is outside [0, 1]",
        ],
    ));
    out.push(material_case(
        "clearcoat_factor_not_a_number",
        json!({"extensions": {"KHR_materials_clearcoat": {"clearcoatFactor": "thick"}}}),
        &["material 0", "KHR_materials_clearcoat"],
    ));
    out.push(material_case(
        "sheen_texture_dangling",
        json!({"extensions": {"KHR_materials_sheen": {"sheenColorTexture": {"index": 9}}}}),
        &["material 0 sheenColorTexture", "texture 9 does not exist"],
    ));
    out.push(material_case(
        "thickness_texture_dangling",
        json!({"extensions": {"KHR_materials_volume": {"thicknessFactor": 1, "thicknessTexture": {"index": 3}}}}),
        &["material 0 thicknessTexture", "texture 3 does not exist"],
    ));
    out.push(material_case(
        "clearcoat_normal_texture_dangling",
        json!({"extensions": {"KHR_materials_clearcoat": {"clearcoatFactor": 1, "clearcoatNormalTexture": {"index": 1, "scale": 2}}}}),
        &["material 0 clearcoatNormalTexture", "texture 1 does not exist"],
    ));
}

#[test]
fn bad_layer_factors_name_material_and_extension() {
    for (ext, body, needle) in [
        (
            "KHR_materials_specular",
            json!({"specularFactor": 2.0}),
            "specularFactor",
        ),
        (
            "KHR_materials_clearcoat",
            json!({"clearcoatFactor": "a lot"}),
            "KHR_materials_clearcoat",
        ),
        (
            "KHR_materials_sheen",
            json!({"sheenColorFactor": [2, 0, 0]}),
            "sheenColorFactor",
        ),
        (
            "KHR_materials_clearcoat",
            json!({"clearcoatTexture": {"index": 7}}),
            "clearcoatTexture",
        ),
    ] {
        let mut b = Builder::default();
        let mut doc = quad_doc(&mut b, json!({"material": 0}));
        doc["materials"] = json!([{"extensions": {ext: body}}]);
        let e = scene::load_slice(
            &bytes(&b.document(doc)),
            None,
            "bad.gltf",
            &LoadOptions::default(),
        )
        .expect_err(ext)
        .to_string();
        assert!(
            e.starts_with("bad.gltf: material 0") && e.contains(needle),
            "{ext}: {e}"
        );
    }
}

#[test]
fn bad_variants_fail_naming_file_and_element() {
    let e = load_variant(&variants_quad(json!([1])), Some("Blue")).unwrap_err();
    assert_eq!(
        e,
        "variants.gltf: root: variant 'Blue' does not exist (variants: Red, Green)"
    );
    let e = load_variant(&variants_quad(json!([7])), Some("Red")).unwrap_err();
    assert!(
        e.starts_with("variants.gltf: mesh 0 primitive 0")
            && e.contains("KHR_materials_variants: mapping 1 names variant 7, the file has 2"),
        "{e}"
    );
}
