//! Bad input: every broken file yields a `SceneError` that names the file and the element,
//! never a panic.

use crate::support::scene_files;

use rqr::scene::{self, LoadOptions, Scene, SceneError};
use scene_files::{asset, bytes, png, png_header, quad_doc, Builder};
use serde_json::{json, Value};

fn load_doc(doc: &Value) -> Result<Scene, SceneError> {
    scene::load_slice(&bytes(doc), None, "bad.gltf", &LoadOptions::default())
}

/// Loads `doc` and returns the error message, asserting it names the file.
fn err(doc: &Value) -> String {
    let e = load_doc(doc).expect_err("loading must fail").to_string();
    assert!(
        e.starts_with("bad.gltf: "),
        "error does not name the file: {e}"
    );
    e
}

fn quad() -> (Builder, Value) {
    let mut b = Builder::default();
    let doc = quad_doc(&mut b, json!({}));
    (b, doc)
}

/// A change to a document, paired with the error it must cause.
type Edit = fn(&mut Value);

/// A textured quad whose only image is `image` (a JSON image object, e.g. with a uri).
fn textured(b: &mut Builder, image: Value) -> Value {
    let mut doc = quad_doc(b, json!({"material": 0}));
    doc["images"] = json!([image]);
    doc["textures"] = json!([{"source": 0}]);
    doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    doc
}

#[test]
fn missing_file() {
    let path = asset("does/not/exist.gltf");
    let e = scene::load(&path, &LoadOptions::default()).unwrap_err();
    assert!(matches!(e, SceneError::Io { .. }));
    let msg = e.to_string();
    assert!(
        msg.contains("does/not/exist.gltf") && msg.contains("cannot read"),
        "{msg}"
    );
}

#[test]
fn truncated_glb_every_length() {
    let full = std::fs::read(asset("Box/Box.glb")).unwrap();
    assert!(scene::load_slice(&full, None, "Box.glb", &LoadOptions::default()).is_ok());
    for len in 0..full.len() {
        let r = scene::load_slice(&full[..len], None, "Box.glb", &LoadOptions::default());
        let e = r
            .err()
            .unwrap_or_else(|| panic!("prefix of {len} bytes loaded"))
            .to_string();
        assert!(e.starts_with("Box.glb: "), "{len}: {e}");
    }
    let e = scene::load_slice(&full[..100], None, "Box.glb", &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("truncated GLB"), "{e}");
}

#[test]
fn truncated_and_malformed_json() {
    let (b, doc) = quad();
    let text = bytes(&b.document(doc));
    for len in (0..text.len() - 1).step_by(7) {
        let e = scene::load_slice(&text[..len], None, "bad.gltf", &LoadOptions::default())
            .err()
            .unwrap_or_else(|| panic!("prefix of {len} bytes loaded"))
            .to_string();
        assert!(e.starts_with("bad.gltf: "), "{e}");
    }
    let e = scene::load_slice(b"{\"asset\": 5}", None, "bad.gltf", &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("bad.gltf: invalid glTF JSON"), "{e}");
    let e = err(&json!({"asset": {"version": "1.0"}}));
    assert!(e.contains("version 1.0"), "{e}");
    // A GLB whose first chunk is not JSON.
    let mut glb = scene_files::glb(b"{}", None);
    glb[16..20].copy_from_slice(b"BIN\0");
    let e = scene::load_slice(&glb, None, "bad.glb", &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("bad.glb: malformed GLB"), "{e}");
}

#[test]
fn buffer_shorter_than_the_accessor_needs() {
    let (b, doc) = quad();
    let mut d = b.document(doc.clone());
    d["accessors"][0]["count"] = json!(10);
    let e = err(&d);
    assert!(
        e.contains("mesh 0 primitive 0: POSITION accessor 0") && e.contains("10 elements"),
        "{e}"
    );

    // Declared byteLength longer than the data behind the URI.
    let mut d = b.document(doc.clone());
    d["buffers"][0]["byteLength"] = json!(b.bin.len() + 100);
    let e = err(&d);
    assert!(e.contains("buffer 0: byteLength"), "{e}");

    // A buffer view reaching past its buffer.
    let mut d = b.document(doc.clone());
    d["bufferViews"][0]["byteOffset"] = json!(1u64 << 40);
    let e = err(&d);
    assert!(
        e.contains("POSITION accessor 0: buffer view 0") && e.contains("exceeds buffer 0"),
        "{e}"
    );

    // An accessor offset past its view, and a stride smaller than the element.
    let mut d = b.document(doc.clone());
    d["accessors"][0]["byteOffset"] = json!(1000);
    assert!(err(&d).contains("past the end of buffer view 0"));
    let mut d = b.document(doc.clone());
    d["bufferViews"][0]["byteStride"] = json!(4);
    assert!(err(&d).contains("byteStride 4 is smaller than the 12-byte element"));

    // GLB without a BIN chunk while buffer 0 needs it.
    let mut d = b.document(doc);
    d["buffers"] = json!([{"byteLength": 12}]);
    let e = scene::load_slice(
        &scene_files::glb(&bytes(&d), None),
        None,
        "bad.glb",
        &LoadOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("buffer 0: has no uri and the file has no GLB BIN chunk"),
        "{e}"
    );
}

#[test]
fn absurd_sizes_are_capped() {
    let (b, doc) = quad();
    // Count × stride beyond the buffer (and beyond any sane allocation).
    let mut d = b.document(doc.clone());
    d["accessors"][0]["count"] = json!(4_000_000_000u64);
    let e = err(&d);
    assert!(
        e.contains("POSITION accessor 0") && e.contains("limit"),
        "{e}"
    );
    let mut d = b.document(doc.clone());
    d["accessors"][0]["count"] = json!(100_000_000u64);
    let e = err(&d);
    assert!(
        e.contains("POSITION accessor 0: buffer view 0 is 48 bytes"),
        "{e}"
    );
    // No buffer view: all zeros, still capped.
    let mut d = b.document(doc);
    d["accessors"][0] = json!({"componentType": 5126, "count": 1u64 << 40, "type": "VEC3",
        "min": [0, 0, 0], "max": [0, 0, 0]});
    let e = err(&d);
    assert!(e.contains("exceeds rqr's limit"), "{e}");
}

#[test]
fn indices_out_of_range() {
    let mut b = Builder::default();
    let pos = b.floats(
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0],
        "VEC3",
    );
    let idx = b.indices_u16(&[0, 1, 2, 0, 2, 7]);
    let doc = json!({
        "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos}, "indices": idx}]}],
    });
    let e = err(&b.document(doc));
    assert_eq!(
        e,
        "bad.gltf: mesh 0 primitive 0: index 7 out of range (4 vertices)"
    );
    // Float indices are refused too.
    let (b, doc) = quad();
    let mut d = b.document(doc);
    d["meshes"][0]["primitives"][0]["indices"] = json!(0);
    let e = err(&d);
    assert!(
        e.contains("mesh 0 primitive 0: indices accessor 0: indices must be SCALAR"),
        "{e}"
    );
}

#[test]
fn sparse_index_out_of_range() {
    let (mut b, mut doc) = quad();
    let si = b.indices_u16(&[9]);
    let sv = b.floats(&[5.0, 5.0, 5.0], "VEC3");
    let si_view = b.accessors[si]["bufferView"].clone();
    let sv_view = b.accessors[sv]["bufferView"].clone();
    let mut d = b.document(doc.clone());
    d["accessors"][0]["sparse"] = json!({"count": 1,
        "indices": {"bufferView": si_view, "componentType": 5123},
        "values": {"bufferView": sv_view}});
    let e = err(&d);
    assert!(
        e.contains("POSITION accessor 0: sparse index 9 out of range (4 elements)"),
        "{e}"
    );
    doc["accessors"] = d["accessors"].clone();
    d["accessors"][0]["sparse"]["count"] = json!(5);
    assert!(err(&d).contains("sparse count 5 exceeds the accessor count 4"));
}

#[test]
fn non_finite_positions() {
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let mut b = Builder::default();
        let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, bad, 0.0, 1.0, 1.0, 0.0], "VEC3");
        b.accessors[pos]["max"] = json!([1, 1, 0]);
        b.accessors[pos]["min"] = json!([0, 0, 0]);
        let doc = json!({
            "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}],
        });
        let e = err(&b.document(doc));
        assert!(
            e.contains("mesh 0 primitive 0: POSITION 1 is not finite"),
            "{e}"
        );
    }
    // Non-finite node transforms too.
    let (b, mut doc) = quad();
    doc["nodes"][0]["matrix"] = json!([1e38, 0, 0, 0, 0, 1e38, 0, 0, 0, 0, 1e38, 0, 0, 0, 0, 1]);
    doc["nodes"] = json!([{"children": [1], "matrix": [1e38, 0, 0, 0, 0, 1e38, 0, 0, 0, 0, 1e38, 0, 0, 0, 0, 1]}, doc["nodes"][0].clone()]);
    doc["scenes"] = json!([{"nodes": [0]}]);
    let e = err(&b.document(doc));
    assert!(e.contains("node 1: world transform is not finite"), "{e}");
}

#[test]
fn missing_or_undecodable_images() {
    let dir = std::env::temp_dir().join(format!("rqr-bad-images-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut b = Builder::default();
    let doc = textured(&mut b, json!({"uri": "missing.png"}));
    let doc = b.document(doc);
    let path = dir.join("scene.gltf");
    std::fs::write(&path, bytes(&doc)).unwrap();
    let e = scene::load(&path, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("scene.gltf: image 0 (missing.png): cannot read"),
        "{e}"
    );

    // Garbage bytes, a truncated PNG, and a format glTF does not allow.
    let good = png(4, 4, &[200; 64]);
    for (data, needle) in [
        (b"definitely not an image".to_vec(), "cannot decode"),
        (good[..good.len() - 20].to_vec(), "cannot decode"),
        (b"BM\0\0\0\0\0\0\0\0\0\0\0\0".to_vec(), "not supported"),
    ] {
        let mut b = Builder::default();
        let view = b.view(&data);
        let doc = textured(&mut b, json!({"bufferView": view, "mimeType": "image/png"}));
        let e = err(&b.document(doc));
        assert!(
            e.contains("bad.gltf: image 0: ") && e.contains(needle),
            "{e}"
        );
    }
    let mut b = Builder::default();
    let view = b.view(b"no mime type either");
    let doc = textured(&mut b, json!({"bufferView": view}));
    assert!(err(&b.document(doc))
        .contains("image 0: not a PNG, JPEG, WebP or KTX2 image (mimeType absent)"));
    // An external file referenced from bytes with no base directory.
    let mut b = Builder::default();
    let doc = textured(&mut b, json!({"uri": "tex.png"}));
    let e = err(&b.document(doc));
    assert!(
        e.contains("image 0 (tex.png)") && e.contains("no base directory"),
        "{e}"
    );
    // Remote URIs are not fetched; broken data URIs are reported.
    let mut b = Builder::default();
    let doc = textured(&mut b, json!({"uri": "https://example.com/a.png"}));
    assert!(err(&b.document(doc)).contains("URI scheme 'https:' is not supported"));
    let mut b = Builder::default();
    let doc = textured(&mut b, json!({"uri": "data:image/png;base64,@@@"}));
    assert!(err(&b.document(doc)).contains("image 0: invalid base64"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn oversized_images() {
    let mut b = Builder::default();
    let view = b.view(&png_header(20000, 20000));
    let doc = textured(&mut b, json!({"bufferView": view, "mimeType": "image/png"}));
    let e = err(&b.document(doc));
    assert!(
        e.contains("image 0: 20000x20000 is outside rqr's 1..=16384"),
        "{e}"
    );
    // Within the limit, the same header fails at decoding (no pixel data), not earlier.
    let mut b = Builder::default();
    let view = b.view(&png_header(16384, 2));
    let doc = textured(&mut b, json!({"bufferView": view, "mimeType": "image/png"}));
    assert!(err(&b.document(doc)).contains("image 0: cannot decode"));

    let mut b = Builder::default();
    let view = b.view(&png(8, 8, &[0; 256]));
    let doc = textured(&mut b, json!({"bufferView": view}));
    let doc = b.document(doc);
    let opts = LoadOptions {
        max_image_size: 4,
        ..Default::default()
    };
    let e = scene::load_slice(&bytes(&doc), None, "bad.gltf", &opts)
        .unwrap_err()
        .to_string();
    assert!(e.contains("8x8 is outside rqr's 1..=4"), "{e}");
    assert!(load_doc(&doc).is_ok());
}

#[test]
fn node_cycles() {
    let (b, mut doc) = quad();
    doc["nodes"] = json!([{"children": [1]}, {"children": [2], "mesh": 0}, {"children": [1]}]);
    doc["scenes"] = json!([{"nodes": [0]}]);
    let e = err(&b.document(doc.clone()));
    assert!(
        e.contains("node hierarchy has a cycle: node 1 -> node 2 -> node 1"),
        "{e}"
    );
    doc["nodes"] = json!([{"children": [0], "mesh": 0}]);
    let e = err(&b.document(doc.clone()));
    assert!(
        e.contains("node 0: node hierarchy has a cycle: node 0 -> node 0"),
        "{e}"
    );
    // A cycle outside the chosen scene is still an invalid file.
    doc["nodes"] = json!([{"mesh": 0}, {"children": [2]}, {"children": [1]}]);
    doc["scenes"] = json!([{"nodes": [0]}]);
    assert!(err(&b.document(doc)).contains("cycle"));
}

#[test]
fn exponential_node_sharing_is_capped() {
    // Each node lists the next one twice: 2^40 paths to the mesh.
    let (b, mut doc) = quad();
    let mut nodes: Vec<Value> = (0..40)
        .map(|i| json!({"children": [i + 1, i + 1]}))
        .collect();
    nodes.push(json!({"mesh": 0}));
    doc["nodes"] = json!(nodes);
    doc["scenes"] = json!([{"nodes": [0]}]);
    let e = err(&b.document(doc));
    assert!(e.contains("expands to more than"), "{e}");
}

#[test]
fn dangling_references() {
    let (b, doc) = quad();
    let base = b.document(doc);
    let cases: Vec<(Edit, &str)> = vec![
        (
            |d| d["nodes"][0]["mesh"] = json!(5),
            "node 0: mesh 5 does not exist (1 meshes)",
        ),
        (
            |d| d["nodes"][0]["children"] = json!([9]),
            "node 0: child 9 does not exist (1 nodes)",
        ),
        (
            |d| d["scenes"][0]["nodes"] = json!([3]),
            "scene 0: node 3 does not exist (1 nodes)",
        ),
        (
            |d| d["scene"] = json!(4),
            "scene 4 (the file's default scene): does not exist (the file has 1 scenes)",
        ),
        (
            |d| d["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(42),
            "mesh 0 primitive 0: NORMAL accessor 42: does not exist (2 accessors)",
        ),
        (
            |d| d["meshes"][0]["primitives"][0]["material"] = json!(2),
            "mesh 0 primitive 0: material 2 does not exist (0 materials)",
        ),
        (
            |d| d["accessors"][0]["bufferView"] = json!(17),
            "POSITION accessor 0: buffer view 17 does not exist (2 buffer views)",
        ),
        (
            |d| {
                d["materials"] =
                    json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 3}}}]);
                d["meshes"][0]["primitives"][0]["material"] = json!(0);
            },
            "material 0 baseColorTexture: texture 3 does not exist (0 textures)",
        ),
        (
            |d| {
                d["materials"] = json!([{"normalTexture": {"index": 0}}]);
                d["textures"] = json!([{"source": 2}]);
                d["meshes"][0]["primitives"][0]["material"] = json!(0);
            },
            "texture 0: image 2 does not exist (0 images)",
        ),
        (
            |d| {
                d["nodes"][0]["camera"] = json!(1);
            },
            "camera 1 (node 0): does not exist (0 cameras)",
        ),
        (
            |d| d["nodes"][0]["extensions"] = json!({"KHR_lights_punctual": {"light": 0}}),
            "light 0 (node 0): does not exist (0 lights)",
        ),
    ];
    for (edit, want) in cases {
        let mut d = base.clone();
        edit(&mut d);
        let e = err(&d);
        assert!(e.contains(want), "want '{want}' in '{e}'");
    }
}

#[test]
fn invalid_values() {
    let (b, doc) = quad();
    let base = b.document(doc);
    let cases: Vec<(Edit, &str)> = vec![
        (
            |d| {
                d["cameras"] =
                    json!([{"type": "perspective", "perspective": {"yfov": 4.0, "znear": 0.1}}]);
                d["nodes"][0]["camera"] = json!(0);
            },
            "camera 0 (node 0): yfov 4 is outside (0, π)",
        ),
        (
            |d| {
                d["extensions"] = json!({"KHR_lights_punctual": {"lights": [
                    {"type": "spot", "spot": {"innerConeAngle": 0.8, "outerConeAngle": 0.5}}]}});
                d["nodes"][0]["extensions"] = json!({"KHR_lights_punctual": {"light": 0}});
            },
            "light 0 (node 0): spot cone angles",
        ),
        (
            |d| d["nodes"][0]["rotation"] = json!([0, 0, 0, 0]),
            "node 0: rotation is a zero quaternion",
        ),
        (
            |d| d["meshes"][0]["primitives"][0]["mode"] = json!(9),
            "mesh 0 primitive 0: invalid mode",
        ),
        (
            |d| {
                d["nodes"][0]["extensions"] = json!({"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": 0, "SCALE": 1}}})
            },
            "node 0 EXT_mesh_gpu_instancing: SCALE accessor 1 has 1 components, expected 3",
        ),
    ];
    for (edit, want) in cases {
        let mut d = base.clone();
        edit(&mut d);
        let e = err(&d);
        assert!(e.contains(want), "want '{want}' in '{e}'");
    }
}

#[test]
fn required_and_optional_extensions() {
    let (b, mut doc) = quad();
    doc["extensionsUsed"] = json!([
        "KHR_materials_diffuse_transmission",
        "KHR_materials_iridescence",
        "KHR_texture_transform"
    ]);
    doc["extensionsRequired"] = json!([
        "KHR_materials_diffuse_transmission",
        "KHR_texture_transform"
    ]);
    let e = load_doc(&b.document(doc.clone())).unwrap_err();
    assert!(
        matches!(&e, SceneError::UnsupportedExtensions { extensions, .. } if extensions == &["KHR_materials_diffuse_transmission"])
    );
    assert_eq!(
        e.to_string(),
        "bad.gltf: requires glTF extension(s) rqr does not support: KHR_materials_diffuse_transmission"
    );
    // Optional unsupported extensions load, and are reported.
    doc["extensionsRequired"] = json!([
        "KHR_texture_transform",
        "KHR_mesh_quantization",
        "EXT_mesh_gpu_instancing"
    ]);
    let s = load_doc(&b.document(doc)).unwrap();
    assert_eq!(
        s.extensions_unsupported,
        vec![
            "KHR_materials_diffuse_transmission",
            "KHR_materials_iridescence"
        ]
    );
    assert_eq!(s.extensions_used.len(), 3);
}

#[test]
fn mutated_files_never_panic() {
    // Deterministic byte mutations of a small GLB with an embedded PNG: every outcome must
    // be a Scene or a SceneError.
    let mut b = Builder::default();
    let view = b.view(&png(4, 4, &[128; 64]));
    let uv = b.floats(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0], "VEC2");
    let mut doc = textured(&mut b, json!({"bufferView": view, "mimeType": "image/png"}));
    doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(uv);
    doc["materials"][0]["normalTexture"] = json!({"index": 0});
    let glb = b.glb(doc);
    let opts = LoadOptions {
        max_image_size: 64,
        ..Default::default()
    };
    assert!(scene::load_slice(&glb, None, "fuzz.glb", &opts).is_ok());
    // RQR_FUZZ_ITERS / RQR_FUZZ_SEED run longer or different campaigns locally.
    let env = |k: &str, d: u64| {
        std::env::var(k)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(d)
    };
    let iterations = env("RQR_FUZZ_ITERS", 3000);
    let mut state = env("RQR_FUZZ_SEED", 0x2545_F491_4F6C_DD1D).max(1);
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let (mut ok, mut failed) = (0, 0);
    for _ in 0..iterations {
        let mut data = glb.clone();
        for _ in 0..1 + next() % 4 {
            let at = (next() % data.len() as u64) as usize;
            data[at] = match next() % 4 {
                0 => 0,
                1 => 0xFF,
                2 => data[at] ^ (1 << (next() % 8)),
                _ => next() as u8,
            };
        }
        match scene::load_slice(&data, None, "fuzz.glb", &opts) {
            Ok(_) => ok += 1,
            Err(e) => {
                assert!(e.to_string().starts_with("fuzz.glb: "), "{e}");
                failed += 1;
            }
        }
    }
    assert!(ok > 0 && failed > 0, "ok {ok}, failed {failed}");
}

/// Collects JSON pointers to every number in `v`.
fn number_paths(v: &Value, path: String, out: &mut Vec<String>) {
    match v {
        Value::Number(_) => out.push(path),
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                number_paths(x, format!("{path}/{i}"), out);
            }
        }
        Value::Object(o) => {
            for (k, x) in o {
                number_paths(x, format!("{path}/{k}"), out);
            }
        }
        _ => {}
    }
}

#[test]
fn mutated_json_values_never_panic() {
    // A document using most features, then numbers replaced by awkward values.
    let mut b = Builder::default();
    let view = b.view(&png(4, 4, &[90; 64]));
    let uv = b.floats(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0], "VEC2");
    let normals = b.floats(&[0.0, 0.0, 1.0].repeat(4), "VEC3");
    let translations = b.floats(&[0.0, 0.0, 0.0, 2.0, 0.0, 0.0], "VEC3");
    let rotations = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0], "VEC4");
    let sparse_idx = b.indices_u16(&[1]);
    let sparse_val = b.floats(&[1.5, 0.0, 0.0], "VEC3");
    let mut doc = textured(&mut b, json!({"bufferView": view, "mimeType": "image/png"}));
    let prim = &mut doc["meshes"][0]["primitives"][0];
    prim["attributes"]["TEXCOORD_0"] = json!(uv);
    prim["attributes"]["NORMAL"] = json!(normals);
    let pos = prim["attributes"]["POSITION"].as_u64().unwrap() as usize;
    let strip = json!({"attributes": {"POSITION": pos}, "mode": 5, "material": 0});
    doc["meshes"][0]["primitives"] = json!([doc["meshes"][0]["primitives"][0].clone(), strip]);
    doc["materials"][0]["normalTexture"] = json!({"index": 0, "texCoord": 0,
        "extensions": {"KHR_texture_transform": {"offset": [0.1, 0.2], "rotation": 0.3, "scale": [2, 2]}}});
    doc["samplers"] =
        json!([{"magFilter": 9728, "minFilter": 9987, "wrapS": 33071, "wrapT": 33648}]);
    doc["textures"][0]["sampler"] = json!(0);
    doc["cameras"] = json!([{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.1, "zfar": 50}},
        {"type": "orthographic", "orthographic": {"xmag": 1, "ymag": 1, "znear": 0, "zfar": 10}}]);
    doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"type": "spot", "intensity": 5, "range": 9, "spot": {"innerConeAngle": 0.1, "outerConeAngle": 0.7}},
        {"type": "point", "intensity": 5}]}});
    doc["nodes"] = json!([
        {"mesh": 0, "children": [1, 2], "extensions": {"EXT_mesh_gpu_instancing":
            {"attributes": {"TRANSLATION": translations, "ROTATION": rotations}}}},
        {"camera": 0, "translation": [0, 0, 5], "extensions": {"KHR_lights_punctual": {"light": 0}}},
        {"camera": 1, "rotation": [0, 0.38, 0, 0.92], "children": [3]},
        {"matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 1, 2, 3, 1], "mesh": 0,
         "extensions": {"KHR_lights_punctual": {"light": 1}}},
    ]);
    let mut doc = b.document(doc);
    let si_view = b.accessors[sparse_idx]["bufferView"].clone();
    let sv_view = b.accessors[sparse_val]["bufferView"].clone();
    doc["accessors"][pos]["sparse"] = json!({"count": 1,
        "indices": {"bufferView": si_view, "componentType": 5123},
        "values": {"bufferView": sv_view}});
    // The data URI buffer is not mutated (its bytes are covered by the GLB test).
    let s = load_doc(&doc).expect("the unmutated document loads");
    assert_eq!(s.instances.len(), 6);
    let mut paths = Vec::new();
    number_paths(&doc, String::new(), &mut paths);
    let awkward = [
        json!(0),
        json!(1),
        json!(2),
        json!(3),
        json!(4),
        json!(5),
        json!(6),
        json!(-1),
        json!(255),
        json!(65535),
        json!(4294967295u64),
        json!(1u64 << 40),
        json!(1e30),
        json!(-1e30),
        json!(0.5),
        json!(1e-30),
        json!(5120),
        json!(5123),
        json!(5125),
        json!(5126),
        json!(9728),
        json!(33071),
    ];
    let env = |k: &str, d: u64| {
        std::env::var(k)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(d)
    };
    let iterations = env("RQR_FUZZ_ITERS", 4000);
    let mut state = env("RQR_FUZZ_SEED", 0x9E37_79B9_7F4A_7C15).max(1);
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let (mut ok, mut failed) = (0, 0);
    for _ in 0..iterations {
        let mut d = doc.clone();
        for _ in 0..1 + next() % 3 {
            let p = &paths[(next() % paths.len() as u64) as usize];
            *d.pointer_mut(p).unwrap() = awkward[(next() % awkward.len() as u64) as usize].clone();
        }
        match load_doc(&d) {
            Ok(s) => {
                ok += 1;
                assert!(s.instances.iter().all(|i| i.transform.is_finite()));
                assert!(s
                    .geometries
                    .iter()
                    .all(|g| g.indices.iter().all(|&i| (i as usize) < g.positions.len())));
            }
            Err(e) => {
                assert!(e.to_string().starts_with("bad.gltf: "), "{e}");
                failed += 1;
            }
        }
    }
    assert!(ok > 0 && failed > 0, "ok {ok}, failed {failed}");
}
