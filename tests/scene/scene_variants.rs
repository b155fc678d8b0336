//! KHR_materials_variants: `LoadOptions::variant` / `--variant NAME` picks each primitive's
//! mapped material, `rqr info` lists the variants (unknown names and broken mappings are in the
//! bad-input binary, `extensions`).

use crate::support;

use std::time::Duration;

use crate::support::scene_files::{load_variant, variants_quad};
use glam::Vec4;
use rqr::scene::Scene;
use serde_json::json;

fn quad_colour(s: &Scene) -> Vec4 {
    s.materials[s.geometries[0].material as usize].base_color
}

#[test]
fn variant_selects_the_mapped_material() {
    let d = variants_quad(json!([1]));
    let plain = load_variant(&d, None).unwrap();
    assert_eq!(plain.variants, ["Red", "Green"]);
    assert_eq!(plain.variant, None);
    assert!(plain.extensions_unsupported.is_empty());
    assert_eq!(quad_colour(&plain), Vec4::ONE);
    let red = load_variant(&d, Some("Red")).unwrap();
    assert_eq!(red.variant, Some(0));
    assert_eq!(quad_colour(&red), Vec4::new(1.0, 0.0, 0.0, 1.0));
    let green = load_variant(&d, Some("Green")).unwrap();
    assert_eq!(quad_colour(&green), Vec4::new(0.0, 1.0, 0.0, 1.0));
}

#[test]
fn info_lists_variants_and_render_takes_one() {
    let dir = std::env::temp_dir().join(format!("rqr-variants-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("variants.gltf");
    std::fs::write(&file, variants_quad(json!([1]))).unwrap();
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
