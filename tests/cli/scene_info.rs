//! `rqr info`: counts as text and JSON, scene choice, and clean failures on bad input.

use crate::support::scene_files;

use std::process::Command;

use serde_json::Value;

fn rqr(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_rqr"))
        .args(args)
        .env("RQR_NO_AUTOTUNE", "1")
        .output()
        .expect("running rqr")
}

fn info_json(args: &[&str]) -> Value {
    let mut all = vec!["info", "--json"];
    all.extend_from_slice(args);
    let out = rqr(&all);
    assert!(
        out.status.success(),
        "rqr {all:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON document on stdout")
}

#[test]
fn info_json_has_every_field() {
    let v = info_json(&[]);
    for key in [
        "meshes",
        "primitives",
        "geometries",
        "instances",
        "triangles",
        "unique_triangles",
        "materials",
        "textures",
        "lights",
        "cameras",
        "extensions_used",
        "extensions_unsupported",
        "bounds",
        "animations",
        "skins",
        "morphed_geometries",
    ] {
        assert!(v.get(key).is_some(), "missing {key} in {v}");
    }
    assert_eq!(v["source"], "built-in");
    assert_eq!(v["lights"], 2);
    assert_eq!(v["bounds"]["min"], serde_json::json!([-2.0, 0.0, -2.0]));
    assert_eq!(v["bounds"]["max"], serde_json::json!([2.0, 4.0, 2.0]));
}

#[test]
fn info_counts_instanced_and_unique_triangles() {
    let path = scene_files::asset("SimpleInstancing/SimpleInstancing.glb");
    let v = info_json(&[path.to_str().unwrap()]);
    assert_eq!(v["triangles"], 1500);
    assert_eq!(v["unique_triangles"], 12);
    assert_eq!(v["instances"], 125);
    assert_eq!(v["geometries"], 1);
    assert_eq!(
        v["extensions_used"],
        serde_json::json!(["EXT_mesh_gpu_instancing"])
    );

    let ms = scene_files::asset("MultipleScenes/MultipleScenes.gltf");
    let ms = ms.to_str().unwrap();
    assert_eq!(info_json(&[ms])["triangles"], 2);
    assert_eq!(info_json(&[ms, "--scene", "0"])["triangles"], 1);
}

#[test]
fn info_text_output() {
    let out = rqr(&["info"]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    for row in [
        "source",
        "triangles",
        "unique triangles",
        "materials",
        "lights",
        "bounds",
    ] {
        assert!(
            text.lines().any(|l| l.starts_with(row)),
            "no '{row}' row in:\n{text}"
        );
    }
}

#[test]
fn info_json_lists_each_extension_with_its_status() {
    let cc = scene_files::asset("ClearCoatTest/ClearCoatTest.glb");
    let v = info_json(&[cc.to_str().unwrap()]);
    assert_eq!(
        v["extensions"],
        serde_json::json!([{"name": "KHR_materials_clearcoat", "status": "supported"}])
    );
    // Optional unknown extensions are "ignored"; a required one is refused, and the JSON on
    // stdout still says which (exit status 1, the error on stderr).
    let dir = std::env::temp_dir().join(format!("rqr-info-ext-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut b = scene_files::Builder::default();
    let mut doc = scene_files::quad_doc(&mut b, serde_json::json!({}));
    doc["extensionsUsed"] =
        serde_json::json!(["KHR_materials_iridescence", "KHR_texture_transform"]);
    let optional = dir.join("optional.gltf");
    std::fs::write(&optional, scene_files::bytes(&b.document(doc.clone()))).unwrap();
    let v = info_json(&[optional.to_str().unwrap()]);
    assert_eq!(
        v["extensions"],
        serde_json::json!([
            {"name": "KHR_materials_iridescence", "status": "ignored"},
            {"name": "KHR_texture_transform", "status": "supported"},
        ])
    );
    doc["extensionsUsed"] = serde_json::json!(["KHR_materials_diffuse_transmission"]);
    doc["extensionsRequired"] = serde_json::json!(["KHR_materials_diffuse_transmission"]);
    let required = dir.join("required.gltf");
    std::fs::write(&required, scene_files::bytes(&b.document(doc))).unwrap();
    let out = rqr(&["info", "--json", required.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let v: Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    assert_eq!(
        v["extensions"],
        serde_json::json!([{"name": "KHR_materials_diffuse_transmission", "status": "unsupported-required"}])
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("KHR_materials_diffuse_transmission"));
    std::fs::remove_dir_all(&dir).ok();
}
