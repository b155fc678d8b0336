//! EXT_meshopt_compression: files made with gltfpack load with the same triangles and
//! positions (within quantization) as their sources and render alike; broken compressed views
//! fail with errors naming the file and the buffer view.

mod common;
mod scene_util;

use glam::Vec3;
use rqr::accel::Backend;
use rqr::render::image::compare;
use rqr::render::{RenderSettings, Renderer};
use rqr::scene::{self, LoadOptions, Scene};
use scene_util::asset;
use serde_json::{json, Value};

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
    let ctx = common::gpu();
    let a = load("Avocado/Avocado.gltf");
    let b = load("Avocado/Avocado_meshopt.glb");
    let camera = scene::auto_camera(&a.bounds, 1.0);
    let settings = RenderSettings {
        width: 96,
        height: 96,
        ..Default::default()
    };
    let mut backends = vec![Backend::Bvh];
    if ctx.features().ray_query {
        backends.insert(0, Backend::Hw);
    }
    for backend in backends {
        let render = |s: &Scene| {
            Renderer::new(&ctx, s, backend)
                .unwrap()
                .render_rt(&ctx, &settings, &camera, false)
                .unwrap()
                .rgba8
        };
        let d = compare::compare(96, 96, &render(&a), &render(&b));
        eprintln!(
            "Avocado vs Avocado_meshopt, {}: FLIP mean {:.5}",
            backend.as_str(),
            d.flip_mean
        );
        assert!(
            d.flip_mean < 0.01,
            "{}: FLIP {} between Avocado and its meshopt copy",
            backend.as_str(),
            d.flip_mean
        );
    }
    common::assert_validation_clean(&ctx);
}

/// The meshopt box with its JSON edited.
pub fn edited_box(edit: impl Fn(&mut Value)) -> Vec<u8> {
    let data = std::fs::read(asset("BoxTextured_meshopt/BoxTextured_meshopt.glb")).unwrap();
    let json_len = u32::from_le_bytes(data[12..16].try_into().unwrap()) as usize;
    let mut doc: Value = serde_json::from_slice(&data[20..20 + json_len]).unwrap();
    let bin_start = 20 + json_len;
    let bin_len = u32::from_le_bytes(data[bin_start..bin_start + 4].try_into().unwrap()) as usize;
    edit(&mut doc);
    scene_util::glb(
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
