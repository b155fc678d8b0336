//! Texture coordinate sets beyond TEXCOORD_1, MultiUVTest, and the layered-material
//! extensions (KHR_materials_specular, _clearcoat) against the same scenes without them.

use crate::support;
use crate::support::scene_files;

use glam::Vec2;
use rqr::accel::Backend;
use rqr::render::image::metrics;
use rqr::render::{RenderSettings, Renderer};
use rqr::scene::{self, Camera, LoadOptions, Scene};
use scene_files::{asset, bytes, png, quad_doc, Builder};
use serde_json::{json, Value};

const SIZE: u32 = 64;

fn render(ctx: &rqr::vk::Context, scene: &Scene, camera: &Camera, backend: Backend) -> Vec<u8> {
    let settings = RenderSettings {
        width: SIZE,
        height: SIZE,
        ..Default::default()
    };
    render_with(ctx, scene, camera, backend, &settings)
}

/// Size of the material comparisons (the sample models' spheres are small in frame).
const MATERIAL_SIZE: u32 = 128;

/// Renders for the material comparisons: a bright sky gradient, so that what a surface
/// reflects is visible (the default background is nearly black).
fn render_lit(ctx: &rqr::vk::Context, scene: &Scene, camera: &Camera, backend: Backend) -> Vec<u8> {
    let settings = RenderSettings {
        width: MATERIAL_SIZE,
        height: MATERIAL_SIZE,
        sky: true,
        background: glam::Vec3::ONE,
        ..Default::default()
    };
    render_with(ctx, scene, camera, backend, &settings)
}

fn render_with(
    ctx: &rqr::vk::Context,
    scene: &Scene,
    camera: &Camera,
    backend: Backend,
    settings: &RenderSettings,
) -> Vec<u8> {
    Renderer::new(ctx, scene, backend)
        .unwrap()
        .render_rt(ctx, settings, camera, false)
        .unwrap()
        .rgba8
}

fn backends(ctx: &rqr::vk::Context) -> Vec<Backend> {
    let mut b = vec![Backend::Bvh];
    if ctx.features().ray_query {
        b.insert(0, Backend::Hw);
    }
    b
}

fn camera_for(scene: &Scene) -> Camera {
    scene
        .cameras
        .first()
        .copied()
        .unwrap_or_else(|| scene::auto_camera(&scene.bounds, 1.0))
}

/// Mean of (r + g + b) / 3 over the image, in 8-bit units.
fn mean_level(rgba: &[u8]) -> f64 {
    let sum: u64 = rgba
        .chunks_exact(4)
        .map(|p| u64::from(p[0]) + u64::from(p[1]) + u64::from(p[2]))
        .sum();
    sum as f64 / (rgba.len() / 4 * 3) as f64
}

/// Mean per-pixel brightening and darkening of `a` against `b` (8-bit units, channel mean).
fn gain_loss(a: &[u8], b: &[u8]) -> (f64, f64) {
    let (mut gain, mut loss) = (0i64, 0i64);
    for (x, y) in a
        .iter()
        .zip(b)
        .enumerate()
        .filter(|(i, _)| i % 4 != 3)
        .map(|(_, p)| p)
    {
        let d = i64::from(*x) - i64::from(*y);
        if d > 0 {
            gain += d;
        } else {
            loss -= d;
        }
    }
    let n = (a.len() / 4 * 3) as f64;
    (gain as f64 / n, loss as f64 / n)
}

/// Writes an image under `target/` for looking at (`RQR_SAVE_IMAGES=1` only).
fn save_png(name: &str, rgba: &[u8]) {
    if std::env::var("RQR_SAVE_IMAGES").is_ok_and(|v| v == "1") {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("target/test-images");
        std::fs::create_dir_all(&dir).unwrap();
        image::RgbaImage::from_raw(MATERIAL_SIZE, MATERIAL_SIZE, rgba.to_vec())
            .unwrap()
            .save(dir.join(format!("{name}.png")))
            .unwrap();
    }
}

fn load_doc(doc: &Value) -> Scene {
    scene::load_slice(&bytes(doc), None, "sets.gltf", &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
}

/// A unit quad whose base colour texture (2×2: red, green / blue, white, nearest) reads
/// TEXCOORD_`set`; every other set present holds UVs that would show one texel only.
fn quad_on_set(set: u32, sets_present: &[u32]) -> Value {
    let mut b = Builder::default();
    let mut doc = quad_doc(&mut b, json!({"material": 0}));
    for &k in sets_present {
        let uv: Vec<f32> = if k == set {
            vec![0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0]
        } else {
            vec![0.25; 8]
        };
        let acc = b.floats(&uv, "VEC2");
        doc["meshes"][0]["primitives"][0]["attributes"][format!("TEXCOORD_{k}")] = json!(acc);
    }
    let img = b.view(&png(
        2,
        2,
        &[
            255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 255,
        ],
    ));
    doc["images"] = json!([{"bufferView": img, "mimeType": "image/png"}]);
    doc["samplers"] = json!([{"magFilter": 9728, "minFilter": 9728}]);
    doc["textures"] = json!([{"source": 0, "sampler": 0}]);
    doc["materials"] = json!([{
        "pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "texCoord": set}, "metallicFactor": 0},
        "emissiveFactor": [1, 1, 1],
        "emissiveTexture": {"index": 0, "texCoord": set},
    }]);
    b.document(doc)
}

#[test]
fn every_texcoord_set_is_read() {
    // The same picture through TEXCOORD_0, _1, _2 and _5 (the others hold decoys).
    let reference = load_doc(&quad_on_set(0, &[0]));
    let camera = scene::auto_camera(&reference.bounds, 1.0);
    let ctx = support::gpu();
    for backend in backends(&ctx) {
        let want = render(&ctx, &reference, &camera, backend);
        assert!(mean_level(&want) > 20.0, "the reference shows the texture");
        for (set, present) in [(1u32, vec![0u32, 1]), (2, vec![0, 2]), (5, vec![0, 1, 5])] {
            let s = load_doc(&quad_on_set(set, &present));
            let m = &s.materials[0];
            assert_eq!(m.base_color_texture.unwrap().tex_coord, set);
            let stored = if set <= 1 { [0, 1] } else { [set, set] };
            assert_eq!(m.uv_sets, stored, "TEXCOORD_{set}");
            let got = render(&ctx, &s, &camera, backend);
            let d = metrics::compare(SIZE, SIZE, &want, &got);
            assert!(
                d.flip_mean < 1e-3,
                "{}: TEXCOORD_{set}: FLIP {} against TEXCOORD_0",
                backend.as_str(),
                d.flip_mean
            );
        }
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn two_high_sets_in_one_material() {
    // Base colour on TEXCOORD_3, emissive on TEXCOORD_2: stored as uv0 = set 2, uv1 = set 3.
    let mut doc = quad_on_set(3, &[0, 2, 3]);
    doc["materials"][0]["emissiveTexture"]["texCoord"] = json!(2);
    let s = load_doc(&doc);
    let m = &s.materials[0];
    assert_eq!(m.uv_sets, [2, 3]);
    assert_eq!(m.stored_uv_set(2), 0);
    assert_eq!(m.stored_uv_set(3), 1);
    let g = &s.geometries[0];
    assert_eq!(g.uv0[0], Vec2::splat(0.25), "uv0 holds TEXCOORD_2 (decoy)");
    assert_eq!(g.uv1[0], Vec2::new(0.0, 1.0), "uv1 holds TEXCOORD_3");
    let gpu = rqr::scene::gpu::gpu_material(m);
    assert_eq!(gpu.base_color_texture.tex_coord, 1);
    assert_eq!(gpu.emissive_texture.tex_coord, 0);
}

/// Rewrites the JSON chunk of a GLB.
fn edit_glb(path: &str, edit: impl Fn(&mut Value)) -> Scene {
    let data = std::fs::read(asset(path)).unwrap();
    let json_len = u32::from_le_bytes(data[12..16].try_into().unwrap()) as usize;
    let mut doc: Value = serde_json::from_slice(&data[20..20 + json_len]).unwrap();
    let bin_start = 20 + json_len;
    let bin_len = u32::from_le_bytes(data[bin_start..bin_start + 4].try_into().unwrap()) as usize;
    let bin = &data[bin_start + 8..bin_start + 8 + bin_len];
    edit(&mut doc);
    let glb = scene_files::glb(&serde_json::to_vec(&doc).unwrap(), Some(bin));
    scene::load_slice(&glb, None, path, &LoadOptions::default()).unwrap()
}

#[test]
fn multi_uv_test_reads_each_texture_through_its_own_set() {
    // MultiUVTest: base colour on TEXCOORD_0, emissive on TEXCOORD_1. Swapping the two
    // attributes AND the two texCoords must give the same image; swapping the attributes
    // alone must not (each texture really follows its own set).
    let original = scene::load(
        &asset("MultiUVTest/MultiUVTest.glb"),
        &LoadOptions::default(),
    )
    .unwrap();
    let swap_attributes = |doc: &mut Value| {
        for mesh in doc["meshes"].as_array_mut().unwrap() {
            for prim in mesh["primitives"].as_array_mut().unwrap() {
                let a = prim["attributes"].as_object_mut().unwrap();
                let t0 = a["TEXCOORD_0"].clone();
                let t1 = a["TEXCOORD_1"].clone();
                a.insert("TEXCOORD_0".into(), t1);
                a.insert("TEXCOORD_1".into(), t0);
            }
        }
    };
    let both = edit_glb("MultiUVTest/MultiUVTest.glb", |doc| {
        swap_attributes(doc);
        let m = &mut doc["materials"][0];
        m["pbrMetallicRoughness"]["baseColorTexture"]["texCoord"] = json!(1);
        m["emissiveTexture"]["texCoord"] = json!(0);
    });
    let attributes_only = edit_glb("MultiUVTest/MultiUVTest.glb", swap_attributes);
    let camera = camera_for(&original);
    let ctx = support::gpu();
    for backend in backends(&ctx) {
        let a = render(&ctx, &original, &camera, backend);
        let b = render(&ctx, &both, &camera, backend);
        let c = render(&ctx, &attributes_only, &camera, backend);
        let same = metrics::compare(SIZE, SIZE, &a, &b).flip_mean;
        let swapped = metrics::compare(SIZE, SIZE, &a, &c).flip_mean;
        eprintln!(
            "MultiUVTest {}: consistent swap FLIP {same:.5}, attributes only {swapped:.5}",
            backend.as_str()
        );
        assert!(
            same < 1e-3,
            "{}: consistent swap: FLIP {same}",
            backend.as_str()
        );
        assert!(
            swapped > 0.02,
            "{}: attribute swap alone: FLIP {swapped}",
            backend.as_str()
        );
    }
    support::assert_validation_clean(&ctx);
}

/// The scene with every material's layered extensions removed (as if the file had none).
fn stripped(scene: &Scene) -> Scene {
    let mut s = scene.clone();
    for m in &mut s.materials {
        m.layers = None;
    }
    s
}

#[test]
fn specular_factor_removes_highlights() {
    // SpecularTest: black dielectric spheres whose specularFactor and colour vary per row;
    // all they show is their specular reflection. Rendered with every specularFactor set to
    // 0, they must lose light against the same scene without the extension (default
    // specular), and gain none; the file as it is must differ from the stripped scene too.
    let s = scene::load(
        &asset("SpecularTest/SpecularTest.glb"),
        &LoadOptions::default(),
    )
    .unwrap();
    let zero = s
        .materials
        .iter()
        .find(|m| m.name == "M1.1_specFac")
        .expect("material M1.1_specFac");
    assert_eq!(zero.layers.as_ref().unwrap().specular, 0.0);
    let mut factor_zero = s.clone();
    for m in &mut factor_zero.materials {
        if let Some(l) = &mut m.layers {
            l.specular = 0.0;
        }
    }
    let camera = camera_for(&s);
    let plain = stripped(&s);
    let ctx = support::gpu();
    for backend in backends(&ctx) {
        let with = render_lit(&ctx, &s, &camera, backend);
        let zero = render_lit(&ctx, &factor_zero, &camera, backend);
        let without = render_lit(&ctx, &plain, &camera, backend);
        save_png(&format!("specular-{}", backend.as_str()), &with);
        save_png(&format!("specular-zero-{}", backend.as_str()), &zero);
        save_png(&format!("specular-stripped-{}", backend.as_str()), &without);
        let (gain, loss) = gain_loss(&zero, &without);
        let flip = metrics::compare(MATERIAL_SIZE, MATERIAL_SIZE, &without, &with).flip_mean;
        eprintln!(
            "specular {}: factor 0 vs stripped: gain {gain:.3}, loss {loss:.3}; file vs stripped: FLIP {flip:.4}",
            backend.as_str()
        );
        assert!(
            loss > 0.2 && gain < 0.1 * loss,
            "{}: specularFactor 0 should only darken: gain {gain:.3}, loss {loss:.3}",
            backend.as_str()
        );
        assert!(
            flip > 0.005,
            "{}: the extension changes nothing (FLIP {flip})",
            backend.as_str()
        );
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn clearcoat_adds_reflection() {
    let s = scene::load(
        &asset("ClearCoatTest/ClearCoatTest.glb"),
        &LoadOptions::default(),
    )
    .unwrap();
    let coated = s
        .materials
        .iter()
        .find(|m| m.name == "Simple_Coated")
        .expect("material Simple_Coated");
    assert_eq!(coated.layers.as_ref().unwrap().clearcoat, 1.0);
    let camera = camera_for(&s);
    let plain = stripped(&s);
    let ctx = support::gpu();
    for backend in backends(&ctx) {
        let with = render_lit(&ctx, &s, &camera, backend);
        let without = render_lit(&ctx, &plain, &camera, backend);
        let (lw, lo) = (mean_level(&with), mean_level(&without));
        let (gain, loss) = gain_loss(&with, &without);
        eprintln!(
            "clearcoat {}: with {lw:.3}, without {lo:.3}; gain {gain:.3}, loss {loss:.3}",
            backend.as_str()
        );
        save_png(&format!("clearcoat-{}", backend.as_str()), &with);
        save_png(
            &format!("clearcoat-stripped-{}", backend.as_str()),
            &without,
        );
        // The coat adds its reflection and dims the base under it by its Fresnel: against a
        // bright sky the added light must dominate.
        assert!(
            gain > 0.1 && gain > 3.0 * loss && lw > lo,
            "{}: KHR_materials_clearcoat should mostly brighten: gain {gain:.3}, loss {loss:.3}",
            backend.as_str()
        );
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn layered_extensions_are_parsed_with_textures() {
    let mut b = Builder::default();
    let mut doc = quad_doc(&mut b, json!({"material": 0}));
    let uv = b.floats(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0], "VEC2");
    doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(uv);
    let img = b.view(&png(1, 1, &[10, 20, 30, 40]));
    doc["images"] = json!([{"bufferView": img, "mimeType": "image/png"}]);
    doc["textures"] = json!([{"source": 0}]);
    doc["extensionsUsed"] = json!([
        "KHR_materials_specular",
        "KHR_materials_clearcoat",
        "KHR_materials_sheen",
        "KHR_materials_volume"
    ]);
    doc["materials"] = json!([{"extensions": {
        "KHR_materials_specular": {"specularFactor": 0.5, "specularColorFactor": [1, 0.5, 0.25], "specularColorTexture": {"index": 0}},
        "KHR_materials_clearcoat": {"clearcoatFactor": 0.75, "clearcoatRoughnessFactor": 0.1, "clearcoatNormalTexture": {"index": 0, "scale": 0.5}},
        "KHR_materials_sheen": {"sheenColorFactor": [0.2, 0.3, 0.4], "sheenRoughnessFactor": 0.6, "sheenRoughnessTexture": {"index": 0}},
        "KHR_materials_volume": {"thicknessFactor": 0.5, "thicknessTexture": {"index": 0}},
    }}]);
    let s = load_doc(&b.document(doc));
    let m = &s.materials[0];
    let l = m.layers.as_ref().expect("layers");
    assert_eq!(l.specular, 0.5);
    assert_eq!(l.specular_color, glam::Vec3::new(1.0, 0.5, 0.25));
    assert_eq!(l.clearcoat, 0.75);
    assert_eq!(l.clearcoat_roughness, 0.1);
    assert_eq!(l.clearcoat_normal_scale, 0.5);
    assert_eq!(l.sheen_color, glam::Vec3::new(0.2, 0.3, 0.4));
    assert_eq!(l.sheen_roughness, 0.6);
    assert!(l.specular_color_texture.is_some() && l.clearcoat_normal_texture.is_some());
    assert!(l.sheen_roughness_texture.is_some() && m.thickness_texture.is_some());
    // The specular colour texture is sRGB, the others linear: two images.
    assert_eq!(s.images.len(), 2);
    let gpu = rqr::scene::gpu::gpu_material(m);
    assert_eq!(
        gpu.flags,
        rqr::scene::layout::MATERIAL_LAYERED | rqr::scene::layout::MATERIAL_EXT_TEXTURES
    );
    assert!(gpu.ext_textures[7].texture >= 0, "thickness texture bound");
    assert_eq!(gpu.ext_textures[0].texture, -1, "no specular texture");
    // A plain material keeps the plain shading path.
    let plain = rqr::scene::gpu::gpu_material(&rqr::scene::Material::default());
    assert_eq!(plain.flags, 0);
}

#[test]
fn fuzz_seeds_load() {
    // The fuzz target's seeds are valid files covering the features (layered materials,
    // TEXCOORD_2, meshopt, Draco): each must load. The animation cases of the bad-input corpus
    // are seeds too (`anim_*`, `skin_*`, `morph_*`, checked against the corpus by
    // tests/bad_inputs): those may be refused, with an error naming the file.
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds");
    let mut loaded = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let corpus_case = ["anim_", "skin_", "morph_"]
            .iter()
            .any(|p| name.starts_with(p));
        match scene::load(&path, &LoadOptions::default()) {
            Ok(s) => {
                assert!(s.triangle_count() > 0, "{}", path.display());
                loaded += 1;
            }
            Err(e) => assert!(
                corpus_case && e.to_string().contains(&name),
                "{}: {e}",
                path.display()
            ),
        }
    }
    assert!(loaded >= 4, "{loaded} seeds load");
}
