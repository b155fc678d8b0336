//! Small scenes built in code: test fixtures that do not depend on the glTF loader
//! (energy tests, backend cross-checks, benchmarks).

use glam::{Mat4, Vec2, Vec3, Vec4};

use super::types::*;

/// An axis-aligned unit quad in the XZ plane (y = 0, normal +Y), centred at the origin.
pub fn quad(material: u32) -> Geometry {
    let positions = vec![
        Vec3::new(-0.5, 0.0, -0.5),
        Vec3::new(-0.5, 0.0, 0.5),
        Vec3::new(0.5, 0.0, 0.5),
        Vec3::new(0.5, 0.0, -0.5),
    ];
    Geometry {
        normals: vec![Vec3::Y; 4],
        uv0: vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(0.0, 1.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(1.0, 0.0),
        ],
        positions,
        indices: vec![0, 1, 2, 0, 2, 3],
        material,
        ..Default::default()
    }
}

/// A unit cube centred at the origin with per-face normals (24 vertices, 12 triangles).
pub fn cube(material: u32) -> Geometry {
    let mut g = Geometry {
        material,
        ..Default::default()
    };
    let faces = [
        (Vec3::X, Vec3::Y),
        (-Vec3::X, Vec3::Y),
        (Vec3::Y, Vec3::Z),
        (-Vec3::Y, Vec3::Z),
        (Vec3::Z, Vec3::Y),
        (-Vec3::Z, Vec3::Y),
    ];
    for (n, up) in faces {
        let right = up.cross(n);
        let c = n * 0.5;
        let base = g.positions.len() as u32;
        for (u, v) in [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)] {
            g.positions.push(c + right * u + up * v);
            g.normals.push(n);
            g.uv0.push(Vec2::new(u + 0.5, 0.5 - v));
        }
        g.indices
            .extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
    }
    g
}

/// A UV sphere of radius 1 (smooth normals), `segments` around and `rings` from pole to pole.
pub fn sphere(material: u32, segments: u32, rings: u32) -> Geometry {
    let mut g = Geometry {
        material,
        ..Default::default()
    };
    for r in 0..=rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..=segments {
            let phi = std::f32::consts::TAU * s as f32 / segments as f32;
            let p = Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                -theta.sin() * phi.sin(),
            );
            g.positions.push(p);
            g.normals.push(p);
            g.uv0.push(Vec2::new(
                s as f32 / segments as f32,
                r as f32 / rings as f32,
            ));
        }
    }
    let row = segments + 1;
    for r in 0..rings {
        for s in 0..segments {
            let a = r * row + s;
            let b = a + row;
            if r != 0 {
                g.indices.extend_from_slice(&[a, b, a + 1]);
            }
            if r != rings - 1 {
                g.indices.extend_from_slice(&[a + 1, b, b + 1]);
            }
        }
    }
    g
}

/// Assembles a scene: computes bounds, keeps the given lights and cameras.
pub fn assemble(
    geometries: Vec<Geometry>,
    instances: Vec<Instance>,
    materials: Vec<Material>,
    lights: Vec<Light>,
    cameras: Vec<Camera>,
) -> Scene {
    let mut bounds = Aabb::EMPTY;
    for inst in &instances {
        for p in &geometries[inst.geometry as usize].positions {
            bounds.grow(inst.transform.transform_point3(*p));
        }
    }
    Scene {
        source: "procedural".into(),
        mesh_count: geometries.len(),
        primitive_count: geometries.len(),
        geometries,
        instances,
        materials,
        lights,
        cameras,
        bounds,
        ..Default::default()
    }
}

/// A scene of one geometry drawn once, untransformed, with the default material: a fixed
/// workload to time (the autotune's BVH builds, `rqr bench`'s warm-up).
pub fn single_mesh(geometry: Geometry) -> Scene {
    assemble(
        vec![geometry],
        vec![Instance {
            geometry: 0,
            transform: Mat4::IDENTITY,
            node: 0,
        }],
        vec![Material::default()],
        Vec::new(),
        Vec::new(),
    )
}

/// Camera-to-world of a camera at `from` looking at `at` (looks down its -Z, +Y up).
pub fn camera_to_world(from: Vec3, at: Vec3, up: Vec3) -> Mat4 {
    let forward = (at - from).normalize();
    let right = forward.cross(up).try_normalize().unwrap_or(Vec3::X);
    let true_up = right.cross(forward);
    Mat4::from_cols(
        right.extend(0.0),
        true_up.extend(0.0),
        (-forward).extend(0.0),
        from.extend(1.0),
    )
}

/// A perspective camera at `from` looking at `at` (+Y up).
pub fn look_at(from: Vec3, at: Vec3, yfov_degrees: f32) -> Camera {
    Camera {
        camera_to_world: camera_to_world(from, at, Vec3::Y),
        projection: Projection::Perspective {
            yfov: yfov_degrees.to_radians(),
            aspect: None,
            znear: 0.01,
            zfar: None,
        },
    }
}

fn material(name: &str, base: Vec3, metallic: f32, roughness: f32) -> Material {
    Material {
        name: name.into(),
        base_color: base.extend(1.0),
        metallic,
        roughness,
        ..Default::default()
    }
}

/// A Cornell-style room (4 m) with a diffuse box, a mirror sphere, a glass sphere (ior 1.5),
/// a point light and a spot light. Test fixture for every path; independent of glTF.
pub fn cornell() -> Scene {
    let materials = vec![
        material("white", Vec3::splat(0.75), 0.0, 0.9),
        material("red", Vec3::new(0.7, 0.1, 0.1), 0.0, 0.9),
        material("green", Vec3::new(0.1, 0.6, 0.15), 0.0, 0.9),
        material("mirror", Vec3::splat(0.95), 1.0, 0.0),
        Material {
            transmission: 1.0,
            ior: 1.5,
            ..material("glass", Vec3::ONE, 0.0, 0.0)
        },
        material("box", Vec3::new(0.8, 0.65, 0.3), 0.0, 0.6),
    ];
    let geometries = vec![
        quad(0),
        quad(1),
        quad(2),
        cube(5),
        sphere(3, 48, 24),
        sphere(4, 48, 24),
    ];
    let s = 4.0;
    let wall = |g: u32, t: Mat4| Instance {
        geometry: g,
        transform: t,
        node: 0,
    };
    let scale = Mat4::from_scale(Vec3::splat(s));
    let instances = vec![
        wall(0, scale), // floor
        wall(
            0,
            Mat4::from_translation(Vec3::Y * s)
                * Mat4::from_rotation_x(std::f32::consts::PI)
                * scale,
        ), // ceiling
        wall(
            0,
            Mat4::from_translation(Vec3::new(0.0, s * 0.5, -s * 0.5))
                * Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2)
                * scale,
        ), // back
        wall(
            1,
            Mat4::from_translation(Vec3::new(-s * 0.5, s * 0.5, 0.0))
                * Mat4::from_rotation_z(-std::f32::consts::FRAC_PI_2)
                * scale,
        ), // left red
        wall(
            2,
            Mat4::from_translation(Vec3::new(s * 0.5, s * 0.5, 0.0))
                * Mat4::from_rotation_z(std::f32::consts::FRAC_PI_2)
                * scale,
        ), // right green
        wall(
            3,
            Mat4::from_translation(Vec3::new(-0.8, 0.6, -0.9))
                * Mat4::from_rotation_y(0.4)
                * Mat4::from_scale(Vec3::new(1.0, 1.2, 1.0)),
        ),
        wall(
            4,
            Mat4::from_translation(Vec3::new(0.9, 0.6, -0.7)) * Mat4::from_scale(Vec3::splat(0.6)),
        ),
        wall(
            5,
            Mat4::from_translation(Vec3::new(0.2, 0.5, 0.6)) * Mat4::from_scale(Vec3::splat(0.5)),
        ),
    ];
    let lights = vec![
        Light {
            kind: LightKind::Point,
            color: Vec3::ONE,
            intensity: 12.0,
            range: f32::INFINITY,
            position: Vec3::new(0.0, 3.6, 0.0),
            direction: -Vec3::Y,
            size: 0.0,
        },
        Light {
            kind: LightKind::Spot {
                inner_cone: 0.3,
                outer_cone: 0.5,
            },
            color: Vec3::new(1.0, 0.9, 0.7),
            intensity: 20.0,
            range: f32::INFINITY,
            position: Vec3::new(1.5, 3.5, 1.8),
            direction: (Vec3::new(0.0, 0.0, -0.5) - Vec3::new(1.5, 3.5, 1.8)).normalize(),
            size: 0.0,
        },
    ];
    let _ = Vec4::ZERO;
    assemble(
        geometries,
        instances,
        materials,
        lights,
        vec![look_at(
            Vec3::new(0.0, 2.0, 7.5),
            Vec3::new(0.0, 1.6, 0.0),
            40.0,
        )],
    )
}
