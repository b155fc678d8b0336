//! EXT_meshopt_compression: files made with gltfpack load with the same triangles and
//! positions (within quantization) as their sources and render alike; broken compressed views
//! fail with errors naming the file and the buffer view.

use crate::support;
use crate::support::scene_files;

use glam::Vec3;
use rqr::scene::{self, LoadOptions, Scene};
use scene_files::asset;
use serde_json::{json, Value};
use support::render_alike::assert_renders_alike;

fn load(rel: &str) -> Scene {
    scene::load(&asset(rel), &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// World-space corners of every triangle, in order.
fn world_corners(s: &Scene) -> Vec<[Vec3; 3]> {
    let mut out = Vec::new();
    for inst in &s.instances {
        let g = &s.geometries[inst.geometry as usize];
        for t in g.indices.chunks_exact(3) {
            out.push(
                [t[0], t[1], t[2]]
                    .map(|i| inst.transform.transform_point3(g.positions[i as usize])),
            );
        }
    }
    out
}

#[test]
fn meshopt_files_match_their_sources() {
    for (plain, packed) in [
        (
            "BoxTextured/BoxTextured.glb",
            "BoxTextured_meshopt/BoxTextured_meshopt.glb",
        ),
        ("Avocado/Avocado.gltf", "Avocado/Avocado_meshopt.glb"),
    ] {
        let a = load(plain);
        let b = load(packed);
        assert!(b.extensions_unsupported.is_empty(), "{packed}");
        assert_eq!(a.triangle_count(), b.triangle_count(), "{packed}");
        // gltfpack reorders triangles and quantizes positions to 14 bits of the bounds: every
        // source triangle has a packed one within that step at each corner.
        let step = (a.bounds.max - a.bounds.min).max_element() / (1 << 13) as f32;
        let packed_tris = world_corners(&b);
        for t in world_corners(&a) {
            let found = packed_tris
                .iter()
                .any(|p| (0..3).any(|r| (0..3).all(|k| p[(k + r) % 3].distance(t[k]) <= step)));
            assert!(found, "{packed}: no triangle near {t:?} (step {step})");
        }
    }
}

#[test]
fn meshopt_renders_like_its_source() {
    let ctx = support::gpu();
    let a = load("Avocado/Avocado.gltf");
    let b = load("Avocado/Avocado_meshopt.glb");
    assert_renders_alike(&ctx, &a, &b, 96, 0.01, "Avocado vs Avocado_meshopt");
    support::assert_validation_clean(&ctx);
}

/// The meshopt box with its JSON edited.
pub fn edited_box(edit: impl Fn(&mut Value)) -> Vec<u8> {
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

#[test]
fn draco_cesium_man_matches_its_source() {
    let a = load("CesiumMan/CesiumMan.glb");
    let b = load("CesiumMan_Draco/CesiumMan.gltf");
    assert!(b.extensions_unsupported.is_empty());
    assert_eq!(a.triangle_count(), b.triangle_count());
    // The Draco copy (gltf-pipeline) quantizes positions to 11 bits of the largest extent
    // and reorders vertices: every source triangle has a Draco one within half a step per
    // axis (√3/2 steps < 2^-11 of the extent) at each corner (in the bind pose: both files
    // have the same nodes, skins and animation).
    let step = (a.bounds.max - a.bounds.min).max_element() / (1 << 11) as f32;
    let draco_tris = world_corners(&b);
    let mut worst = 0f32;
    for t in world_corners(&a) {
        let best = draco_tris
            .iter()
            .flat_map(|p| {
                (0..3).map(move |r| {
                    (0..3)
                        .map(|k| p[(k + r) % 3].distance(t[k]))
                        .fold(0f32, f32::max)
                })
            })
            .fold(f32::INFINITY, f32::min);
        worst = worst.max(best);
        assert!(best <= step, "no Draco triangle near {t:?} (step {step})");
    }
    eprintln!("CesiumMan vs CesiumMan_Draco: worst corner distance {worst} (step {step})");
}

#[test]
fn draco_renders_like_its_source() {
    let ctx = support::gpu();
    let a = load("CesiumMan/CesiumMan.glb");
    let b = load("CesiumMan_Draco/CesiumMan.gltf");
    assert_renders_alike(&ctx, &a, &b, 96, 0.01, "CesiumMan vs CesiumMan_Draco");
    support::assert_validation_clean(&ctx);
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
