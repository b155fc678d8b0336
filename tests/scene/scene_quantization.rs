//! KHR_mesh_quantization: every attribute type the extension allows (normalized and not, byte
//! and short, signed and unsigned, for POSITION, NORMAL, TANGENT and TEXCOORD) decodes as the
//! glTF spec defines, and Avocado_Quantized renders like Avocado (its non-normalized
//! UNSIGNED_SHORT texture coordinates are scaled by KHR_texture_transform by ~2.4e-4).

use crate::support;

use crate::support::scene_files::{asset, bytes, png, Builder};
use glam::{Vec2, Vec3};
use rqr::accel::Backend;
use rqr::render::image::metrics;
use rqr::render::{RenderSettings, Renderer};
use rqr::scene::{self, LoadOptions, Scene};
use serde_json::{json, Value};

/// A glTF component type of KHR_mesh_quantization.
#[derive(Clone, Copy, Debug)]
enum Component {
    I8,
    U8,
    I16,
    U16,
}

impl Component {
    fn code(self) -> u32 {
        match self {
            Component::I8 => 5120,
            Component::U8 => 5121,
            Component::I16 => 5122,
            Component::U16 => 5123,
        }
    }

    fn size(self) -> usize {
        match self {
            Component::I8 | Component::U8 => 1,
            Component::I16 | Component::U16 => 2,
        }
    }

    fn encode(self, v: i32, out: &mut Vec<u8>) {
        match self {
            Component::I8 => out.push(v as i8 as u8),
            Component::U8 => out.push(v as u8),
            Component::I16 => out.extend_from_slice(&(v as i16).to_le_bytes()),
            Component::U16 => out.extend_from_slice(&(v as u16).to_le_bytes()),
        }
    }

    /// The spec's decoding: normalized signed values are `max(c / MAX, -1)`, unsigned ones
    /// `c / MAX`; others are the integer's value.
    fn decode(self, v: i32, normalized: bool) -> f32 {
        if !normalized {
            return v as f32;
        }
        match self {
            Component::I8 => (v as f32 / 127.0).max(-1.0),
            Component::U8 => v as f32 / 255.0,
            Component::I16 => (v as f32 / 32767.0).max(-1.0),
            Component::U16 => v as f32 / 65535.0,
        }
    }

    /// Extreme and ordinary values of this type.
    fn samples(self) -> [i32; 3] {
        match self {
            Component::I8 => [-128, 127, -37],
            Component::U8 => [0, 255, 91],
            Component::I16 => [-32768, 32767, -1234],
            Component::U16 => [0, 65535, 40000],
        }
    }
}

/// An integer accessor of `comps` components per element, each element padded to 4 bytes
/// with a byteStride as KHR_mesh_quantization requires for vertex attributes.
fn int_accessor(
    b: &mut Builder,
    ct: Component,
    normalized: bool,
    comps: usize,
    elements: &[Vec<i32>],
) -> usize {
    let elem = comps * ct.size();
    let stride = elem.div_ceil(4) * 4;
    let mut data = Vec::new();
    for e in elements {
        for &v in e {
            ct.encode(v, &mut data);
        }
        data.resize(data.len() + stride - elem, 0);
    }
    let view = b.view(&data);
    b.views[view]["byteStride"] = json!(stride);
    let ty = ["SCALAR", "VEC2", "VEC3", "VEC4"][comps - 1];
    let mut acc = json!({"bufferView": view, "componentType": ct.code(), "count": elements.len(), "type": ty});
    if normalized {
        acc["normalized"] = json!(true);
    }
    if comps == 3 {
        // POSITION needs min/max; other attributes ignore them.
        let mut min = [i32::MAX; 3];
        let mut max = [i32::MIN; 3];
        for e in elements {
            for k in 0..3 {
                min[k] = min[k].min(e[k]);
                max[k] = max[k].max(e[k]);
            }
        }
        let d = |v: i32| ct.decode(v, normalized);
        acc["min"] = json!(min.map(d));
        acc["max"] = json!(max.map(d));
    }
    b.accessor(acc)
}

/// One triangle with the given attributes; material 0 has a normal map (so tangents are kept).
fn triangle_doc(b: &mut Builder, attributes: Value) -> Value {
    let img = b.view(&png(1, 1, &[128, 128, 255, 255]));
    json!({
        "extensionsUsed": ["KHR_mesh_quantization"],
        "extensionsRequired": ["KHR_mesh_quantization"],
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "images": [{"bufferView": img, "mimeType": "image/png"}],
        "textures": [{"source": 0}],
        "materials": [{"normalTexture": {"index": 0}}],
        "meshes": [{"primitives": [{"attributes": attributes, "material": 0}]}],
    })
}

fn load_doc(doc: &Value) -> Scene {
    scene::load_slice(&bytes(doc), None, "quantized.gltf", &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
}

/// Three float positions of a triangle in the XY plane (for attributes other than POSITION).
fn float_positions(b: &mut Builder) -> usize {
    b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3")
}

const ALL: [Component; 4] = [Component::I8, Component::U8, Component::I16, Component::U16];

#[test]
fn quantized_positions_every_type() {
    for ct in ALL {
        for normalized in [false, true] {
            let [a, z, m] = ct.samples();
            // A non-degenerate triangle using each sample in each coordinate.
            let elements = vec![vec![a, a, m], vec![z, a, a], vec![a, z, z]];
            let mut b = Builder::default();
            let pos = int_accessor(&mut b, ct, normalized, 3, &elements);
            let doc = triangle_doc(&mut b, json!({"POSITION": pos}));
            let s = load_doc(&b.document(doc));
            let got = &s.geometries[0].positions;
            // Flat normals (none in the file) un-weld the vertices; compare triangle corners.
            let corners: Vec<Vec3> = s.geometries[0]
                .indices
                .iter()
                .map(|&i| got[i as usize])
                .collect();
            let want: Vec<Vec3> = elements
                .iter()
                .map(|e| Vec3::new(e[0] as f32, e[1] as f32, e[2] as f32))
                .map(|v| v.to_array().map(|c| ct.decode(c as i32, normalized)).into())
                .collect();
            assert_eq!(corners, want, "POSITION {ct:?} normalized={normalized}");
        }
    }
}

#[test]
fn quantized_normals_and_tangents_every_type() {
    // The extension allows normalized BYTE and SHORT for NORMAL and TANGENT.
    for ct in [Component::I8, Component::I16] {
        let max = if matches!(ct, Component::I8) {
            127
        } else {
            32767
        };
        let min = -max - 1;
        let normals = vec![vec![0, 0, max], vec![min, 0, 0], vec![max / 2, max / 2, 0]];
        let tangents = vec![
            vec![max, 0, 0, max],
            vec![0, max, 0, min],
            vec![0, min, max / 3, max],
        ];
        let mut b = Builder::default();
        let pos = float_positions(&mut b);
        let n = int_accessor(&mut b, ct, true, 3, &normals);
        let t = int_accessor(&mut b, ct, true, 4, &tangents);
        let doc = triangle_doc(&mut b, json!({"POSITION": pos, "NORMAL": n, "TANGENT": t}));
        let s = load_doc(&b.document(doc));
        let g = &s.geometries[0];
        for (i, e) in normals.iter().enumerate() {
            let want = Vec3::from_array([0, 1, 2].map(|k| ct.decode(e[k], true))).normalize();
            assert!(
                g.normals[i].abs_diff_eq(want, 1e-6),
                "NORMAL {ct:?} {i}: {} vs {want}",
                g.normals[i]
            );
        }
        assert_eq!(
            g.tangents.len(),
            3,
            "TANGENT {ct:?} kept for the normal map"
        );
        for (i, e) in tangents.iter().enumerate() {
            let xyz = Vec3::from_array([0, 1, 2].map(|k| ct.decode(e[k], true))).normalize();
            let w = if ct.decode(e[3], true) < 0.0 {
                -1.0
            } else {
                1.0
            };
            assert!(
                g.tangents[i].abs_diff_eq(xyz.extend(w), 1e-6),
                "TANGENT {ct:?} {i}: {} vs {}",
                g.tangents[i],
                xyz.extend(w)
            );
        }
    }
}

#[test]
fn quantized_texcoords_every_type_and_set() {
    for ct in ALL {
        for normalized in [false, true] {
            let [a, z, m] = ct.samples();
            let elements = vec![vec![a, z], vec![z, m], vec![m, a]];
            let mut b = Builder::default();
            let pos = float_positions(&mut b);
            let uv0 = int_accessor(&mut b, ct, normalized, 2, &elements);
            let uv1 = int_accessor(&mut b, ct, normalized, 2, &elements);
            let doc = triangle_doc(
                &mut b,
                json!({"POSITION": pos, "TEXCOORD_0": uv0, "TEXCOORD_1": uv1}),
            );
            let s = load_doc(&b.document(doc));
            let g = &s.geometries[0];
            let want: Vec<Vec2> = elements
                .iter()
                .map(|e| Vec2::new(ct.decode(e[0], normalized), ct.decode(e[1], normalized)))
                .collect();
            // Flat normals un-weld; the corners keep their file order for one triangle.
            let corners0: Vec<Vec2> = g.indices.iter().map(|&i| g.uv0[i as usize]).collect();
            let corners1: Vec<Vec2> = g.indices.iter().map(|&i| g.uv1[i as usize]).collect();
            assert_eq!(corners0, want, "TEXCOORD_0 {ct:?} normalized={normalized}");
            assert_eq!(corners1, want, "TEXCOORD_1 {ct:?} normalized={normalized}");
        }
    }
}

#[test]
fn quantized_texcoords_keep_their_transform() {
    // Avocado_Quantized: TEXCOORD_0 is non-normalized UNSIGNED_SHORT, scaled into [0, 1] by
    // KHR_texture_transform. The loader keeps the integers and the transform; their product
    // must match Avocado's float UVs (up to the 16-bit quantization step).
    let plain = scene::load(&asset("Avocado/Avocado.gltf"), &LoadOptions::default()).unwrap();
    let quant = scene::load(
        &asset("Avocado_Quantized/Avocado.gltf"),
        &LoadOptions::default(),
    )
    .unwrap();
    let tq = quant.materials[0].base_color_texture.unwrap();
    assert!(tq.transform.x_axis.x < 1e-3, "the UVs are scaled down");
    let gp = &plain.geometries[0];
    let gq = &quant.geometries[0];
    assert_eq!(gp.uv0.len(), gq.uv0.len());
    let max_uv = gq.uv0.iter().fold(0f32, |m, v| m.max(v.x).max(v.y));
    assert!(
        max_uv > 1000.0,
        "raw integers kept, not normalized: max {max_uv}"
    );
    // Vertex order differs (gltfpack reorders); compare the sets of transformed UVs.
    let transformed: Vec<Vec2> = gq
        .uv0
        .iter()
        .map(|uv| (tq.transform * uv.extend(1.0)).truncate())
        .collect();
    for uv in &gp.uv0 {
        let nearest = transformed
            .iter()
            .map(|t| t.distance(*uv))
            .fold(f32::INFINITY, f32::min);
        assert!(
            nearest < 5e-4,
            "uv {uv}: nearest quantized uv {nearest} away"
        );
    }
}

fn render(
    ctx: &rqr::vk::Context,
    scene: &Scene,
    camera: &rqr::scene::Camera,
    backend: Backend,
) -> Vec<u8> {
    let settings = RenderSettings {
        width: 128,
        height: 128,
        ..Default::default()
    };
    let renderer = Renderer::new(ctx, scene, backend).unwrap();
    renderer
        .render_rt(ctx, &settings, camera, false)
        .unwrap()
        .rgba8
}

#[test]
fn avocado_quantized_renders_like_avocado() {
    let ctx = support::gpu();
    let plain = scene::load(&asset("Avocado/Avocado.gltf"), &LoadOptions::default()).unwrap();
    let quant = scene::load(
        &asset("Avocado_Quantized/Avocado.gltf"),
        &LoadOptions::default(),
    )
    .unwrap();
    // Same view for both (the quantized bounds differ by the quantization step).
    let camera = scene::auto_camera(&plain.bounds, 1.0);
    let mut backends = vec![Backend::Bvh];
    if ctx.features().ray_query {
        backends.insert(0, Backend::Hw);
    }
    for backend in backends {
        let a = render(&ctx, &plain, &camera, backend);
        let b = render(&ctx, &quant, &camera, backend);
        let d = metrics::compare(128, 128, &a, &b);
        eprintln!(
            "Avocado vs Avocado_Quantized, {}: FLIP mean {:.5}",
            backend.as_str(),
            d.flip_mean
        );
        // Before the fix the texture LOD came from the untransformed integer UVs: a
        // flat-coloured avocado, FLIP mean 0.179 here (lavapipe, both backends); 0.004 after.
        assert!(
            d.flip_mean < 0.01,
            "{}: FLIP mean {} between Avocado and Avocado_Quantized",
            backend.as_str(),
            d.flip_mean
        );
    }
    support::assert_validation_clean(&ctx);
}
