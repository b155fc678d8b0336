//! Writes `assets/default_scene.glb`, the built-in scene `rqr` renders without a file:
//!
//! ```sh
//! cargo run --example make_default_scene            # writes assets/default_scene.glb
//! cargo run --example make_default_scene -- out.glb  # or another path
//! ```
//!
//! A Cornell-style room 4 m wide, deep and high (x, z in [-2, 2], y in [0, 4], open towards
//! +z): checker-textured floor, white ceiling and back wall, red left and green right
//! walls. Inside: a diffuse box (shadows), a mirror sphere (metallic 1, roughness 0:
//! reflection), a glass sphere and a glass block (KHR_materials_transmission 1,
//! KHR_materials_ior 1.5, KHR_materials_volume: refraction; the block's side faces show
//! total internal reflection when seen through its front face). Lit by a 25 cd point light
//! 0.8 m under the ceiling and a 45 cd spot light from the front right (KHR_lights_punctual), seen
//! by a 40° perspective camera in front of the opening.

use glam::{Quat, Vec3};
use serde_json::{json, Value};

/// Binary buffer with 4-byte aligned buffer views.
#[derive(Default)]
struct Bin {
    data: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while self.data.len() % 4 != 0 {
            self.data.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": self.data.len(), "byteLength": bytes.len()});
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.views.push(v);
        self.data.extend_from_slice(bytes);
        self.views.len() - 1
    }

    fn vec3(&mut self, data: &[Vec3], bounds: bool) -> usize {
        let bytes: Vec<u8> = data
            .iter()
            .flat_map(|v| v.to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let view = self.view(&bytes, Some(34962));
        let mut acc =
            json!({"bufferView": view, "componentType": 5126, "count": data.len(), "type": "VEC3"});
        if bounds {
            let min = data.iter().fold(Vec3::INFINITY, |a, &b| a.min(b));
            let max = data.iter().fold(Vec3::NEG_INFINITY, |a, &b| a.max(b));
            acc["min"] = json!(min.to_array());
            acc["max"] = json!(max.to_array());
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    fn vec2(&mut self, data: &[[f32; 2]]) -> usize {
        let bytes: Vec<u8> = data
            .iter()
            .flatten()
            .flat_map(|f| f.to_le_bytes())
            .collect();
        let view = self.view(&bytes, Some(34962));
        self.accessors.push(
            json!({"bufferView": view, "componentType": 5126, "count": data.len(), "type": "VEC2"}),
        );
        self.accessors.len() - 1
    }

    fn indices(&mut self, data: &[u16]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(34963));
        self.accessors.push(json!({"bufferView": view, "componentType": 5123, "count": data.len(), "type": "SCALAR"}));
        self.accessors.len() - 1
    }
}

/// A mesh's vertex and index data.
struct MeshData {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    uvs: Vec<[f32; 2]>,
    indices: Vec<u16>,
}

/// A quad with corners `a, b, c, d` (counter-clockwise seen from the side it faces).
fn quad(a: Vec3, b: Vec3, c: Vec3, d: Vec3, uv_scale: f32) -> MeshData {
    let n = (b - a).cross(c - a).normalize();
    MeshData {
        positions: vec![a, b, c, d],
        normals: vec![n; 4],
        uvs: vec![
            [0.0, uv_scale],
            [uv_scale, uv_scale],
            [uv_scale, 0.0],
            [0.0, 0.0],
        ],
        indices: vec![0, 1, 2, 0, 2, 3],
    }
}

/// The cube [-0.5, 0.5]³ with flat per-face normals.
fn cube() -> MeshData {
    let mut m = MeshData {
        positions: vec![],
        normals: vec![],
        uvs: vec![],
        indices: vec![],
    };
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let mut n = Vec3::ZERO;
            n[axis] = sign;
            // u × v = n, so the corners below run counter-clockwise seen from outside.
            let u = n.any_orthonormal_vector();
            let v = n.cross(u);
            let base = m.positions.len() as u16;
            for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                m.positions.push((n + u * su + v * sv) * 0.5);
                m.normals.push(n);
            }
            m.indices
                .extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
        }
    }
    m
}

/// A unit UV sphere: `segments` around, `rings` from pole to pole, one triangle per
/// segment at each pole (no degenerate triangles).
fn sphere(segments: u16, rings: u16) -> MeshData {
    let mut m = MeshData {
        positions: vec![],
        normals: vec![],
        uvs: vec![],
        indices: vec![],
    };
    let top = 0u16;
    m.positions.push(Vec3::Y);
    for r in 1..rings {
        let theta = std::f32::consts::PI * f32::from(r) / f32::from(rings);
        for s in 0..segments {
            let phi = std::f32::consts::TAU * f32::from(s) / f32::from(segments);
            m.positions.push(Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                -theta.sin() * phi.sin(),
            ));
        }
    }
    let bottom = m.positions.len() as u16;
    m.positions.push(Vec3::NEG_Y);
    m.normals = m.positions.iter().map(|p| p.normalize()).collect();
    let ring = |r: u16, s: u16| 1 + (r - 1) * segments + s % segments;
    for s in 0..segments {
        m.indices
            .extend_from_slice(&[top, ring(1, s), ring(1, s + 1)]);
        for r in 1..rings - 1 {
            let (a, b, c, d) = (
                ring(r, s),
                ring(r + 1, s),
                ring(r + 1, s + 1),
                ring(r, s + 1),
            );
            m.indices.extend_from_slice(&[a, b, c, a, c, d]);
        }
        m.indices
            .extend_from_slice(&[bottom, ring(rings - 1, s + 1), ring(rings - 1, s)]);
    }
    m
}

/// Adds a primitive's accessors; returns the glTF primitive JSON.
fn primitive(bin: &mut Bin, m: &MeshData, material: usize) -> Value {
    let mut attributes = json!({
        "POSITION": bin.vec3(&m.positions, true),
        "NORMAL": bin.vec3(&m.normals, false),
    });
    if !m.uvs.is_empty() {
        attributes["TEXCOORD_0"] = json!(bin.vec2(&m.uvs));
    }
    json!({"attributes": attributes, "indices": bin.indices(&m.indices), "material": material})
}

/// A 256² PNG checkerboard of 8 x 8 light/dark grey squares (sRGB).
fn checker_png() -> Vec<u8> {
    let img = image::RgbaImage::from_fn(256, 256, |x, y| {
        if (x / 32 + y / 32) % 2 == 0 {
            image::Rgba([210, 205, 195, 255])
        } else {
            image::Rgba([70, 70, 75, 255])
        }
    });
    let mut out = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)
        .expect("PNG encoding to memory");
    out
}

fn glb(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let mut j = json.to_vec();
    while j.len() % 4 != 0 {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while b.len() % 4 != 0 {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    out.extend_from_slice(&(b.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&b);
    out
}

fn trs(t: Vec3, r: Quat, s: Vec3) -> Value {
    json!({"translation": t.to_array(), "rotation": r.to_array(), "scale": s.to_array()})
}

/// A node at `from` whose -Z points at `at` (lights and cameras look down -Z).
fn aimed(from: Vec3, at: Vec3) -> Value {
    let r = Quat::from_rotation_arc(Vec3::NEG_Z, (at - from).normalize());
    json!({"translation": from.to_array(), "rotation": r.to_array()})
}

fn main() {
    let out = std::env::args().nth(1).unwrap_or_else(|| {
        concat!(env!("CARGO_MANIFEST_DIR"), "/assets/default_scene.glb").to_string()
    });
    let mut bin = Bin::default();
    let (x0, x1, y0, y1, z0, z1) = (-2.0, 2.0, 0.0, 4.0, -2.0, 2.0);
    let v = Vec3::new;

    // Materials (indices used below).
    let materials = json!([
        {"name": "floor", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0},
            "metallicFactor": 0.0, "roughnessFactor": 0.9}},
        {"name": "white wall", "pbrMetallicRoughness": {"baseColorFactor": [0.73, 0.73, 0.73, 1.0],
            "metallicFactor": 0.0, "roughnessFactor": 1.0}},
        {"name": "red wall", "pbrMetallicRoughness": {"baseColorFactor": [0.63, 0.065, 0.05, 1.0],
            "metallicFactor": 0.0, "roughnessFactor": 1.0}},
        {"name": "green wall", "pbrMetallicRoughness": {"baseColorFactor": [0.14, 0.45, 0.091, 1.0],
            "metallicFactor": 0.0, "roughnessFactor": 1.0}},
        {"name": "diffuse box", "pbrMetallicRoughness": {"baseColorFactor": [0.3, 0.45, 0.75, 1.0],
            "metallicFactor": 0.0, "roughnessFactor": 1.0}},
        {"name": "mirror", "pbrMetallicRoughness": {"baseColorFactor": [0.95, 0.95, 0.95, 1.0],
            "metallicFactor": 1.0, "roughnessFactor": 0.0}},
        {"name": "glass sphere", "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0],
            "metallicFactor": 0.0, "roughnessFactor": 0.0},
         "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
            "KHR_materials_ior": {"ior": 1.5},
            "KHR_materials_volume": {"thicknessFactor": 1.0}}},
        {"name": "glass block", "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0],
            "metallicFactor": 0.0, "roughnessFactor": 0.0},
         "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
            "KHR_materials_ior": {"ior": 1.5},
            "KHR_materials_volume": {"thicknessFactor": 0.6}}},
    ]);

    // The room: one mesh, one primitive per surface, all facing inwards. The floor
    // repeats the checker texture twice in each direction.
    let room = vec![
        primitive(
            &mut bin,
            &quad(
                v(x0, y0, z1),
                v(x1, y0, z1),
                v(x1, y0, z0),
                v(x0, y0, z0),
                2.0,
            ),
            0,
        ),
        primitive(
            &mut bin,
            &MeshData {
                uvs: vec![],
                ..quad(
                    v(x0, y1, z0),
                    v(x1, y1, z0),
                    v(x1, y1, z1),
                    v(x0, y1, z1),
                    1.0,
                )
            },
            1,
        ),
        primitive(
            &mut bin,
            &MeshData {
                uvs: vec![],
                ..quad(
                    v(x0, y0, z0),
                    v(x1, y0, z0),
                    v(x1, y1, z0),
                    v(x0, y1, z0),
                    1.0,
                )
            },
            1,
        ),
        primitive(
            &mut bin,
            &MeshData {
                uvs: vec![],
                ..quad(
                    v(x0, y0, z1),
                    v(x0, y0, z0),
                    v(x0, y1, z0),
                    v(x0, y1, z1),
                    1.0,
                )
            },
            2,
        ),
        primitive(
            &mut bin,
            &MeshData {
                uvs: vec![],
                ..quad(
                    v(x1, y0, z0),
                    v(x1, y0, z1),
                    v(x1, y1, z1),
                    v(x1, y1, z0),
                    1.0,
                )
            },
            3,
        ),
    ];
    let cube_prim = primitive(&mut bin, &cube(), 4);
    let sphere_prim = primitive(&mut bin, &sphere(48, 24), 5);
    let with_material = |p: &Value, m: usize| {
        let mut p = p.clone();
        p["material"] = json!(m);
        p
    };
    let meshes = json!([
        {"name": "room", "primitives": room},
        {"name": "box", "primitives": [cube_prim]},
        {"name": "mirror sphere", "primitives": [sphere_prim]},
        {"name": "glass sphere", "primitives": [with_material(&sphere_prim, 6)]},
        {"name": "glass block", "primitives": [with_material(&cube_prim, 7)]},
    ]);

    let png_view = bin.view(&checker_png(), None);
    let mut nodes = vec![
        json!({"name": "room", "mesh": 0}),
        {
            let mut n = trs(
                v(-0.85, 0.8, -0.8),
                Quat::from_rotation_y(20f32.to_radians()),
                v(1.0, 1.6, 1.0),
            );
            n["name"] = json!("diffuse box");
            n["mesh"] = json!(1);
            n
        },
        {
            let mut n = trs(v(1.05, 0.6, -0.75), Quat::IDENTITY, Vec3::splat(0.6));
            n["name"] = json!("mirror sphere");
            n["mesh"] = json!(2);
            n
        },
        {
            let mut n = trs(v(0.05, 0.5, 0.75), Quat::IDENTITY, Vec3::splat(0.5));
            n["name"] = json!("glass sphere");
            n["mesh"] = json!(3);
            n
        },
        {
            // 2 mm above the floor: a bottom face coplanar with the floor would leave rays
            // inside the glass to pick floor or glass at random (speckles).
            let mut n = trs(
                v(-0.85, 0.302, 0.9),
                Quat::from_rotation_y(35f32.to_radians()),
                Vec3::splat(0.6),
            );
            n["name"] = json!("glass block");
            n["mesh"] = json!(4);
            n
        },
    ];
    let mut camera = aimed(v(0.0, 2.0, 6.8), v(0.0, 1.6, 0.0));
    camera["name"] = json!("camera");
    camera["camera"] = json!(0);
    nodes.push(camera);
    let mut lamp = json!({"name": "ceiling lamp", "translation": [0.0, 3.2, 0.0]});
    lamp["extensions"] = json!({"KHR_lights_punctual": {"light": 0}});
    nodes.push(lamp);
    let mut spot = aimed(v(1.6, 3.6, 1.8), v(0.2, 0.0, 0.2));
    spot["name"] = json!("spot");
    spot["extensions"] = json!({"KHR_lights_punctual": {"light": 1}});
    nodes.push(spot);

    let doc = json!({
        "asset": {"version": "2.0", "generator": "rqr examples/make_default_scene.rs"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume"],
        "scene": 0,
        "scenes": [{"name": "rqr default scene", "nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "textures": [{"sampler": 0, "source": 0}],
        "samplers": [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}],
        "images": [{"name": "checker", "bufferView": png_view, "mimeType": "image/png"}],
        "cameras": [{"type": "perspective", "name": "front",
            "perspective": {"yfov": 40f32.to_radians(), "znear": 0.05, "zfar": 100.0}}],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "ceiling lamp", "type": "point", "color": [1.0, 0.95, 0.85], "intensity": 25.0},
            {"name": "spot", "type": "spot", "color": [1.0, 1.0, 1.0], "intensity": 45.0,
             "spot": {"innerConeAngle": 20f32.to_radians(), "outerConeAngle": 30f32.to_radians()}},
        ]}},
        "buffers": [{"byteLength": bin.data.len()}],
        "bufferViews": bin.views,
        "accessors": bin.accessors,
    });
    let json = serde_json::to_vec(&doc).expect("serialising JSON");
    let bytes = glb(&json, &bin.data);
    std::fs::write(&out, &bytes).unwrap_or_else(|e| panic!("writing {out}: {e}"));
    println!("wrote {out} ({} bytes)", bytes.len());
}
