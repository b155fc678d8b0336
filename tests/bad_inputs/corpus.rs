//! The bad-input corpus: broken or hostile glTF / GLB files, each with what loading it must
//! do. Generated here (small, reviewable) rather than stored, except the fuzzer's finds in
//! `tests/bad_inputs/regressions/`.

use serde_json::{json, Value};

use crate::support::scene_files::{base64, bytes, glb, png, quad_doc, unbase64, Builder};

/// What loading a case must do.
#[derive(Clone, Debug)]
pub enum Expect {
    /// Fail with an error that contains every one of these.
    Fails(Vec<&'static str>),
    /// Fail, with any message that names the file (e.g. a GLB cut at an arbitrary byte).
    FailsAny,
    /// Load (the file is still renderable); `rqr info` prints `warning` on stderr when given,
    /// and `render` draws it with every backend when `render` is set.
    Loads {
        warning: Option<&'static str>,
        render: bool,
    },
}

/// One corpus entry: files written into a directory of their own; the first is the scene.
pub struct Case {
    pub name: String,
    pub files: Vec<(String, Vec<u8>)>,
    pub expect: Expect,
}

pub fn fails(needles: &[&'static str]) -> Expect {
    Expect::Fails(needles.to_vec())
}

pub const RENDERS: Expect = Expect::Loads {
    warning: None,
    render: true,
};

pub fn case(name: &str, file: &str, data: Vec<u8>, expect: Expect) -> Case {
    Case {
        name: name.to_string(),
        files: vec![(file.to_string(), data)],
        expect,
    }
}

pub fn gltf(name: &str, doc: &Value, expect: Expect) -> Case {
    case(name, "scene.gltf", bytes(doc), expect)
}

/// The unit quad as a builder and its document (buffer views 0/1: positions/indices).
fn quad() -> (Builder, Value) {
    let mut b = Builder::default();
    let doc = quad_doc(&mut b, json!({}));
    (b, doc)
}

/// The quad as a complete `.gltf` document with an embedded buffer.
pub fn quad_gltf() -> Value {
    let (b, doc) = quad();
    b.document(doc)
}

/// A GLB of the quad with a 2×2 PNG texture and UVs: small enough to cut at every byte.
pub fn small_glb() -> Vec<u8> {
    embedded_glb(&png(2, 2, &[255, 0, 0, 255].repeat(4)))
}

/// A grey `side`² PNG with real pixel data (8-bit greyscale: small to encode, 4 bytes per
/// texel once decoded to RGBA8).
pub fn big_png(side: u32) -> Vec<u8> {
    let mut out = Vec::new();
    let img = image::GrayImage::from_pixel(side, side, image::Luma([128]));
    image::codecs::png::PngEncoder::new_with_quality(
        &mut out,
        image::codecs::png::CompressionType::Fast,
        image::codecs::png::FilterType::NoFilter,
    )
    .write_image(&img, side, side, image::ExtendedColorType::L8)
    .unwrap();
    out
}

use image::ImageEncoder as _;

/// A textured quad whose only image is `image` (a JSON image object).
pub fn textured(image: Value) -> (Builder, Value) {
    let mut b = Builder::default();
    let doc = textured_in(&mut b, image);
    (b, doc)
}

/// The quad with UVs and a base-colour texture whose image is `image`, built in `b`.
pub fn textured_in(b: &mut Builder, image: Value) -> Value {
    let uv = b.floats(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0], "VEC2");
    let mut doc = quad_doc(b, json!({"material": 0}));
    doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(uv);
    doc["images"] = json!([image]);
    doc["textures"] = json!([{"source": 0}]);
    doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    doc
}

/// A GLB of the textured quad with `image` (PNG bytes, or what claims to be) in its BIN chunk.
pub fn embedded_glb(image: &[u8]) -> Vec<u8> {
    let mut b = Builder::default();
    let view = b.view(image);
    let doc = textured_in(&mut b, json!({"bufferView": view, "mimeType": "image/png"}));
    b.glb(doc)
}

/// Positions (one triangle per 9 floats) as a document without indices.
fn triangles(positions: &[f32]) -> Value {
    let mut b = Builder::default();
    let pos = b.floats(positions, "VEC3");
    // min/max of non-finite data are not what is under test.
    b.accessors[pos]["min"] = json!([0, 0, 0]);
    b.accessors[pos]["max"] = json!([1, 1, 1]);
    b.document(json!({
        "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}],
    }))
}

/// GLB container damage: header fields, chunk lengths and types.
fn container_cases(out: &mut Vec<Case>) {
    let full = small_glb();
    out.push(case("glb_intact", "scene.glb", full.clone(), RENDERS));
    let u32_at = |v: &[u8], o: usize| u32::from_le_bytes(v[o..o + 4].try_into().unwrap());
    let set = |v: &mut Vec<u8>, o: usize, x: u32| v[o..o + 4].copy_from_slice(&x.to_le_bytes());
    let json_len = u32_at(&full, 12) as usize;
    let bin_at = 20 + json_len;

    type Edit = Box<dyn Fn(&mut Vec<u8>)>;
    let mut edits: Vec<(&str, Edit, Expect)> = vec![
        (
            "glb_bad_magic",
            Box::new(|v| v[3] = b'X'),
            fails(&["invalid glTF JSON"]),
        ),
        (
            "glb_version_1",
            Box::new(move |v| set(v, 4, 1)),
            fails(&["GLB version 1 is not supported (only 2)"]),
        ),
        (
            "glb_version_3",
            Box::new(move |v| set(v, 4, 3)),
            fails(&["GLB version 3 is not supported"]),
        ),
        (
            "glb_length_past_end",
            Box::new(move |v| {
                let n = v.len() as u32 + 100;
                set(v, 8, n)
            }),
            fails(&["truncated GLB: header says"]),
        ),
        (
            "glb_length_too_small",
            Box::new(move |v| set(v, 8, 16)),
            fails(&["malformed GLB: length 16 leaves no JSON chunk"]),
        ),
        (
            "glb_json_chunk_past_end",
            Box::new(move |v| set(v, 12, 0x7FFF_FFF0)),
            fails(&["truncated GLB: chunk at offset 12 claims 2147483632 bytes"]),
        ),
        (
            "glb_json_chunk_empty",
            Box::new(move |v| set(v, 12, 0)),
            Expect::FailsAny,
        ),
        (
            "glb_bin_chunk_past_end",
            Box::new(move |v| {
                let n = u32_at(v, bin_at) + 1000;
                set(v, bin_at, n)
            }),
            fails(&["truncated GLB: chunk at offset"]),
        ),
        (
            "glb_bin_chunk_short",
            // The bytes after the shortened chunk then read as a chunk header of their own.
            Box::new(move |v| set(v, bin_at, 8)),
            fails(&["truncated GLB: chunk at offset"]),
        ),
        (
            "glb_first_chunk_bin",
            Box::new(|v| v[16..20].copy_from_slice(b"BIN\0")),
            fails(&["malformed GLB: misplaced BIN chunk"]),
        ),
        (
            "glb_second_json_chunk",
            Box::new(move |v| v[bin_at + 4..bin_at + 8].copy_from_slice(b"JSON")),
            fails(&["malformed GLB: unexpected second JSON chunk"]),
        ),
        (
            "glb_unknown_chunk_instead_of_bin",
            Box::new(move |v| v[bin_at + 4..bin_at + 8].copy_from_slice(b"XTRA")),
            fails(&["buffer 0: has no uri and the file has no GLB BIN chunk"]),
        ),
        (
            "glb_json_not_utf8",
            Box::new(|v| v[21] = 0xFF),
            fails(&["invalid glTF JSON"]),
        ),
    ];
    for (name, edit, expect) in edits.drain(..) {
        let mut v = full.clone();
        edit(&mut v);
        out.push(case(name, "scene.glb", v, expect));
    }
    // A GLB whose JSON is fine but has no BIN chunk at all.
    let doc = json!({"asset": {"version": "2.0"}, "buffers": [{"byteLength": 12}],
        "bufferViews": [{"buffer": 0, "byteLength": 12}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 1, "type": "VEC3"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}]});
    out.push(case(
        "glb_without_bin_chunk",
        "scene.glb",
        glb(&bytes(&doc), None),
        fails(&["buffer 0: has no uri and the file has no GLB BIN chunk"]),
    ));
}

/// JSON syntax and schema errors.
fn json_cases(out: &mut Vec<Case>) {
    let good = bytes(&quad_gltf());
    let text = String::from_utf8(good.clone()).unwrap();
    let syntax: Vec<(&str, Vec<u8>)> = vec![
        ("json_empty", Vec::new()),
        ("json_whitespace", b"  \n\t ".to_vec()),
        ("json_missing_brace", good[..good.len() - 1].to_vec()),
        (
            "json_trailing_comma",
            text.replacen("}", ",}", 1).into_bytes(),
        ),
        ("json_comment", format!("// a comment\n{text}").into_bytes()),
        (
            "json_single_quotes",
            text.replace("\"asset\"", "'asset'").into_bytes(),
        ),
        (
            "json_nan_literal",
            text.replacen("\"scene\":0", "\"scene\":NaN", 1)
                .into_bytes(),
        ),
        ("json_not_an_object", b"[1, 2, 3]".to_vec()),
        (
            "json_number_too_large",
            text.replacen("\"scene\":0", "\"scene\":1e400", 1)
                .into_bytes(),
        ),
        ("json_missing_asset", b"{\"scenes\": []}".to_vec()),
    ];
    for (name, data) in syntax {
        out.push(case(
            name,
            "scene.gltf",
            data,
            fails(&["invalid glTF JSON"]),
        ));
    }
    // Deeply nested values: skipped where glTF allows anything (extras: an empty scene
    // loads), refused beyond serde_json's recursion limit elsewhere; never a stack overflow.
    let empty = Expect::Loads {
        warning: Some("nothing to render"),
        render: false,
    };
    out.push(case(
        "json_deep_nesting_in_extras",
        "scene.gltf",
        format!(
            "{{\"asset\":{{\"version\":\"2.0\"}},\"extras\":{}{}}}",
            "[".repeat(100_000),
            "]".repeat(100_000)
        )
        .into_bytes(),
        empty.clone(),
    ));
    out.push(case(
        "json_deep_nesting_in_extensions",
        "scene.gltf",
        format!(
            "{{\"asset\":{{\"version\":\"2.0\"}},\"extensions\":{{\"X\":{}1{}}}}}",
            "{\"a\":".repeat(100_000),
            "}".repeat(100_000)
        )
        .into_bytes(),
        fails(&["invalid glTF JSON: recursion limit exceeded"]),
    ));
    let mut doc = quad_gltf();
    doc["asset"]["version"] = json!("1.0");
    out.push(gltf(
        "json_version_1",
        &doc,
        fails(&["glTF version 1.0 is not supported (only 2.x)"]),
    ));
    let mut bom = b"\xEF\xBB\xBF".to_vec();
    bom.extend_from_slice(&good);
    out.push(case("json_utf8_bom", "scene.gltf", bom, RENDERS));
    let mut doc = quad_gltf();
    doc["accessors"][0]["componentType"] = json!(5124);
    out.push(gltf("json_invalid_enum", &doc, Expect::FailsAny));
}

/// Buffers, views and accessors pointing outside their data.
fn accessor_cases(out: &mut Vec<Case>) {
    type Edit = fn(&mut Value);
    let edits: Vec<(&str, Edit, Expect)> = vec![
        (
            "accessor_past_buffer_end",
            |d| d["accessors"][0]["count"] = json!(10),
            fails(&["mesh 0 primitive 0: POSITION accessor 0", "10 elements"]),
        ),
        (
            "buffer_shorter_than_byte_length",
            |d| d["buffers"][0]["byteLength"] = json!(10_000),
            fails(&["buffer 0: byteLength is 10000"]),
        ),
        (
            "view_past_buffer",
            |d| d["bufferViews"][0]["byteOffset"] = json!(1u64 << 40),
            fails(&["POSITION accessor 0: buffer view 0", "exceeds buffer 0"]),
        ),
        (
            "accessor_offset_past_view",
            |d| d["accessors"][0]["byteOffset"] = json!(1000),
            fails(&["past the end of buffer view 0"]),
        ),
        (
            "stride_smaller_than_element",
            |d| d["bufferViews"][0]["byteStride"] = json!(4),
            fails(&["byteStride 4 is smaller than the 12-byte element"]),
        ),
        (
            "stride_not_a_multiple_of_4",
            |d| d["bufferViews"][0]["byteStride"] = json!(13),
            Expect::FailsAny,
        ),
        (
            "stride_above_252",
            |d| d["bufferViews"][0]["byteStride"] = json!(256),
            Expect::FailsAny,
        ),
        (
            "accessor_count_absurd",
            |d| d["accessors"][0]["count"] = json!(4_000_000_000u64),
            fails(&["POSITION accessor 0", "limit"]),
        ),
        (
            "accessor_without_view_absurd",
            |d| {
                d["accessors"][0] = json!({"componentType": 5126, "count": 1u64 << 40,
                    "type": "VEC3", "min": [0, 0, 0], "max": [0, 0, 0]})
            },
            fails(&["exceeds rqr's limit"]),
        ),
        (
            "accessor_missing",
            |d| d["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(99),
            fails(&["POSITION accessor 99: does not exist"]),
        ),
        (
            "indices_out_of_range",
            |d| {
                // The quad's index view: 0 1 2 0 2 3 → make the last one 7.
                d["accessors"][1]["count"] = json!(6);
                let uri = d["buffers"][0]["uri"].as_str().unwrap().to_string();
                let payload = uri.split(',').nth(1).unwrap().to_string();
                let mut bin = unbase64(&payload);
                let at = d["bufferViews"][1]["byteOffset"].as_u64().unwrap() as usize + 10;
                bin[at] = 7;
                d["buffers"][0]["uri"] = json!(format!(
                    "data:application/octet-stream;base64,{}",
                    base64(&bin)
                ));
            },
            fails(&["mesh 0 primitive 0: index 7 out of range (4 vertices)"]),
        ),
        (
            "indices_not_scalar",
            |d| d["meshes"][0]["primitives"][0]["indices"] = json!(0),
            fails(&["indices accessor 0: indices must be SCALAR"]),
        ),
        (
            "buffer_data_uri_bad_base64",
            |d| d["buffers"][0]["uri"] = json!("data:application/octet-stream;base64,@@@@"),
            fails(&["buffer 0: invalid base64"]),
        ),
        (
            "buffer_data_uri_without_comma",
            |d| d["buffers"][0]["uri"] = json!("data:application/octet-stream;base64"),
            fails(&["buffer 0: data URI without ','"]),
        ),
        (
            "buffer_remote_uri",
            |d| d["buffers"][0]["uri"] = json!("https://example.com/scene.bin"),
            fails(&["URI scheme 'https:' is not supported"]),
        ),
        (
            "buffer_missing_file",
            |d| d["buffers"][0]["uri"] = json!("missing.bin"),
            fails(&["buffer 0 (missing.bin): cannot read"]),
        ),
    ];
    for (name, edit, expect) in edits {
        let mut d = quad_gltf();
        edit(&mut d);
        out.push(gltf(name, &d, expect));
    }
    // Many primitives sharing one 2^24-vertex accessor without a buffer view (all zeros):
    // a few hundred bytes of JSON that would expand to gigabytes.
    let prims: Vec<Value> = (0..64)
        .map(|_| json!({"attributes": {"POSITION": 0}}))
        .collect();
    let doc = json!({"asset": {"version": "2.0"},
        "accessors": [{"componentType": 5126, "count": 1 << 24, "type": "VEC3",
            "min": [0, 0, 0], "max": [0, 0, 0]}],
        "meshes": [{"primitives": prims}], "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}]});
    out.push(gltf(
        "shared_unbacked_accessor_amplification",
        &doc,
        fails(&["more than rqr's limit of 67108864"]),
    ));
    // Thousands of buffers naming the same file: their byteLengths add up beyond the limit.
    let file = vec![0u8; 1 << 20];
    let buffers: Vec<Value> = (0..5000)
        .map(|_| json!({"uri": "big.bin", "byteLength": 1 << 20}))
        .collect();
    let doc = json!({"asset": {"version": "2.0"}, "buffers": buffers});
    out.push(Case {
        name: "buffers_repeat_one_file".into(),
        files: vec![("scene.gltf".into(), bytes(&doc)), ("big.bin".into(), file)],
        expect: fails(&["buffers: 5242880000 bytes in total exceed rqr's limit"]),
    });
}

/// Geometry that is malformed, degenerate or empty.
fn geometry_cases(out: &mut Vec<Case>) {
    let tri = |a: f32| vec![0.0, 0.0, 0.0, 1.0, a, 0.0, 1.0, 1.0, 0.0];
    out.push(gltf(
        "position_nan",
        &triangles(&tri(f32::NAN)),
        fails(&["mesh 0 primitive 0: POSITION 1 is not finite"]),
    ));
    out.push(gltf(
        "position_infinite",
        &triangles(&tri(f32::INFINITY)),
        fails(&["mesh 0 primitive 0: POSITION 1 is not finite"]),
    ));
    out.push(gltf(
        "position_huge",
        &triangles(&[0.0, 0.0, 0.0, 3e38, 0.0, 0.0, 0.0, 3e38, -3e38]),
        fails(&[
            "node 0: mesh vertices reach world coordinate",
            "beyond rqr's limit",
        ]),
    ));
    out.push(gltf(
        "positions_far_but_finite",
        &triangles(&[
            1e15,
            1e15,
            0.0,
            1e15 + 1e9,
            1e15,
            0.0,
            1e15,
            1e15 + 1e9,
            0.0,
        ]),
        RENDERS,
    ));
    out.push(gltf(
        "triangles_degenerate",
        &triangles(&[0.5; 18]),
        RENDERS,
    ));
    out.push(gltf(
        "zero_triangles_two_vertices",
        &triangles(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0]),
        Expect::Loads {
            warning: Some("nothing to render"),
            render: true,
        },
    ));
    let mut d = quad_gltf();
    d["meshes"][0]["primitives"] = json!([]);
    out.push(gltf(
        "mesh_without_primitives",
        &d,
        Expect::Loads {
            warning: Some("nothing to render"),
            render: true,
        },
    ));
    let mut d = quad_gltf();
    d["meshes"][0]["primitives"][0]["mode"] = json!(1);
    out.push(gltf(
        "lines_only",
        &d,
        Expect::Loads {
            warning: Some("skipping Lines primitive"),
            render: true,
        },
    ));
    let mut d = quad_gltf();
    d["meshes"][0]["primitives"][0]["mode"] = json!(9);
    out.push(gltf(
        "mode_invalid",
        &d,
        fails(&["mesh 0 primitive 0: invalid mode"]),
    ));
    let mut d = quad_gltf();
    d["nodes"][0]["rotation"] = json!([0, 0, 0, 0]);
    out.push(gltf(
        "rotation_zero_quaternion",
        &d,
        fails(&["node 0: rotation is a zero quaternion"]),
    ));
    let mut d = quad_gltf();
    d["nodes"][0]["scale"] = json!([1e30, 1e30, 1e30]);
    d["nodes"] = json!([{"children": [1], "scale": [1e30, 1e30, 1e30]}, d["nodes"][0].clone()]);
    d["scenes"] = json!([{"nodes": [0]}]);
    out.push(gltf(
        "transform_overflow",
        &d,
        fails(&["node 1: world transform is not finite"]),
    ));
}

/// Node graphs: cycles, self-parenting, exponential sharing, a million nodes.
fn node_cases(out: &mut Vec<Case>) {
    let mut d = quad_gltf();
    d["nodes"] = json!([{"children": [1]}, {"children": [2], "mesh": 0}, {"children": [1]}]);
    d["scenes"] = json!([{"nodes": [0]}]);
    out.push(gltf(
        "node_cycle",
        &d,
        fails(&["node hierarchy has a cycle: node 1 -> node 2 -> node 1"]),
    ));
    let mut d = quad_gltf();
    d["nodes"] = json!([{"children": [0], "mesh": 0}]);
    out.push(gltf(
        "node_self_parent",
        &d,
        fails(&["node 0: node hierarchy has a cycle: node 0 -> node 0"]),
    ));
    let mut d = quad_gltf();
    d["nodes"] = json!([{"children": [5]}]);
    out.push(gltf(
        "node_child_missing",
        &d,
        fails(&["node 0: child 5 does not exist (1 nodes)"]),
    ));
    let mut d = quad_gltf();
    let mut nodes: Vec<Value> = (0..40)
        .map(|i| json!({"children": [i + 1, i + 1]}))
        .collect();
    nodes.push(json!({"mesh": 0}));
    d["nodes"] = json!(nodes);
    d["scenes"] = json!([{"nodes": [0]}]);
    out.push(gltf(
        "node_exponential_sharing",
        &d,
        fails(&["expands to more than"]),
    ));
    // Light sizes in `extras` (distributed shading): a wrong type or range is a warning that
    // names the light, and the light stays punctual.
    for (name, kind, extras, warning) in [
        (
            "light_radius_string",
            "point",
            json!({"radius": "big"}),
            "light 0 (node 1): extras.radius must be a non-negative number",
        ),
        (
            "light_radius_negative",
            "spot",
            json!({"radius": -1.0}),
            "light 0 (node 1): extras.radius must be a non-negative number",
        ),
        (
            "light_angular_radius_too_wide",
            "directional",
            json!({"angularRadius": 2.0}),
            "light 0 (node 1): extras.angularRadius must be an angle in radians",
        ),
        (
            "light_radius_on_directional",
            "directional",
            json!({"radius": 0.5}),
            "extras.radius does not apply to this kind of light",
        ),
    ] {
        let mut d = quad_gltf();
        d["extensionsUsed"] = json!(["KHR_lights_punctual"]);
        let mut light = json!({"type": kind, "intensity": 5.0, "extras": extras});
        if kind == "spot" {
            light["spot"] = json!({"outerConeAngle": 0.5});
        }
        d["extensions"] = json!({"KHR_lights_punctual": {"lights": [light]}});
        d["nodes"] = json!([{"mesh": 0}, {"extensions": {"KHR_lights_punctual": {"light": 0}}, "translation": [0.0, 2.0, 0.0]}]);
        d["scenes"] = json!([{"nodes": [0, 1]}]);
        out.push(gltf(
            name,
            &d,
            Expect::Loads {
                warning: Some(warning),
                render: false,
            },
        ));
    }
}

/// Big inputs, each generated on demand (seconds each): 10^6 nodes side by side and in one
/// chain, and a real 16384² texture.
pub fn heavy_case(name: &str) -> Case {
    match name {
        "nodes_million_flat" | "nodes_million_deep" => million_nodes(name),
        "image_16k_by_16k" => case(name, "scene.glb", embedded_glb(&big_png(16384)), RENDERS),
        _ => panic!("no heavy case {name}"),
    }
}

fn million_nodes(name: &str) -> Case {
    const MILLION: usize = 1_000_000;
    let mut d = quad_gltf();
    if name == "nodes_million_flat" {
        d["nodes"] = Value::Array(
            (0..MILLION)
                .map(|i| {
                    let (x, y) = ((i % 1000) as f32 * 1.5, (i / 1000) as f32 * 1.5);
                    json!({"mesh": 0, "translation": [x, y, 0]})
                })
                .collect(),
        );
        d["scenes"] = json!([{"nodes": (0..MILLION).collect::<Vec<_>>()}]);
    } else {
        d["nodes"] = Value::Array(
            (0..MILLION)
                .map(|i| {
                    if i + 1 < MILLION {
                        json!({"children": [i + 1]})
                    } else {
                        json!({"mesh": 0})
                    }
                })
                .collect(),
        );
        d["scenes"] = json!([{"nodes": [0]}]);
    }
    gltf(name, &d, RENDERS)
}

/// Every cut point of [`small_glb`] (the intact file is a case of its own).
pub fn truncations() -> Vec<Case> {
    let full = small_glb();
    (0..full.len())
        .map(|n| {
            case(
                &format!("glb_cut_{n}"),
                "scene.glb",
                full[..n].to_vec(),
                Expect::FailsAny,
            )
        })
        .collect()
}

/// The fuzzer's crash cases (`tests/bad_inputs/regressions/`), loaded as GLB or JSON bytes.
pub fn regressions() -> Vec<Case> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/bad_inputs/regressions");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.path()).collect())
        .unwrap_or_default();
    files.retain(|p| p.extension().is_some_and(|e| e == "bin"));
    files.sort();
    files
        .into_iter()
        .map(|p| Case {
            name: format!("regression_{}", p.file_stem().unwrap().to_string_lossy()),
            files: vec![("scene.glb".into(), std::fs::read(&p).unwrap())],
            expect: Expect::FailsAny,
        })
        .collect()
}

/// Every named case (not the truncations or regressions).
pub fn cases() -> Vec<Case> {
    let mut out = Vec::new();
    container_cases(&mut out);
    json_cases(&mut out);
    accessor_cases(&mut out);
    geometry_cases(&mut out);
    node_cases(&mut out);
    crate::images::cases(&mut out);
    crate::extensions::cases(&mut out);
    crate::animation::cases(&mut out);
    out
}
