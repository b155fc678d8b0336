//! Bad-input cases of the material extensions rqr reads (KHR_materials_specular, _clearcoat,
//! _sheen, the volume's thickness texture) and of texture coordinate sets.

use serde_json::json;

use super::corpus::{Case, Expect};
use crate::scene_util::{asset, bytes, glb, quad_doc, Builder};

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

/// Out-of-range factors, wrong JSON types and dangling textures in extensions; broken
/// EXT_meshopt_compression views.
pub fn cases(out: &mut Vec<Case>) {
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
