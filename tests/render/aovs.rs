//! The primary-hit AOVs an external denoiser and a dataset need: albedo (base colour after
//! texture, vertex colour and factor), shading normal, depth and integer ids, the same in the
//! ray-traced path and in the hybrid path with either G-buffer layout, on every backend.

use crate::support;
use crate::support::scene_files;

use glam::{Vec2, Vec3};
use rqr::accel::Backend;
use rqr::interface::{Aov, AOV_NO_ID};
use rqr::render::passes::draw_list;
use rqr::render::passes::gbuffer::GbufferLayout;
use rqr::render::{RenderOutput, RenderSettings, Renderer, SamplerKind};
use rqr::scene::procedural::{camera_to_world, cornell, look_at};
use rqr::scene::{Camera, LoadOptions, Scene};
use scene_files::Builder;
use serde_json::json;

/// Every backend the device runs (lavapipe: the compute BVH only).
fn backends(ctx: &rqr::vk::Context) -> Vec<Backend> {
    let mut b = vec![Backend::Bvh];
    if ctx.features().ray_query {
        b.insert(0, Backend::Hw);
    }
    b
}

fn settings(size: u32) -> RenderSettings {
    RenderSettings {
        width: size,
        height: size,
        spp: 1,
        sampler: SamplerKind::Center,
        ..Default::default()
    }
}

/// The ray-traced render and the hybrid ones (visibility buffer, full G-buffer) of `scene`
/// from `camera`, with AOVs, on `backend`.
fn render_all_paths(
    ctx: &rqr::vk::Context,
    scene: &Scene,
    camera: &Camera,
    backend: Backend,
    size: u32,
) -> Vec<(String, RenderOutput)> {
    let renderer = Renderer::new(ctx, scene, backend).unwrap();
    let mut outs = vec![(
        format!("rt/{backend:?}"),
        renderer
            .render_rt(ctx, &settings(size), camera, true)
            .unwrap(),
    )];
    for layout in [GbufferLayout::Visibility, GbufferLayout::Full] {
        let s = RenderSettings {
            gbuffer: layout,
            ..settings(size)
        };
        let out = renderer
            .render_hybrid(ctx, &draw_list::draws(scene), &s, camera, true)
            .unwrap();
        outs.push((format!("hybrid {layout:?}/{backend:?}"), out));
    }
    outs
}

fn srgb_to_linear(c: u8) -> f32 {
    let c = f32::from(c) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The 2x2 texture of [`textured_quad`], row 0 at the top (v = 0).
const TEXELS: [[u8; 4]; 4] = [
    [200, 40, 10, 255],
    [20, 180, 60, 255],
    [90, 90, 230, 255],
    [250, 250, 120, 255],
];
const FACTOR: [f32; 4] = [0.9, 0.5, 1.0, 1.0];
const VERTEX_COLOUR: [f32; 4] = [1.0, 0.8, 0.6, 1.0];

/// A glTF unit quad in the XY plane at z = 0 (uv = (x, 1 - y)) with a 2x2 base-colour texture
/// sampled NEAREST, a base-colour factor and a constant vertex colour, written to a temporary
/// file and loaded.
fn textured_quad() -> Scene {
    let mut b = Builder::default();
    let pos = b.floats(
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0],
        "VEC3",
    );
    let uv = b.floats(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0], "VEC2");
    let colour: Vec<f32> = (0..4).flat_map(|_| VERTEX_COLOUR).collect();
    let col = b.floats(&colour, "VEC4");
    let idx = b.indices_u16(&[0, 1, 2, 0, 2, 3]);
    let rgba: Vec<u8> = TEXELS.iter().flatten().copied().collect();
    let png = scene_files::png(2, 2, &rgba);
    let doc = b.document(json!({
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{
            "attributes": {"POSITION": pos, "TEXCOORD_0": uv, "COLOR_0": col},
            "indices": idx,
            "material": 0,
        }]}],
        "materials": [{"pbrMetallicRoughness": {
            "baseColorFactor": FACTOR,
            "baseColorTexture": {"index": 0},
            "metallicFactor": 0.0,
            "roughnessFactor": 0.8,
        }}],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"magFilter": 9728, "minFilter": 9728}],
        "images": [{"uri": format!("data:image/png;base64,{}", scene_files::base64(&png))}],
    }));
    let dir = std::env::temp_dir().join(format!("rqr-aovs-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("textured_quad.gltf");
    std::fs::write(&path, scene_files::bytes(&doc)).unwrap();
    rqr::scene::load(&path, &LoadOptions::default()).unwrap()
}

/// Looking straight at the quad's centre from 2 units in front of it (+Z).
fn quad_camera() -> Camera {
    let mut camera = look_at(Vec3::new(0.5, 0.5, 2.0), Vec3::new(0.5, 0.5, 0.0), 35.0);
    camera.camera_to_world =
        camera_to_world(Vec3::new(0.5, 0.5, 2.0), Vec3::new(0.5, 0.5, 0.0), Vec3::Y);
    camera
}

#[test]
fn aov_record_is_80_bytes_with_integer_ids_last() {
    assert_eq!(std::mem::size_of::<Aov>(), 80);
    assert_eq!(std::mem::offset_of!(Aov, albedo), 48);
    assert_eq!(std::mem::offset_of!(Aov, instance), 72);
    assert_eq!(std::mem::offset_of!(Aov, primitive), 76);
    // The ids are u32 (a compile-time check): values above 2^24 survive exactly, which a
    // float would not (2^24 + 1 rounds to 2^24).
    let a = Aov {
        instance: (1 << 24) + 1,
        primitive: u32::MAX - 1,
        ..Default::default()
    };
    assert_eq!(a.instance(), (1 << 24) + 1);
    assert_eq!(a.primitive() as u32, u32::MAX - 1);
    assert!(a.hit());
    let miss = Aov {
        instance: AOV_NO_ID,
        primitive: AOV_NO_ID,
        ..Default::default()
    };
    assert_eq!((miss.instance(), miss.primitive()), (-1, -1));
    assert!(!miss.hit());
}

/// The albedo of a textured glTF surface is the texel's colour (sRGB decoded) times the
/// vertex colour and the base-colour factor, in every path and on every backend; misses
/// report zero albedo and normal and the no-id marker.
#[test]
fn albedo_of_a_textured_surface_is_texel_times_vertex_colour_times_factor() {
    let ctx = support::gpu();
    let scene = textured_quad();
    let camera = quad_camera();
    let size = 48;
    for backend in backends(&ctx) {
        for (name, out) in render_all_paths(&ctx, &scene, &camera, backend, size) {
            let (mut checked, mut misses) = (0, 0);
            for a in &out.aov {
                if !a.hit() {
                    misses += 1;
                    assert_eq!(a.instance, AOV_NO_ID, "{name}");
                    assert_eq!(a.primitive, AOV_NO_ID, "{name}");
                    assert_eq!(a.albedo, [0.0; 4], "{name}");
                    assert_eq!(a.shading_normal(), Vec3::ZERO, "{name}");
                    assert_eq!(a.depth(), 0.0, "{name}");
                    continue;
                }
                assert_eq!(a.instance(), 0, "{name}");
                assert!(a.primitive() == 0 || a.primitive() == 1, "{name}");
                let p = a.world_position();
                let uv = Vec2::new(p.x, 1.0 - p.y);
                // Away from the texel seams and the quad's edges.
                let away = |t: f32| (t - 0.5).abs() > 0.06 && t > 0.04 && t < 0.96;
                if !(away(uv.x) && away(uv.y)) {
                    continue;
                }
                let texel = TEXELS[(uv.y >= 0.5) as usize * 2 + (uv.x >= 0.5) as usize];
                let channel = |k: usize| srgb_to_linear(texel[k]) * FACTOR[k] * VERTEX_COLOUR[k];
                let expected = Vec3::new(channel(0), channel(1), channel(2));
                let got = a.albedo_rgb();
                // The full G-buffer stores the base colour as half floats.
                assert!(
                    (got - expected).abs().max_element() < 2e-3,
                    "{name} at uv {uv}: albedo {got}, expected {expected}"
                );
                assert!(
                    (a.albedo[3] - 1.0).abs() < 1e-3,
                    "{name}: alpha {}",
                    a.albedo[3]
                );
                // The quad faces the camera (+Z) and has no normal map.
                assert!(
                    (a.shading_normal() - Vec3::Z).length() < 1e-3,
                    "{name}: shading normal {}",
                    a.shading_normal()
                );
                checked += 1;
            }
            assert!(checked > 400, "{name}: only {checked} texel pixels");
            assert!(misses > 100, "{name}: only {misses} misses");
        }
    }
    support::assert_validation_clean(&ctx);
}

/// On the Cornell room (a diffuse box, a mirror and a glass sphere, coloured walls): every hit
/// pixel's albedo is its material's base colour, looked up through the pixel's integer
/// instance id; the instance, primitive and barycentrics rebuild the pixel's world position;
/// and albedo, shading normal and depth agree between the ray-traced and both hybrid paths
/// wherever the ids agree.
#[test]
fn albedo_normal_depth_and_ids_agree_across_paths_on_the_cornell_room() {
    let ctx = support::gpu();
    let scene = cornell();
    let camera = scene.cameras[0];
    let size = 64;
    for backend in backends(&ctx) {
        let outs = render_all_paths(&ctx, &scene, &camera, backend, size);
        for (name, out) in &outs {
            let mut hits = 0;
            for a in &out.aov {
                if !a.hit() {
                    continue;
                }
                hits += 1;
                let inst = scene.instances[a.instance() as usize];
                let g = &scene.geometries[inst.geometry as usize];
                let base = scene.materials[g.material as usize].base_color.truncate();
                assert!(
                    (a.albedo_rgb() - base).abs().max_element() < 1e-3,
                    "{name}: instance {} albedo {} vs its material's {base}",
                    a.instance(),
                    a.albedo_rgb()
                );
                let prim = a.primitive() as usize;
                assert!(prim * 3 < g.indices.len(), "{name}: primitive {prim}");
                let b = Vec2::from(a.bary);
                let w = [1.0 - b.x - b.y, b.x, b.y];
                let local: Vec3 = (0..3)
                    .map(|k| w[k] * g.positions[g.indices[3 * prim + k] as usize])
                    .sum();
                let rebuilt = inst.transform.transform_point3(local);
                assert!(
                    (rebuilt - a.world_position()).length() < 2e-3,
                    "{name}: instance {} primitive {prim} rebuilds {rebuilt}, the AOV says {}",
                    a.instance(),
                    a.world_position()
                );
                let n = a.shading_normal();
                assert!((n.length() - 1.0).abs() < 1e-3, "{name}: |normal| {n}");
                let eye = camera.camera_to_world.w_axis.truncate();
                let to_eye = (eye - a.world_position()).normalize();
                assert!(n.dot(to_eye) > -1e-3, "{name}: normal {n} faces away");
                let distance = (a.world_position() - eye).length();
                assert!(
                    (a.depth() - distance).abs() < 1e-3 * distance,
                    "{name}: depth {} vs distance {distance}",
                    a.depth()
                );
            }
            assert!(
                hits > (size * size) as usize / 2,
                "{name}: only {hits} hits"
            );
        }
        let (rt_name, rt) = &outs[0];
        for (name, hy) in &outs[1..] {
            let (mut same, mut worst_normal, mut worst_depth, mut worst_albedo) =
                (0usize, 0f32, 0f32, 0f32);
            for (a, b) in rt.aov.iter().zip(&hy.aov) {
                if (a.instance, a.primitive) != (b.instance, b.primitive) {
                    continue;
                }
                same += 1;
                worst_normal = worst_normal.max((a.shading_normal() - b.shading_normal()).length());
                worst_depth = worst_depth.max((a.depth() - b.depth()).abs() / a.depth().max(1e-3));
                worst_albedo =
                    worst_albedo.max((a.albedo_rgb() - b.albedo_rgb()).abs().max_element());
            }
            assert!(
                same as f64 >= 0.99 * rt.aov.len() as f64,
                "{rt_name} vs {name}: ids agree on {same} of {} pixels",
                rt.aov.len()
            );
            assert!(
                worst_normal < 2e-3,
                "{rt_name} vs {name}: normal differs by {worst_normal}"
            );
            assert!(
                worst_depth < 1e-4,
                "{rt_name} vs {name}: depth differs by {worst_depth} (relative)"
            );
            assert!(
                worst_albedo < 1e-3,
                "{rt_name} vs {name}: albedo differs by {worst_albedo}"
            );
        }
    }
    support::assert_validation_clean(&ctx);
}
