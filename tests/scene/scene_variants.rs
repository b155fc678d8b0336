//! KHR_materials_variants: `LoadOptions::variant` / `--variant NAME` picks each primitive's
//! mapped material, `rqr info` lists the variants, unknown names and broken mappings fail
//! naming the file and the element.

use crate::support;

use std::time::Duration;

use crate::support::scene_files::{bytes, quad_doc, Builder};
use glam::Vec4;
use rqr::scene::{self, LoadOptions, Scene};
use serde_json::json;

/// A quad with three materials (white default, red, green) and variants "Red" and "Green"
/// mapping to them; `mapping_variants` is the Green mapping's variant list.
fn doc(mapping_variants: serde_json::Value) -> Vec<u8> {
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

fn load(doc: &[u8], variant: Option<&str>) -> Result<Scene, String> {
    let opts = LoadOptions {
        variant: variant.map(str::to_string),
        ..Default::default()
    };
    scene::load_slice(doc, None, "variants.gltf", &opts).map_err(|e| e.to_string())
}

fn quad_colour(s: &Scene) -> Vec4 {
    s.materials[s.geometries[0].material as usize].base_color
}

#[test]
fn variant_selects_the_mapped_material() {
    let d = doc(json!([1]));
    let plain = load(&d, None).unwrap();
    assert_eq!(plain.variants, ["Red", "Green"]);
    assert_eq!(plain.variant, None);
    assert!(plain.extensions_unsupported.is_empty());
    assert_eq!(quad_colour(&plain), Vec4::ONE);
    let red = load(&d, Some("Red")).unwrap();
    assert_eq!(red.variant, Some(0));
    assert_eq!(quad_colour(&red), Vec4::new(1.0, 0.0, 0.0, 1.0));
    let green = load(&d, Some("Green")).unwrap();
    assert_eq!(quad_colour(&green), Vec4::new(0.0, 1.0, 0.0, 1.0));
}

#[test]
fn bad_variants_fail_naming_file_and_element() {
    let e = load(&doc(json!([1])), Some("Blue")).unwrap_err();
    assert_eq!(
        e,
        "variants.gltf: root: variant 'Blue' does not exist (variants: Red, Green)"
    );
    let e = load(&doc(json!([7])), Some("Red")).unwrap_err();
    assert!(
        e.starts_with("variants.gltf: mesh 0 primitive 0")
            && e.contains("KHR_materials_variants: mapping 1 names variant 7, the file has 2"),
        "{e}"
    );
}

#[test]
fn info_lists_variants_and_render_takes_one() {
    let dir = std::env::temp_dir().join(format!("rqr-variants-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("variants.gltf");
    std::fs::write(&file, doc(json!([1]))).unwrap();
    let f = file.to_str().unwrap();
    let env = [("RQR_NO_AUTOTUNE", "1")];
    let limit = Duration::from_secs(120);
    let (out, _) = support::run_rqr(&["info", "--json", "--variant", "Green", f], &env, limit);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["variants"], json!(["Red", "Green"]));
    assert_eq!(v["variant"], json!("Green"));
    let (out, _) = support::run_rqr(&["info", f], &env, limit);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("variants           Red, Green"), "{text}");
    let png = dir.join("green.png");
    let (out, _) = support::run_rqr(
        &[
            "render",
            f,
            "--variant",
            "Green",
            "--width",
            "16",
            "--height",
            "16",
            "--output",
            png.to_str().unwrap(),
        ],
        &env,
        Duration::from_secs(300),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let img = image::open(&png).unwrap().to_rgba8();
    let centre = img.get_pixel(8, 8).0;
    assert!(
        centre[1] > centre[0] && centre[1] > centre[2],
        "green quad: {centre:?}"
    );
    let (out, _) = support::run_rqr(
        &[
            "render",
            f,
            "--variant",
            "Blue",
            "--width",
            "16",
            "--height",
            "16",
            "--output",
            png.to_str().unwrap(),
        ],
        &env,
        limit,
    );
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("variant 'Blue' does not exist"));
    std::fs::remove_dir_all(&dir).ok();
}
