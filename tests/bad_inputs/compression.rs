//! Broken compressed meshes: EXT_meshopt_compression views (bad filter, mode, stride, length,
//! count or buffer) and KHR_draco_mesh_compression primitives (cut or foreign streams,
//! attribute ids the stream lacks, absurd face counts), each failing naming the view or the
//! primitive.

use rqr::scene::{self, LoadOptions, Scene};
use serde_json::{json, Value};

use crate::support::scene_files::{self, asset};

/// The meshopt box with its JSON edited.
fn edited_box(edit: impl Fn(&mut Value)) -> Vec<u8> {
    let data = std::fs::read(asset("BoxTextured_meshopt/BoxTextured_meshopt.glb")).unwrap();
    let json_len = u32::from_le_bytes(data[12..16].try_into().unwrap()) as usize;
    let mut doc: Value = serde_json::from_slice(&data[20..20 + json_len]).unwrap();
    let bin_start = 20 + json_len;
    let bin_len = u32::from_le_bytes(data[bin_start..bin_start + 4].try_into().unwrap()) as usize;
    edit(&mut doc);
    scene_files::glb(
        &serde_json::to_vec(&doc).unwrap(),
        Some(&data[bin_start + 8..bin_start + 8 + bin_len]),
    )
}

#[test]
fn broken_meshopt_views_name_the_view() {
    // View 1 holds octahedral normals (ATTRIBUTES, stride 4), view 2 UVs (stride 8), view 4
    // the triangles.
    let cases: Vec<(usize, &str, Value, &str)> = vec![
        (1, "filter", json!("WAVELET"), "buffer view 1: EXT_meshopt_compression: unknown filter 'WAVELET'"),
        (4, "mode", json!("STRIPS"), "buffer view 4: EXT_meshopt_compression: unknown mode 'STRIPS'"),
        (1, "byteStride", json!(6), "buffer view 1: EXT_meshopt_compression: byteStride 6 of ATTRIBUTES"),
        (2, "byteStride", json!(4), "buffer view 2: EXT_meshopt_compression: the ATTRIBUTES data cannot be decoded"),
        (4, "byteLength", json!(5), "buffer view 4: EXT_meshopt_compression: the TRIANGLES data cannot be decoded"),
        (4, "byteLength", json!(100000), "buffer view 4: EXT_meshopt_compression: bytes 4632..+100000 are outside buffer 0"),
        (2, "count", json!(1u64 << 40), "buffer view 2: EXT_meshopt_compression: 1099511627776 elements of 8 bytes exceed"),
        (4, "filter", json!("OCTAHEDRAL"), "buffer view 4: EXT_meshopt_compression: filter OCTAHEDRAL is not allowed with mode TRIANGLES"),
        (4, "buffer", json!(7), "buffer view 4: EXT_meshopt_compression: buffer 7 does not exist"),
    ];
    for (view, field, value, want) in cases {
        let glb = edited_box(|d| {
            d["bufferViews"][view]["extensions"]["EXT_meshopt_compression"][field] = value.clone()
        });
        let e = scene::load_slice(&glb, None, "box.glb", &LoadOptions::default())
            .expect_err(want)
            .to_string();
        assert!(
            e.starts_with("box.glb: ") && e.contains(want),
            "want '{want}' in '{e}'"
        );
    }
}

/// `CesiumMan_Draco` loaded from its JSON after `edit`, with its buffer beside it.
fn edited_draco(edit: impl Fn(&mut Value, &mut Vec<u8>)) -> Result<Scene, String> {
    let dir = std::env::temp_dir().join(format!(
        "rqr-draco-{}-{}",
        std::process::id(),
        std::thread::current()
            .name()
            .unwrap_or("t")
            .replace("::", "-")
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let src = asset("CesiumMan_Draco/CesiumMan.gltf");
    let mut doc: Value = serde_json::from_slice(&std::fs::read(&src).unwrap()).unwrap();
    let mut bin = std::fs::read(src.with_file_name("CesiumMan_data.bin")).unwrap();
    // No texture: only the geometry is under test.
    doc.as_object_mut().unwrap().remove("images");
    doc.as_object_mut().unwrap().remove("textures");
    doc["materials"] = json!([{}]);
    edit(&mut doc, &mut bin);
    std::fs::write(dir.join("CesiumMan_data.bin"), &bin).unwrap();
    let path = dir.join("man.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let r = scene::load(&path, &LoadOptions::default()).map_err(|e| e.to_string());
    std::fs::remove_dir_all(&dir).ok();
    r
}

/// An edit of `CesiumMan_Draco`'s JSON and buffer.
type Edit = dyn Fn(&mut Value, &mut Vec<u8>);

#[test]
fn broken_draco_primitives_name_the_primitive() {
    let ext = "/meshes/0/primitives/0/extensions/KHR_draco_mesh_compression";
    let set = |pointer: String, v: Value| {
        move |d: &mut Value, _: &mut Vec<u8>| *d.pointer_mut(&pointer).unwrap() = v.clone()
    };
    let cases: Vec<(Box<Edit>, &str)> = vec![
        (
            // The stream cut after 1000 of its 48166 bytes.
            Box::new(set("/bufferViews/4/byteLength".into(), json!(1000))),
            "mesh 0 primitive 0: KHR_draco_mesh_compression: the Draco stream in buffer view 4 cannot be decoded",
        ),
        (
            Box::new(set("/bufferViews/4/byteLength".into(), json!(9))),
            "mesh 0 primitive 0: KHR_draco_mesh_compression: the buffer view does not hold a Draco stream (9 bytes",
        ),
        (
            Box::new(set(format!("{ext}/attributes/POSITION"), json!(9))),
            "mesh 0 primitive 0: KHR_draco_mesh_compression: attribute POSITION names Draco attribute id 9, which the stream does not have (ids: 0, 2, 3, 4, 1)",
        ),
        (
            Box::new(|d: &mut Value, _: &mut Vec<u8>| {
                d["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]
                    ["attributes"]["TEXCOORD_1"] = json!(3)
            }),
            "mesh 0 primitive 0: KHR_draco_mesh_compression: attribute TEXCOORD_1 (Draco id 3) is not among the primitive's attributes",
        ),
        (
            Box::new(set(format!("{ext}/bufferView"), json!(40))),
            "mesh 0 primitive 0: KHR_draco_mesh_compression: buffer view 40 does not exist",
        ),
        (
            // Edgebreaker header: 2^40 faces declared (the varints from byte 12 of the
            // stream are the encoded vertex count, then the face count).
            Box::new(|_: &mut Value, bin: &mut Vec<u8>| {
                let s = 41344;
                let mut r = 12;
                while bin[s + r] & 0x80 != 0 {
                    r += 1;
                }
                r += 1; // past the encoded vertex count: the face count follows
                let mut faces_len = 1;
                while bin[s + r + faces_len - 1] & 0x80 != 0 {
                    faces_len += 1;
                }
                let huge = [0x80, 0x80, 0x80, 0x80, 0x80, 0x20];
                bin.splice(s + r..s + r + faces_len, huge);
            }),
            "mesh 0 primitive 0: KHR_draco_mesh_compression: the stream declares 1099511627776 faces, more than rqr's limit",
        ),
    ];
    for (edit, want) in cases {
        let e = edited_draco(edit).expect_err(want);
        assert!(
            e.contains("man.gltf: ") && e.contains(want),
            "want '{want}' in '{e}'"
        );
    }
}
