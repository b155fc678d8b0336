//! EXT_meshopt_compression and KHR_draco_mesh_compression: files made with gltfpack and Draco
//! load with the same triangles and positions (within quantization) as their sources and render
//! alike (broken ones are in the bad-input binary, `compression`).

use crate::support;
use crate::support::scene_files;

use glam::Vec3;
use rqr::scene::{self, LoadOptions, Scene};
use scene_files::asset;
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
