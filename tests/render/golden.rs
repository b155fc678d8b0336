//! Golden images of the pure ray-traced path (96×96, both backends), compared with NVIDIA FLIP.
//!
//! On failure the test writes `tests/golden/<name>-actual.png` and `<name>-diff.png` (FLIP
//! heat map). A missing golden is written and the test fails: look at it, then commit it.
//! `RQR_BLESS=1` rewrites every golden (only after looking at the differences).

use crate::support;
use crate::support::scene_files::load_asset;

use std::path::{Path, PathBuf};

use rqr::accel::Backend;
use rqr::render::image::metrics;
use rqr::render::{RenderSettings, Renderer};
use rqr::scene::Scene;

const SIZE: u32 = 96;
/// Mean FLIP allowed against the golden: a wrong shadow or a flipped normal on a 96² image
/// moves the mean by several hundredths, float noise between runs by < 0.001.
const MAX_MEAN: f32 = 0.004;
/// 99th-percentile FLIP allowed (a few isolated pixels may flip at silhouettes).
const MAX_P99: f32 = 0.12;

fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

fn save(path: &Path, w: u32, h: u32, rgba: &[u8]) {
    image::RgbaImage::from_raw(w, h, rgba.to_vec())
        .unwrap()
        .save(path)
        .unwrap();
}

/// Renders `scene` with every backend and checks each against `tests/golden/<name>.png`.
fn check(name: &str, scene: &Scene, settings: &RenderSettings) {
    let ctx = support::gpu();
    let camera = scene.cameras.first().copied().unwrap_or_else(|| {
        rqr::scene::auto_camera(
            &scene.bounds,
            settings.width as f32 / settings.height as f32,
        )
    });
    let golden_path = golden_dir().join(format!("{name}.png"));
    let bless = std::env::var("RQR_BLESS").is_ok_and(|v| v == "1");
    let mut backends = vec![Backend::Bvh];
    if ctx.features().ray_query {
        backends.insert(0, Backend::Hw);
    }
    let mut failures = Vec::new();
    for backend in backends {
        let renderer = Renderer::new(&ctx, scene, backend).unwrap();
        let out = renderer.render_rt(&ctx, settings, &camera, false).unwrap();
        if !golden_path.exists() || (bless && backend == Backend::Hw) {
            save(&golden_path, out.width, out.height, &out.rgba8);
            if !bless {
                failures.push(format!(
                    "{name}: no golden image; wrote {} — look at it, then commit it",
                    golden_path.display()
                ));
            }
            continue;
        }
        let golden = image::open(&golden_path).unwrap().to_rgba8();
        assert_eq!(
            (golden.width(), golden.height()),
            (out.width, out.height),
            "{name}: golden size"
        );
        let d = metrics::compare(out.width, out.height, golden.as_raw(), &out.rgba8);
        if d.flip_mean > MAX_MEAN || d.flip_p99 > MAX_P99 {
            let actual = golden_dir().join(format!("{name}-{}-actual.png", backend.as_str()));
            let diff = golden_dir().join(format!("{name}-{}-diff.png", backend.as_str()));
            save(&actual, out.width, out.height, &out.rgba8);
            image::RgbImage::from_raw(out.width, out.height, d.heatmap.clone())
                .unwrap()
                .save(&diff)
                .unwrap();
            failures.push(format!(
                "{name} ({}): FLIP mean {:.5} (max {MAX_MEAN}), p99 {:.4} (max {MAX_P99}); see {} and {}",
                backend.as_str(),
                d.flip_mean,
                d.flip_p99,
                actual.display(),
                diff.display()
            ));
        }
    }
    support::assert_validation_clean(&ctx);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

fn small() -> RenderSettings {
    RenderSettings {
        width: SIZE,
        height: SIZE,
        ..Default::default()
    }
}

/// Built-in room: checker texture (sRGB, mips), point + spot light shadows, mirror sphere
/// reflections, glass sphere refraction, glass block total internal reflection.
#[test]
fn golden_builtin_scene() {
    check("builtin", &rqr::scene::load_default().unwrap(), &small());
}

/// Built-in room at depth 1: direct light and shadows only (no reflection or refraction).
#[test]
fn golden_builtin_depth1() {
    let s = RenderSettings {
        max_depth: 1,
        ..small()
    };
    check("builtin-depth1", &rqr::scene::load_default().unwrap(), &s);
}

/// Normal maps with mirrored UVs (tangent handedness), default sun light.
#[test]
fn golden_normal_tangent_mirror() {
    check(
        "normal-tangent-mirror",
        &load_asset("NormalTangentMirrorTest/NormalTangentMirrorTest.glb"),
        &small(),
    );
}

/// Alpha OPAQUE / MASK (cutoff) / BLEND side by side over a textured background.
#[test]
fn golden_alpha_modes() {
    check(
        "alpha-blend-mode",
        &load_asset("AlphaBlendModeTest/AlphaBlendModeTest.glb"),
        &small(),
    );
}

/// Transmission with KHR_materials_volume attenuation (Beer–Lambert) of several colours.
#[test]
fn golden_attenuation() {
    check(
        "attenuation",
        &load_asset("AttenuationTest/AttenuationTest.glb"),
        &small(),
    );
}

/// KHR_materials_emissive_strength.
#[test]
fn golden_emissive_strength() {
    check(
        "emissive-strength",
        &load_asset("EmissiveStrengthTest/EmissiveStrengthTest.glb"),
        &small(),
    );
}

/// Base-colour texture with KHR_texture_transform (offset, rotation, scale).
#[test]
fn golden_texture_transform() {
    check(
        "texture-transform",
        &load_asset("TextureTransformTest/TextureTransformTest.gltf"),
        &small(),
    );
}

/// Under a bright sky gradient, so that reflections show.
fn sky() -> RenderSettings {
    RenderSettings {
        sky: true,
        background: glam::Vec3::ONE,
        ..small()
    }
}

/// KHR_materials_clearcoat: columns without coat, coated, coat only, in rows of factor,
/// roughness, textures and clearcoat normal maps; the coat adds a sharp reflection lobe.
#[test]
fn golden_clearcoat() {
    check(
        "clearcoat",
        &load_asset("ClearCoatTest/ClearCoatTest.glb"),
        &sky(),
    );
}

/// KHR_materials_specular: black dielectric spheres that show only their specular
/// reflection, with specular factor, texture and colour varying per row.
#[test]
fn golden_specular() {
    check(
        "specular",
        &load_asset("SpecularTest/SpecularTest.glb"),
        &sky(),
    );
}
