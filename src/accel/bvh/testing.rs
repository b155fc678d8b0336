//! Deterministic scene and ray generators shared by the BVH's unit tests, GPU tests and
//! benchmark: compiled for the unit tests and with the `testing` feature only (the
//! integration tests and benchmarks enable it). Spheres come from the scene's own
//! [`crate::scene::procedural::sphere`].

use glam::{Mat4, Quat, Vec3, Vec4};

use super::cpu::Ray;
use crate::scene::{AlphaMode, Geometry, Instance, Material, Scene};

/// A small PCG32 generator: reproducible inputs without a `rand` dependency.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// Seeds the generator.
    pub fn new(seed: u64) -> Self {
        let mut r = Self(seed.wrapping_mul(6_364_136_223_846_793_005) ^ 0x9E37_79B9_7F4A_7C15);
        r.next_u32();
        r
    }

    /// Next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let old = self.0;
        self.0 = old
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }

    /// Uniform in [0, 1).
    pub fn f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 / (1u32 << 24) as f32
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }

    /// Uniform in the box.
    pub fn vec3(&mut self, lo: Vec3, hi: Vec3) -> Vec3 {
        Vec3::new(
            self.range(lo.x, hi.x),
            self.range(lo.y, hi.y),
            self.range(lo.z, hi.z),
        )
    }

    /// Uniform direction on the unit sphere.
    pub fn unit(&mut self) -> Vec3 {
        let z = self.range(-1.0, 1.0);
        let phi = self.range(0.0, std::f32::consts::TAU);
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}

/// A geometry from positions and a triangle list (normals left empty: traversal ignores them).
pub fn geometry(positions: Vec<Vec3>, indices: Vec<u32>, material: u32) -> Geometry {
    Geometry {
        positions,
        indices,
        material,
        ..Default::default()
    }
}

/// `n` independent random triangles (no shared vertices) of size up to `size` in a cube of
/// half-extent `extent`.
pub fn random_triangles(rng: &mut Rng, n: usize, extent: f32, size: f32) -> Geometry {
    let mut positions = Vec::with_capacity(3 * n);
    for _ in 0..n {
        let c = rng.vec3(Vec3::splat(-extent), Vec3::splat(extent));
        for _ in 0..3 {
            positions.push(c + rng.vec3(Vec3::splat(-size), Vec3::splat(size)));
        }
    }
    let indices = (0..3 * n as u32).collect();
    geometry(positions, indices, 0)
}

/// [`crate::scene::procedural::sphere`] (`segments` around, `rings` from pole to pole)
/// scaled to radius `r`.
pub fn scaled_sphere(segments: u32, rings: u32, r: f32) -> Geometry {
    let mut g = crate::scene::procedural::sphere(0, segments, rings);
    for p in &mut g.positions {
        *p *= r;
    }
    g
}

/// A closed axis-aligned cube `[-1, 1]^3` with every face split into `n x n` quads of two
/// triangles, vertices shared along face seams. Grid coordinates are exact in f32 for
/// power-of-two `n`, so rays aimed at vertices and edge points hit them exactly.
pub fn grid_cube(n: u32) -> Geometry {
    let mut positions: Vec<Vec3> = Vec::new();
    let mut lookup = std::collections::HashMap::new();
    let mut vertex = |p: Vec3, positions: &mut Vec<Vec3>| -> u32 {
        let key = (p.x.to_bits(), p.y.to_bits(), p.z.to_bits());
        *lookup.entry(key).or_insert_with(|| {
            positions.push(p);
            positions.len() as u32 - 1
        })
    };
    let mut indices = Vec::new();
    let coord = |i: u32| -1.0 + 2.0 * i as f32 / n as f32;
    for axis in 0..3 {
        for side in [-1.0f32, 1.0] {
            let (u_axis, v_axis) = ((axis + 1) % 3, (axis + 2) % 3);
            for i in 0..n {
                for j in 0..n {
                    let p = |a: u32, b: u32| {
                        let mut v = Vec3::ZERO;
                        v[axis] = side;
                        v[u_axis] = coord(a);
                        v[v_axis] = coord(b);
                        v
                    };
                    let q = [p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1)];
                    let q = q.map(|v| vertex(v, &mut positions));
                    // Outward winding on both sides.
                    if side > 0.0 {
                        indices.extend([q[0], q[1], q[2], q[0], q[2], q[3]]);
                    } else {
                        indices.extend([q[0], q[2], q[1], q[0], q[3], q[2]]);
                    }
                }
            }
        }
    }
    geometry(positions, indices, 0)
}

/// A scene of the given geometries with one identity instance each and `materials` (the
/// default material when empty).
pub fn scene_of(geometries: Vec<Geometry>, materials: Vec<Material>) -> Scene {
    let instances = (0..geometries.len() as u32)
        .map(|g| Instance {
            geometry: g,
            transform: Mat4::IDENTITY,
            node: g as usize,
        })
        .collect();
    finish_scene(geometries, instances, materials)
}

/// Fills the derived fields of a scene.
pub fn finish_scene(
    geometries: Vec<Geometry>,
    instances: Vec<Instance>,
    mut materials: Vec<Material>,
) -> Scene {
    if materials.is_empty() {
        materials.push(Material::default());
    }
    let mut scene = Scene {
        source: "built-in".into(),
        geometries,
        instances,
        materials,
        ..Default::default()
    };
    for inst in &scene.instances {
        if let Some(g) = scene.geometries.get(inst.geometry as usize) {
            for p in &g.positions {
                scene.bounds.grow(inst.transform.transform_point3(*p));
            }
        }
    }
    scene
}

/// A grid of `nx * nz` instances of three shared geometries (sphere, cube, triangle soup) with
/// rotated, non-uniformly scaled and mirrored transforms.
pub fn instanced_grid(rng: &mut Rng, nx: u32, nz: u32) -> Scene {
    let geometries = vec![
        crate::scene::procedural::sphere(0, 16, 12),
        grid_cube(2),
        random_triangles(rng, 200, 1.0, 0.4),
    ];
    let mut instances = Vec::new();
    for i in 0..nx {
        for k in 0..nz {
            let g = (i * nz + k) % 3;
            let axis = rng.unit();
            let rot = Quat::from_axis_angle(axis, rng.range(0.0, std::f32::consts::TAU));
            let mut scale = rng.vec3(Vec3::splat(0.4), Vec3::splat(1.2));
            // Every third instance mirrored: negative determinant, flipped winding.
            if (i + k) % 3 == 1 {
                scale.x = -scale.x;
            }
            let pos = Vec3::new(3.0 * i as f32, rng.range(-0.5, 0.5), 3.0 * k as f32);
            instances.push(Instance {
                geometry: g,
                transform: Mat4::from_scale_rotation_translation(scale, rot, pos),
                node: instances.len(),
            });
        }
    }
    finish_scene(geometries, instances, Vec::new())
}

/// Three parallel quads facing +z at z = 1, 0, -1 (hit in that order by rays travelling -z):
/// a MASK quad whose base alpha (0.3) is below its cutoff (0.5) so it never blocks; a MASK
/// quad whose vertex-colour alpha runs 0 -> 1 across x, so it blocks where x > 0; an OPAQUE
/// quad that blocks everywhere.
pub fn alpha_quads() -> Scene {
    let quad = |z: f32, material: u32, colors: bool| {
        let p = vec![
            Vec3::new(-1.0, -1.0, z),
            Vec3::new(1.0, -1.0, z),
            Vec3::new(1.0, 1.0, z),
            Vec3::new(-1.0, 1.0, z),
        ];
        let mut g = geometry(p, vec![0, 1, 2, 0, 2, 3], material);
        if colors {
            g.colors = vec![
                Vec4::new(1.0, 1.0, 1.0, 0.0),
                Vec4::new(1.0, 1.0, 1.0, 1.0),
                Vec4::new(1.0, 1.0, 1.0, 1.0),
                Vec4::new(1.0, 1.0, 1.0, 0.0),
            ];
        }
        g
    };
    let mask = |alpha: f32| Material {
        base_color: Vec4::new(1.0, 1.0, 1.0, alpha),
        alpha_mode: AlphaMode::Mask,
        alpha_cutoff: 0.5,
        ..Default::default()
    };
    scene_of(
        vec![
            quad(1.0, 0, false),
            quad(0.0, 1, true),
            quad(-1.0, 2, false),
        ],
        vec![mask(0.3), mask(1.0), Material::default()],
    )
}

/// `n` rays with origins in the scene bounds grown by half their size, random non-unit
/// directions, and a mix of `[tmin, tmax]` ranges (full, clipped, and some empty).
pub fn random_rays(rng: &mut Rng, scene: &Scene, n: usize) -> Vec<Ray> {
    let (lo, hi) = if scene.bounds.is_empty() {
        (Vec3::splat(-1.0), Vec3::splat(1.0))
    } else {
        let ext = (scene.bounds.max - scene.bounds.min) * 0.5;
        (scene.bounds.min - ext, scene.bounds.max + ext)
    };
    let diag = (hi - lo).length();
    (0..n)
        .map(|i| {
            let origin = rng.vec3(lo, hi);
            // Mostly towards the scene so most rays hit something.
            let target = if i % 4 == 0 {
                origin + rng.unit()
            } else {
                rng.vec3(scene.bounds.min.min(lo), scene.bounds.max.max(hi))
            };
            let len = rng.range(0.25, 4.0);
            let dir = (target - origin).normalize_or(Vec3::X) * len;
            let (tmin, tmax) = match i % 5 {
                0 => (0.0, f32::INFINITY),
                1 => (0.0, rng.range(0.0, diag / len)),
                2 => (rng.range(0.0, diag / len * 0.5), f32::INFINITY),
                3 => (1e-3, 2.0 * diag / len),
                _ => (0.0, 1e30),
            };
            Ray {
                origin,
                dir,
                tmin,
                tmax,
            }
        })
        .collect()
}

/// Primary rays of a pinhole camera, pixel centres, row 0 at the top; `fov_y` in radians.
pub fn camera_rays(width: u32, height: u32, eye: Vec3, target: Vec3, fov_y: f32) -> Vec<Ray> {
    let forward = (target - eye).normalize();
    let right = forward.cross(Vec3::Y).normalize();
    let up = right.cross(forward);
    let h = (fov_y * 0.5).tan();
    let aspect = width as f32 / height as f32;
    let mut rays = Vec::with_capacity((width * height) as usize);
    for y in 0..height {
        for x in 0..width {
            let u = (2.0 * (x as f32 + 0.5) / width as f32 - 1.0) * h * aspect;
            let v = (1.0 - 2.0 * (y as f32 + 0.5) / height as f32) * h;
            rays.push(Ray {
                origin: eye,
                dir: (forward + u * right + v * up).normalize(),
                tmin: 0.0,
                tmax: f32::INFINITY,
            });
        }
    }
    rays
}

/// Reads the first mesh primitive of a glTF/GLB file: positions and triangle-list indices
/// (the benchmark meshes; the real loader lives in `scene`).
pub fn load_mesh(path: &std::path::Path) -> Result<Geometry, String> {
    let (doc, buffers, _) = gltf::import(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let prim = doc
        .meshes()
        .flat_map(|m| m.primitives())
        .next()
        .ok_or_else(|| format!("{}: no mesh primitive", path.display()))?;
    let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
    let positions: Vec<Vec3> = reader
        .read_positions()
        .ok_or_else(|| format!("{}: no POSITION", path.display()))?
        .map(Vec3::from)
        .collect();
    let indices: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None => (0..positions.len() as u32).collect(),
    };
    Ok(geometry(positions, indices, 0))
}
