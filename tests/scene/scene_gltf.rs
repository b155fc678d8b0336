//! glTF loading: the copied Khronos sample models (counts, transforms, sparse accessors,
//! instancing, texture transforms, scenes, cameras) and small crafted files (strips, fans,
//! quantized attributes, lights, sRGB vs linear images, tangents).

use std::collections::HashSet;

use crate::support::scene_files::{asset, bytes, index_rows, png, quad_doc, Builder};
use glam::{Mat4, Vec2, Vec3, Vec4};
use rqr::scene::{self, AlphaMode, LightKind, LoadOptions, Projection, Scene, SceneError, Wrap};
use serde_json::json;

fn load(rel: &str) -> Scene {
    scene::load(&asset(rel), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("loading {rel}: {e}"))
}

fn load_scene(rel: &str, index: usize) -> Result<Scene, SceneError> {
    scene::load(
        &asset(rel),
        &LoadOptions {
            scene: Some(index),
            ..Default::default()
        },
    )
}

fn from_json(doc: &serde_json::Value) -> Result<Scene, SceneError> {
    scene::load_slice(&bytes(doc), None, "test.gltf", &LoadOptions::default())
}

fn instance_of_node(s: &Scene, node: usize) -> Mat4 {
    s.instances
        .iter()
        .find(|i| i.node == node)
        .unwrap_or_else(|| panic!("no instance for node {node}"))
        .transform
}

fn close3(a: Vec3, b: Vec3, eps: f32) -> bool {
    a.abs_diff_eq(b, eps)
}

#[test]
fn sample_models_match_index_counts() {
    let rows = index_rows();
    assert!(rows.len() >= 10, "INDEX.tsv lists the copied models");
    for row in rows {
        let s = load(&row.main_file);
        assert_eq!(
            s.triangle_count(),
            row.tris_instanced,
            "{}: triangles over all instances",
            row.name
        );
        if row.name == "MultipleScenes" {
            // The index counts every mesh of the file; each scene holds one of the two.
            let both = load_scene(&row.main_file, 0)
                .unwrap()
                .unique_triangle_count()
                + load_scene(&row.main_file, 1)
                    .unwrap()
                    .unique_triangle_count();
            assert_eq!(both, row.tris_unique, "{}", row.name);
        } else {
            assert_eq!(
                s.unique_triangle_count(),
                row.tris_unique,
                "{}: unique triangles",
                row.name
            );
        }
        for g in &s.geometries {
            assert_eq!(g.indices.len() % 3, 0);
            assert_eq!(g.normals.len(), g.positions.len(), "{}: normals", row.name);
            assert!(g.indices.iter().all(|&i| (i as usize) < g.positions.len()));
            assert!((g.material as usize) < s.materials.len());
        }
        assert!(!s.bounds.is_empty(), "{}: bounds", row.name);
        assert!(!s.materials.is_empty());
    }
}

#[test]
fn shared_meshes_become_one_geometry_with_many_instances() {
    // AttenuationTest reuses meshes across nodes: 232 unique vs 292 instanced triangles.
    let s = load("AttenuationTest/AttenuationTest.glb");
    assert!(s.instances.len() > s.geometries.len());
    let pairs: HashSet<(usize, usize)> =
        s.geometries.iter().map(|g| (g.mesh, g.primitive)).collect();
    assert_eq!(
        pairs.len(),
        s.geometries.len(),
        "(mesh, primitive) deduplicated"
    );
    assert!(s.extensions_unsupported.is_empty());
    assert!(s
        .materials
        .iter()
        .any(|m| m.transmission > 0.0 && m.thickness > 0.0 && m.attenuation_distance.is_finite()));
}

#[test]
fn orientation_test_node_transforms() {
    let s = load("OrientationTest/OrientationTest.glb");
    let d = 35f32.to_radians();
    // Node 0 "ArrowX1": TRS, rotation -35° about X, translation (5, 0, 0).
    let m = instance_of_node(&s, 0);
    assert!(close3(
        m.transform_point3(Vec3::ZERO),
        Vec3::new(5.0, 0.0, 0.0),
        1e-5
    ));
    assert!(close3(
        m.transform_vector3(Vec3::Y),
        Vec3::new(0.0, d.cos(), -d.sin()),
        1e-3
    ));
    // Node 1 "ArrowX2": matrix, +5° about X at (-5, 0, 0).
    let m = instance_of_node(&s, 1);
    let f = 5f32.to_radians();
    assert!(close3(
        m.transform_point3(Vec3::ZERO),
        Vec3::new(-5.0, 0.0, 0.0),
        1e-5
    ));
    assert!(close3(
        m.transform_vector3(Vec3::Y),
        Vec3::new(0.0, f.cos(), f.sin()),
        1e-5
    ));
    // Node 3 "ArrowY2": matrix, -12° about Y at (0, -5, 0): X maps to (cos 12°, 0, sin 12°).
    let m = instance_of_node(&s, 3);
    let t = 12f32.to_radians();
    assert!(close3(
        m.transform_point3(Vec3::ZERO),
        Vec3::new(0.0, -5.0, 0.0),
        1e-5
    ));
    assert!(close3(
        m.transform_vector3(Vec3::X),
        Vec3::new(t.cos(), 0.0, t.sin()),
        1e-4
    ));
    // Node 2 "ArrowY1": quaternion (0, -0.5736, 0, 0.8192) = -70° about Y at (0, 5, 0).
    let m = instance_of_node(&s, 2);
    let a = (-70f32).to_radians();
    assert!(close3(
        m.transform_point3(Vec3::ZERO),
        Vec3::new(0.0, 5.0, 0.0),
        1e-5
    ));
    assert!(close3(
        m.transform_vector3(Vec3::X),
        Vec3::new(a.cos(), 0.0, -a.sin()),
        1e-4
    ));
    assert!(s.instances.iter().all(|i| !i.flips_winding()));
}

#[test]
fn recursive_skeletons_compose_deep_hierarchies() {
    let s = load("RecursiveSkeletons/RecursiveSkeletons.glb");
    assert_eq!(s.geometries.len(), 1);
    assert_eq!(s.instances.len(), 84);
    // Node 0 at (25, 0, 25), nodes 1..=9 each +10 in y; node 11 scales by 0.3 and moves
    // (3, 0, 3); nodes 12..=20 each move (0, 10, 0) in that scaled frame.
    let w = |n: usize| s.node_world[n].unwrap_or_else(|| panic!("node {n} not reached"));
    assert!(close3(
        w(9).transform_point3(Vec3::ZERO),
        Vec3::new(25.0, 90.0, 25.0),
        1e-4
    ));
    assert!(close3(
        w(11).transform_point3(Vec3::ZERO),
        Vec3::new(28.0, 90.0, 28.0),
        1e-4
    ));
    assert!(close3(
        w(20).transform_point3(Vec3::ZERO),
        Vec3::new(28.0, 117.0, 28.0),
        1e-3
    ));
    assert!(close3(
        w(20).transform_vector3(Vec3::X),
        Vec3::new(0.3, 0.0, 0.0),
        1e-5
    ));
    assert!(close3(
        w(232).transform_point3(Vec3::ZERO),
        Vec3::new(-25.0, 10.0, 25.0),
        1e-4
    ));
}

#[test]
fn simple_sparse_accessor_overrides_positions() {
    let s = load("SimpleSparseAccessor/SimpleSparseAccessor.gltf");
    // The file has no normals, so vertices were un-welded for flat normals: compare the set
    // of positions.
    let set: HashSet<[u32; 3]> = s.geometries[0]
        .positions
        .iter()
        .map(|p| p.to_array().map(f32::to_bits))
        .collect();
    let has = |x: f32, y: f32| set.contains(&[x.to_bits(), y.to_bits(), 0f32.to_bits()]);
    assert!(
        has(1.0, 2.0) && has(3.0, 3.0) && has(5.0, 4.0),
        "sparse values applied"
    );
    assert!(
        !has(1.0, 1.0) && !has(3.0, 1.0) && !has(5.0, 1.0),
        "base values replaced"
    );
    assert!(has(2.0, 1.0) && has(6.0, 1.0), "other vertices untouched");
    assert_eq!(s.unique_triangle_count(), 12);
    assert_eq!(s.bounds.max, Vec3::new(6.0, 4.0, 0.0));
}

#[test]
fn simple_instancing_expands_ext_mesh_gpu_instancing() {
    let s = load("SimpleInstancing/SimpleInstancing.glb");
    assert_eq!(s.geometries.len(), 1);
    assert_eq!(s.unique_triangle_count(), 12);
    assert_eq!(s.instances.len(), 125);
    assert_eq!(s.triangle_count(), 1500);
    let origins: HashSet<[u32; 3]> = s
        .instances
        .iter()
        .map(|i| {
            i.transform
                .transform_point3(Vec3::ZERO)
                .to_array()
                .map(f32::to_bits)
        })
        .collect();
    assert_eq!(origins.len(), 125, "every instance placed differently");
    for i in &s.instances {
        let (scale, _, t) = i.transform.to_scale_rotation_translation();
        assert!(t.min_element() >= 0.0 && t.max_element() <= 10.0);
        assert!(scale.min_element() >= 1.0 - 1e-5 && scale.max_element() <= 2.0 + 1e-5);
    }
    assert!(s
        .extensions_used
        .iter()
        .any(|e| e == "EXT_mesh_gpu_instancing"));
}

#[test]
fn texture_transform_test_matrices() {
    let s = load("TextureTransformTest/TextureTransformTest.gltf");
    let by_name = |n: &str| s.materials.iter().find(|m| m.name == n).unwrap();
    let tr = |n: &str| by_name(n).base_color_texture.unwrap().transform;
    assert_eq!(tr("Offset U").z_axis, Vec3::new(0.5, 0.0, 1.0));
    assert_eq!(tr("Offset V").z_axis, Vec3::new(0.0, 0.5, 1.0));
    assert_eq!(tr("Offset UV").z_axis, Vec3::new(0.5, 0.5, 1.0));
    assert_eq!(tr("Scale").x_axis, Vec3::new(1.5, 0.0, 0.0));
    assert_eq!(tr("Correct").z_axis, Vec3::Z, "no extension: identity");

    // The file's own markers: the "Correct" marker node sits where a correct transform
    // puts the arrow tip, which the untransformed texture shows at the "Not Supported"
    // marker. Map each marker's position on its quad to UV and apply the matrix.
    let quad_uv = |quad_node: usize, marker_node: usize| -> Vec2 {
        let quad = s.node_world[quad_node].unwrap();
        let p = s.node_world[marker_node]
            .unwrap()
            .transform_point3(Vec3::ZERO);
        let local = quad.inverse().transform_point3(p);
        // The quads span [-0.5, 0.5]² with u along +x and v along -y.
        Vec2::new(local.x + 0.5, 0.5 - local.y)
    };
    let g = s
        .geometries
        .iter()
        .find(|g| g.mesh == 3)
        .expect("rotation quad");
    for (p, uv) in g.positions.iter().zip(&g.uv0) {
        assert!(
            uv.abs_diff_eq(Vec2::new(p.x + 0.5, 0.5 - p.y), 1e-5),
            "quad UV layout"
        );
    }
    let tip = quad_uv(3, 5); // "Rotation - Not Supported"
    for (quad, marker, material, eps) in [
        (3, 4, "Rotation", 1e-3),
        (7, 8, "Scale", 1e-3),
        (10, 11, "All", 0.05),
    ] {
        let uv = quad_uv(quad, marker);
        let got = (tr(material) * uv.extend(1.0)).truncate();
        assert!(
            got.abs_diff_eq(tip, eps),
            "{material}: {uv} -> {got}, want {tip}"
        );
    }
    // "Rotation - Error" is where the opposite rotation would put the tip.
    let wrong = (tr("Rotation") * quad_uv(3, 6).extend(1.0)).truncate();
    assert!(!wrong.abs_diff_eq(tip, 0.1));

    // The sampler clamps and disables mipmapping (minFilter LINEAR).
    let t = s.textures[by_name("Rotation").base_color_texture.unwrap().texture as usize];
    assert_eq!(t.sampler.wrap_s, Wrap::ClampToEdge);
    assert!(!t.sampler.mipmaps && t.sampler.min_linear && t.sampler.mag_linear);
    assert!(s.images.iter().all(|i| i.srgb && i.width > 0));
}

#[test]
fn multiple_scenes_and_scene_choice() {
    let s = load("MultipleScenes/MultipleScenes.gltf");
    assert_eq!(s.triangle_count(), 2, "default scene 1: the square");
    assert_eq!(
        load_scene("MultipleScenes/MultipleScenes.gltf", 0)
            .unwrap()
            .triangle_count(),
        1
    );
    let e = load_scene("MultipleScenes/MultipleScenes.gltf", 2)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("MultipleScenes.gltf") && e.contains("scene 2") && e.contains("2 scenes"),
        "{e}"
    );
}

#[test]
fn cameras_perspective_and_orthographic() {
    let s = load("Cameras/Cameras.gltf");
    assert_eq!(s.cameras.len(), 2);
    assert_eq!(
        s.cameras[0].projection,
        Projection::Perspective {
            yfov: 0.7,
            aspect: Some(1.0),
            znear: 0.01,
            zfar: Some(100.0)
        }
    );
    assert_eq!(
        s.cameras[1].projection,
        Projection::Orthographic {
            xmag: 1.0,
            ymag: 1.0,
            znear: 0.01,
            zfar: 100.0
        }
    );
    for c in &s.cameras {
        assert!(close3(c.position(), Vec3::new(0.5, 0.5, 3.0), 1e-6));
        assert!(close3(c.forward(), Vec3::NEG_Z, 1e-6));
    }
    assert_eq!(s.camera(None, 1.5).unwrap(), s.cameras[0]);
    assert_eq!(s.camera(Some(1), 1.5).unwrap(), s.cameras[1]);
    let e = s.camera(Some(2), 1.0).unwrap_err().to_string();
    assert!(e.contains("camera 2") && e.contains("2 cameras"), "{e}");
    // Without file cameras: the automatic camera sees the whole scene.
    let tri = load("Triangle/Triangle.gltf");
    let auto = tri.camera(None, 1.0).unwrap();
    assert!(auto.position().z > tri.bounds.max.z);
}

#[test]
fn camera_scale_is_removed() {
    let mut b = Builder::default();
    let mut doc = quad_doc(&mut b, json!({}));
    doc["cameras"] = json!([{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}]);
    doc["nodes"] = json!([{"mesh": 0}, {"camera": 0, "scale": [2, 3, 4], "translation": [1, 2, 10],
        "rotation": [0, 0.2588190451, 0, 0.9659258263]}]);
    doc["scenes"] = json!([{"nodes": [0, 1]}]);
    let s = from_json(&b.document(doc)).unwrap();
    let c = s.cameras[0].camera_to_world;
    assert!((c.determinant() - 1.0).abs() < 1e-5);
    assert!(close3(c.w_axis.truncate(), Vec3::new(1.0, 2.0, 10.0), 1e-6));
    let r = Mat4::from_rotation_y(30f32.to_radians());
    assert!(c.z_axis.abs_diff_eq(r.z_axis, 1e-5));
    assert_eq!(
        s.cameras[0].projection,
        Projection::Perspective {
            yfov: 0.8,
            aspect: None,
            znear: 0.1,
            zfar: None
        }
    );
}

#[test]
fn triangle_without_indices_gets_flat_normals() {
    let s = load("TriangleWithoutIndices/TriangleWithoutIndices.gltf");
    let g = &s.geometries[0];
    assert_eq!(g.indices, vec![0, 1, 2]);
    assert!(g.normals.iter().all(|n| close3(*n, Vec3::Z, 1e-6)));
    assert!(s.default_lights && !s.lights.is_empty());
}

#[test]
fn strips_and_fans_become_lists_with_consistent_winding() {
    // Five vertices on a fan/strip in the XY plane, all triangles facing +Z when wound
    // as glTF defines.
    for (mode, positions, want) in [
        (
            5,
            vec![
                0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 0.0, 2.0, 0.0,
            ],
            vec![0, 1, 2, 1, 3, 2, 2, 3, 4],
        ),
        (
            6,
            vec![
                0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0, -1.0, 1.0, 0.0,
            ],
            vec![1, 2, 0, 2, 3, 0, 3, 4, 0],
        ),
    ] {
        let mut b = Builder::default();
        let pos = b.floats(&positions, "VEC3");
        let doc = json!({
            "scenes": [{"nodes": [0]}],
            "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": pos}, "mode": mode}]}],
        });
        let s = from_json(&b.document(doc)).unwrap();
        let g = &s.geometries[0];
        // Flat normals un-weld the vertices, so compare triangle corners by position.
        let corners: Vec<Vec3> = g.indices.iter().map(|&i| g.positions[i as usize]).collect();
        let expected: Vec<Vec3> = want
            .iter()
            .map(|&i| Vec3::from_slice(&positions[i * 3..]))
            .collect();
        assert_eq!(corners, expected, "mode {mode}");
        assert_eq!(s.triangle_count(), 3);
        // Flat normals were computed from the winding: all +Z.
        assert!(
            g.normals.iter().all(|n| close3(*n, Vec3::Z, 1e-6)),
            "mode {mode}"
        );
    }
    // Indexed strip, and points are skipped (but counted as primitives).
    let mut b = Builder::default();
    let pos = b.floats(
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0],
        "VEC3",
    );
    let idx = b.indices_u16(&[3, 2, 1, 0]);
    let doc = json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [
            {"attributes": {"POSITION": pos}, "indices": idx, "mode": 5},
            {"attributes": {"POSITION": pos}, "mode": 0},
        ]}],
    });
    let s = from_json(&b.document(doc)).unwrap();
    assert_eq!(s.primitive_count, 2);
    assert_eq!(s.geometries.len(), 1);
    let g = &s.geometries[0];
    let corners: Vec<Vec3> = g.indices.iter().map(|&i| g.positions[i as usize]).collect();
    let p = |x: f32, y: f32| Vec3::new(x, y, 0.0);
    // Strip 3, 2, 1, 0 → (3, 2, 1), (2, 0, 1).
    assert_eq!(
        corners,
        vec![
            p(1.0, 1.0),
            p(0.0, 1.0),
            p(1.0, 0.0),
            p(0.0, 1.0),
            p(0.0, 0.0),
            p(1.0, 0.0)
        ]
    );
}

#[test]
fn glb_gltf_and_external_files_load_the_same() {
    let mut b = Builder::default();
    let doc = quad_doc(&mut b, json!({}));
    let from_gltf = from_json(&b.document(doc.clone())).unwrap();
    let from_glb =
        scene::load_slice(&b.glb(doc.clone()), None, "t.glb", &LoadOptions::default()).unwrap();
    assert_eq!(
        from_gltf.geometries[0].positions,
        from_glb.geometries[0].positions
    );
    assert_eq!(
        from_gltf.geometries[0].indices,
        from_glb.geometries[0].indices
    );

    // External buffer and image with a percent-encoded file name.
    let dir = std::env::temp_dir().join(format!("rqr-scene-ext-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("my data.bin"), &b.bin).unwrap();
    std::fs::write(dir.join("tex.png"), png(1, 1, &[255, 0, 0, 255])).unwrap();
    let mut ext = b.document(doc);
    ext["buffers"][0]["uri"] = json!("my%20data.bin");
    ext["images"] = json!([{"uri": "tex.png"}]);
    ext["textures"] = json!([{"source": 0}]);
    ext["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    ext["meshes"][0]["primitives"][0]["material"] = json!(0);
    let path = dir.join("scene.gltf");
    std::fs::write(&path, bytes(&ext)).unwrap();
    let s = scene::load(&path, &LoadOptions::default()).unwrap();
    assert_eq!(s.geometries[0].positions, from_gltf.geometries[0].positions);
    assert_eq!(s.images[0].rgba8, vec![255, 0, 0, 255]);
    assert_eq!(s.source, path.display().to_string());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn quantized_attributes_are_dequantized() {
    // KHR_mesh_quantization: SHORT positions (not normalized), BYTE normalized normals,
    // UNSIGNED_SHORT normalized UVs, UNSIGNED_BYTE normalized VEC3 colours.
    let mut b = Builder::default();
    let pos: Vec<u8> = [[0i16, 0, 0, 0], [100, 0, 0, 0], [0, 100, 0, 0]]
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let pv = b.view(&pos);
    b.views[pv]["byteStride"] = json!(8);
    let pa = b.accessor(
        json!({"bufferView": pv, "componentType": 5122, "count": 3, "type": "VEC3",
        "min": [0, 0, 0], "max": [100, 100, 0]}),
    );
    let nv = b.view(&[0, 0, 127, 0, 0, 0, 127, 0, 0, 0, 0x81, 0]);
    b.views[nv]["byteStride"] = json!(4);
    let na = b.accessor(json!({"bufferView": nv, "componentType": 5120, "normalized": true, "count": 3, "type": "VEC3"}));
    let uv: Vec<u8> = [0u16, 0, 65535, 0, 0, 32768]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let uvv = b.view(&uv);
    let ua = b.accessor(json!({"bufferView": uvv, "componentType": 5123, "normalized": true, "count": 3, "type": "VEC2"}));
    let cv = b.view(&[255, 0, 0, 0, 0, 255, 0, 0, 0, 0, 255, 0]);
    b.views[cv]["byteStride"] = json!(4);
    let ca = b.accessor(json!({"bufferView": cv, "componentType": 5121, "normalized": true, "count": 3, "type": "VEC3"}));
    let doc = json!({
        "extensionsUsed": ["KHR_mesh_quantization"],
        "extensionsRequired": ["KHR_mesh_quantization"],
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "scale": [0.01, 0.01, 0.01]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pa, "NORMAL": na, "TEXCOORD_0": ua, "COLOR_0": ca}}]}],
    });
    let s = from_json(&b.document(doc)).unwrap();
    let g = &s.geometries[0];
    assert_eq!(g.positions[1], Vec3::new(100.0, 0.0, 0.0));
    assert_eq!(g.normals[0], Vec3::Z);
    assert_eq!(g.normals[2], Vec3::NEG_Z, "-127 and -128 both map to -1");
    assert_eq!(g.uv0[1], Vec2::new(1.0, 0.0));
    assert!((g.uv0[2].y - 32768.0 / 65535.0).abs() < 1e-7);
    assert_eq!(g.colors[1], Vec4::new(0.0, 1.0, 0.0, 1.0));
    assert!(close3(s.bounds.max, Vec3::new(1.0, 1.0, 0.0), 1e-6));
    assert!(s.extensions_unsupported.is_empty());
}

#[test]
fn srgb_only_for_colour_images_and_decoded_once() {
    let mut b = Builder::default();
    let doc_base = quad_doc(&mut b, json!({"material": 0}));
    let uv = b.floats(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0], "VEC2");
    let img = b.view(&png(2, 1, &[10, 20, 30, 255, 40, 50, 60, 255]));
    let mut doc = doc_base;
    doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(uv);
    doc["images"] = json!([{"bufferView": img, "mimeType": "image/png"}]);
    doc["samplers"] = json!([{"magFilter": 9728, "minFilter": 9984, "wrapS": 33648}]);
    doc["textures"] = json!([{"source": 0, "sampler": 0}, {"source": 0}]);
    doc["materials"] = json!([{
        "pbrMetallicRoughness": {
            "baseColorTexture": {"index": 0},
            "metallicRoughnessTexture": {"index": 1},
        },
        "emissiveTexture": {"index": 0},
        "normalTexture": {"index": 1, "scale": 0.5},
        "occlusionTexture": {"index": 1, "strength": 0.25},
        "alphaMode": "MASK",
        "alphaCutoff": 0.3,
        "doubleSided": true,
    }]);
    let s = from_json(&b.document(doc)).unwrap();
    let m = &s.materials[0];
    let base = m.base_color_texture.unwrap().texture as usize;
    let emissive = m.emissive_texture.unwrap().texture as usize;
    let mr = m.metallic_roughness_texture.unwrap().texture as usize;
    let normal = m.normal_texture.unwrap().texture as usize;
    assert_eq!(
        base, emissive,
        "same glTF texture, same colour space: one texture"
    );
    assert_eq!(mr, normal);
    assert_ne!(base, mr);
    let img = |t: usize| &s.images[s.textures[t].image as usize];
    assert!(img(base).srgb);
    assert!(!img(mr).srgb);
    assert_eq!(s.images.len(), 2, "one image per colour space");
    assert_eq!(img(base).rgba8, img(mr).rgba8);
    assert_eq!((img(base).width, img(base).height), (2, 1));
    let sampler = s.textures[base].sampler;
    assert!(!sampler.mag_linear && !sampler.min_linear && !sampler.mip_linear && sampler.mipmaps);
    assert_eq!(sampler.wrap_s, Wrap::MirroredRepeat);
    assert_eq!(sampler.wrap_t, Wrap::Repeat);
    assert_eq!((m.normal_scale, m.occlusion_strength), (0.5, 0.25));
    assert_eq!(
        (m.alpha_mode, m.alpha_cutoff, m.double_sided),
        (AlphaMode::Mask, 0.3, true)
    );
    // The normal map needs tangents: computed with MikkTSpace (the file has none).
    let g = &s.geometries[0];
    assert_eq!(g.tangents.len(), g.positions.len());
    assert!(g
        .tangents
        .iter()
        .all(|t| close3(t.truncate(), Vec3::X, 1e-5) && t.w == 1.0));
    // BoxTextured: its only image is a base colour.
    let bt = load("BoxTextured/BoxTextured.glb");
    assert!(bt.images.len() == 1 && bt.images[0].srgb);
    assert!(
        bt.geometries[0].tangents.is_empty(),
        "no normal map, no tangents"
    );
}

#[test]
fn punctual_lights_in_world_space() {
    let mut b = Builder::default();
    let mut doc = quad_doc(&mut b, json!({}));
    doc["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"type": "spot", "intensity": 40, "range": 12, "color": [1, 0.5, 0.25],
         "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.6}},
        {"type": "point", "intensity": 25},
        {"type": "directional", "intensity": 3},
    ]}});
    // Spot: rotated -90° about X (its -Z now points down) under a translated parent.
    let h = std::f32::consts::FRAC_1_SQRT_2;
    doc["nodes"] = json!([
        {"mesh": 0},
        {"translation": [0, 3, 0], "children": [2, 3, 4]},
        {"extensions": {"KHR_lights_punctual": {"light": 0}}, "translation": [1, 0, 0],
         "rotation": [-h, 0, 0, h]},
        {"extensions": {"KHR_lights_punctual": {"light": 1}}, "translation": [0, 1, 0], "scale": [5, 5, 5]},
        {"extensions": {"KHR_lights_punctual": {"light": 2}}, "rotation": [0, h, 0, h]},
    ]);
    doc["scenes"] = json!([{"nodes": [0, 1]}]);
    let s = from_json(&b.document(doc)).unwrap();
    assert!(!s.default_lights);
    assert_eq!(s.lights.len(), 3);
    let spot = s.lights[0];
    assert_eq!(
        spot.kind,
        LightKind::Spot {
            inner_cone: 0.2,
            outer_cone: 0.6
        }
    );
    assert!(close3(spot.position, Vec3::new(1.0, 3.0, 0.0), 1e-6));
    assert!(close3(spot.direction, Vec3::NEG_Y, 1e-5));
    assert_eq!(
        (spot.intensity, spot.range, spot.color),
        (40.0, 12.0, Vec3::new(1.0, 0.5, 0.25))
    );
    let point = s.lights[1];
    assert_eq!(point.kind, LightKind::Point);
    assert!(close3(point.position, Vec3::new(0.0, 4.0, 0.0), 1e-6));
    assert_eq!(point.range, f32::INFINITY);
    let sun = s.lights[2];
    assert_eq!(sun.kind, LightKind::Directional);
    assert!(
        close3(sun.direction, Vec3::NEG_X, 1e-5),
        "+90° about Y turns -Z into -X"
    );
}

#[test]
fn mirrored_nodes_keep_their_transform() {
    let mut b = Builder::default();
    let mut doc = quad_doc(&mut b, json!({}));
    doc["nodes"] = json!([{"mesh": 0, "scale": [-1, 1, 1]}, {"mesh": 0, "translation": [3, 0, 0]}]);
    doc["scenes"] = json!([{"nodes": [0, 1]}]);
    let s = from_json(&b.document(doc)).unwrap();
    assert_eq!(s.geometries.len(), 1);
    assert_eq!(s.instances.len(), 2);
    assert!(s.instances[0].flips_winding());
    assert!(!s.instances[1].flips_winding());
    assert_eq!(s.bounds.min.x, -1.0);
    assert_eq!(s.bounds.max.x, 4.0);
}

#[test]
fn emissive_strength_multiplies_the_factor() {
    let s = load("EmissiveStrengthTest/EmissiveStrengthTest.glb");
    let e = |n: &str| s.materials.iter().find(|m| m.name == n).unwrap().emissive;
    assert!(close3(e("Emit1"), Vec3::new(0.1, 0.5, 0.9), 1e-6));
    assert!(close3(e("Emit16"), Vec3::new(1.6, 8.0, 14.4), 1e-5));
}
