//! CPU mirror of `shaders/common/trace_bvh.glsl`: the same ray set-up, sign-selected slab test
//! and watertight triangle test, plus a brute-force reference over every instance. Tests compare
//! the GPU against these; the renderer never calls them.

use glam::{Mat4, Vec2, Vec3};

use super::layout::{decode_link, BvhNode, BVH_INSTANCE_ALPHA_TEST, BVH_WIDTH, LINK_EMPTY};
use super::{BvhData, TLAS_ROOT};
use crate::scene::{AlphaMode, Scene};

/// Smallest direction component magnitude used for `1 / d` (larger values keep `inv_d` finite,
/// so `fma(p, inv_d, -o * inv_d)` never produces `inf - inf`). Same value in `trace_bvh.glsl`.
pub const MIN_DIR_COMPONENT: f32 = 1e-20;

/// A ray closest-hit or any-hit query, with the `VK_KHR_ray_query` semantics: hits count when
/// `tmin <= t <= tmax`, `t` in units of `dir` (which need not be unit length).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin.
    pub origin: Vec3,
    /// Direction.
    pub dir: Vec3,
    /// Smallest accepted t.
    pub tmin: f32,
    /// Largest accepted t.
    pub tmax: f32,
}

/// A hit as `trace_closest()` reports it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HostHit {
    /// Distance along `dir`.
    pub t: f32,
    /// Scene instance index.
    pub instance: u32,
    /// Triangle index within the geometry (original index order).
    pub primitive: u32,
    /// Weights of vertices 1 and 2.
    pub barycentrics: Vec2,
}

/// Per-ray constants of the slab and watertight tests.
#[derive(Clone, Copy, Debug)]
pub struct RayPre {
    /// Origin.
    pub origin: Vec3,
    /// `1 / dir`, with tiny components clamped to [`MIN_DIR_COMPONENT`].
    pub inv_dir: Vec3,
    /// `-origin * inv_dir`: each slab plane is one `fma(p, inv_dir, o_times_inv)`.
    pub o_times_inv: Vec3,
    /// Axis permutation of the watertight test: `kz` is the dominant axis of `dir`.
    pub k: [usize; 3],
    /// Shear constants `(dir[kx] / dir[kz], dir[ky] / dir[kz], 1 / dir[kz])`.
    pub shear: Vec3,
}

impl RayPre {
    /// Precomputes the constants for `origin + t * dir`.
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        let safe = |x: f32| {
            if x.abs() < MIN_DIR_COMPONENT {
                MIN_DIR_COMPONENT.copysign(x)
            } else {
                x
            }
        };
        let inv_dir = Vec3::new(1.0 / safe(dir.x), 1.0 / safe(dir.y), 1.0 / safe(dir.z));
        let o_times_inv = -origin * inv_dir;
        let a = dir.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        // Keeps the winding of the projected triangle independent of the ray's direction sign.
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let shear = Vec3::new(dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]);
        Self {
            origin,
            inv_dir,
            o_times_inv,
            k: [kx, ky, kz],
            shear,
        }
    }

    /// Slab tests of a node's children, as `trace_bvh.glsl` does them: the ray is moved into
    /// the node's quantization frame once (`a = scale * inv_dir`,
    /// `b = fma(origin, inv_dir, o_times_inv)`), then every plane is one `fma(q, a, b)`. Near
    /// and far planes are picked by the sign of the direction, so an inverted (unused) box
    /// never hits. Returns each child's entry distance where `[t_entry, t_exit]` overlaps
    /// `[tmin, tmax]`.
    pub fn node_hits(&self, node: &BvhNode, tmin: f32, tmax: f32) -> [Option<f32>; BVH_WIDTH] {
        let scale = node.scales();
        let a: [f32; 3] = [0, 1, 2].map(|k| scale[k] * self.inv_dir[k]);
        let b: [f32; 3] =
            [0, 1, 2].map(|k| node.origin[k].mul_add(self.inv_dir[k], self.o_times_inv[k]));
        std::array::from_fn(|c| {
            let mut entry = tmin;
            let mut exit = tmax;
            for k in 0..3 {
                let lo = f32::from(node.planes[2 * k][c]);
                let hi = f32::from(node.planes[2 * k + 1][c]);
                let (near, far) = if self.inv_dir[k] < 0.0 {
                    (hi, lo)
                } else {
                    (lo, hi)
                };
                entry = entry.max(near.mul_add(a[k], b[k]));
                exit = exit.min(far.mul_add(a[k], b[k]));
            }
            (entry <= exit).then_some(entry)
        })
    }

    /// Watertight ray/triangle test (Woop, Benthin, Wald 2013): `Some((t, b1, b2))` for a hit
    /// with `tmin <= t <= tmax`; edges and vertices shared by two triangles never let a ray
    /// through, because both triangles evaluate the shared edge function on identical inputs
    /// and its sign is exact.
    pub fn triangle(
        &self,
        v0: Vec3,
        v1: Vec3,
        v2: Vec3,
        tmin: f32,
        tmax: f32,
    ) -> Option<(f32, f32, f32)> {
        let [kx, ky, kz] = self.k;
        let s = self.shear;
        let a = v0 - self.origin;
        let b = v1 - self.origin;
        let c = v2 - self.origin;
        let (ax, ay) = (a[kx] - s.x * a[kz], a[ky] - s.y * a[kz]);
        let (bx, by) = (b[kx] - s.x * b[kz], b[ky] - s.y * b[kz]);
        let (cx, cy) = (c[kx] - s.x * c[kz], c[ky] - s.y * c[kz]);
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            // A float zero may hide a tiny non-zero value of either sign; f64 products of f32
            // values are exact, so the sign is.
            let dop = |p: f32, q: f32, r: f32, t: f32| {
                (f64::from(p) * f64::from(q) - f64::from(r) * f64::from(t)) as f32
            };
            u = dop(cx, by, cy, bx);
            v = dop(ax, cy, ay, cx);
            w = dop(bx, ay, by, ax);
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let t_scaled = u * (s.z * a[kz]) + v * (s.z * b[kz]) + w * (s.z * c[kz]);
        let rcp = 1.0 / det;
        let t = t_scaled * rcp;
        // Written so that NaN (degenerate rays) fails.
        if !(t >= tmin && t <= tmax) {
            return None;
        }
        Some((t, v * rcp, w * rcp))
    }
}

/// Rows of the world-to-object affine part of `object_to_world`'s inverse, or `None` when the
/// transform is singular or not finite.
pub fn world_to_object_rows(object_to_world: &Mat4) -> Option<[[f32; 4]; 3]> {
    let inv = object_to_world.inverse();
    let rows = [
        inv.row(0).to_array(),
        inv.row(1).to_array(),
        inv.row(2).to_array(),
    ];
    rows.iter().flatten().all(|x| x.is_finite()).then_some(rows)
}

/// Applies world-to-object rows to a point (`w = 1`) or a direction (`w = 0`), with the same
/// operation order as `trace_bvh.glsl`.
pub fn transform_rows(rows: &[[f32; 4]; 3], p: Vec3, w: f32) -> Vec3 {
    let r = |row: &[f32; 4]| row[0] * p.x + row[1] * p.y + row[2] * p.z + row[3] * w;
    Vec3::new(r(&rows[0]), r(&rows[1]), r(&rows[2]))
}

/// The CPU rule of `alpha_accepts()` for scenes without textures: MASK materials keep a hit
/// when base-colour alpha times interpolated vertex-colour alpha reaches the cutoff. Base colour
/// textures are not sampled here (tests use factors and vertex colours).
pub fn alpha_accepts_untextured(scene: &Scene, instance: u32, prim: u32, bary: Vec2) -> bool {
    let Some(inst) = scene.instances.get(instance as usize) else {
        return true;
    };
    let Some(geom) = scene.geometries.get(inst.geometry as usize) else {
        return true;
    };
    let Some(mat) = scene.materials.get(geom.material as usize) else {
        return true;
    };
    if mat.alpha_mode != AlphaMode::Mask {
        return true;
    }
    let mut alpha = mat.base_color.w;
    if !geom.colors.is_empty() {
        let base = 3 * prim as usize;
        let w = [1.0 - bary.x - bary.y, bary.x, bary.y];
        let mut a = 0.0;
        for (k, wk) in w.iter().enumerate() {
            let vi = geom.indices[base + k] as usize;
            a += wk * geom.colors.get(vi).map_or(1.0, |c| c.w);
        }
        alpha *= a;
    }
    alpha >= mat.alpha_cutoff
}

impl BvhData {
    /// Closest hit through the flattened BVH, visiting nodes as `trace_closest()` does.
    /// `accepts(instance, primitive, barycentrics)` is consulted for alpha-tested instances only.
    pub fn trace_closest(
        &self,
        ray: &Ray,
        mut accepts: impl FnMut(u32, u32, Vec2) -> bool,
    ) -> Option<HostHit> {
        let mut best = None;
        self.traverse(ray, false, &mut |inst, prim, t, bary, alpha_test| {
            let ok = !alpha_test || accepts(inst, prim, bary);
            if ok {
                best = Some(HostHit {
                    t,
                    instance: inst,
                    primitive: prim,
                    barycentrics: bary,
                });
            }
            ok
        });
        best
    }

    /// Whether anything is hit in `[tmin, tmax]` (`trace_any()`).
    pub fn trace_any(&self, ray: &Ray, mut accepts: impl FnMut(u32, u32, Vec2) -> bool) -> bool {
        let mut any = false;
        self.traverse(ray, true, &mut |inst, prim, _, bary, alpha_test| {
            any = !alpha_test || accepts(inst, prim, bary);
            any
        });
        any
    }

    /// Every (instance, primitive) pair in the leaves reachable from the top-level root, once
    /// per leaf occurrence: for the "every triangle exactly once" invariants.
    pub fn leaf_primitives(&self) -> Vec<(u32, u32)> {
        let mut out = Vec::new();
        // (node, instance whose bottom level this is, or None in the top level)
        let mut stack: Vec<(u32, Option<u32>)> = vec![(TLAS_ROOT, None)];
        while let Some((node, inst)) = stack.pop() {
            for child in self.nodes[node as usize].children() {
                match (decode_link(child.link), inst) {
                    (Ok(n), _) => stack.push((n, inst)),
                    (Err((i, _)), None) => {
                        stack.push((self.instances[i as usize].blas_root, Some(i)))
                    }
                    (Err((first, count)), Some(i)) => out.extend(
                        (first..first + count).map(|t| (i, self.triangles[t as usize].primitive)),
                    ),
                }
            }
        }
        out
    }

    /// Nearer-first traversal of both levels. `on_hit(instance, prim, t, bary, alpha_test)`
    /// says whether a candidate is accepted; accepted hits shrink tmax (or end an any-hit query).
    fn traverse(
        &self,
        ray: &Ray,
        any: bool,
        on_hit: &mut dyn FnMut(u32, u32, f32, Vec2, bool) -> bool,
    ) {
        let world = RayPre::new(ray.origin, ray.dir);
        let mut tmax = ray.tmax;
        // (node, ray constants of its level, instance when in a bottom level)
        let mut stack: Vec<(u32, RayPre, Option<u32>)> = vec![(TLAS_ROOT, world, None)];
        while let Some((node, pre, inst)) = stack.pop() {
            let n = &self.nodes[node as usize];
            let mut hits: Vec<(f32, u32)> = pre
                .node_hits(n, ray.tmin, tmax)
                .iter()
                .zip(n.links)
                .filter_map(|(t, link)| t.filter(|_| link != LINK_EMPTY).map(|t| (t, link)))
                .collect();
            // Farther children pushed first so the nearest one is popped next.
            hits.sort_by(|a, b| b.0.total_cmp(&a.0));
            for (_, link) in hits {
                match (decode_link(link), inst) {
                    (Ok(next), _) => stack.push((next, pre, inst)),
                    (Err((i, _)), None) => {
                        let bi = &self.instances[i as usize];
                        let object = RayPre::new(
                            transform_rows(&bi.world_to_object, ray.origin, 1.0),
                            transform_rows(&bi.world_to_object, ray.dir, 0.0),
                        );
                        stack.push((bi.blas_root, object, Some(i)));
                    }
                    (Err((first, count)), Some(i)) => {
                        let alpha_test =
                            self.instances[i as usize].flags & BVH_INSTANCE_ALPHA_TEST != 0;
                        for tri in first..first + count {
                            let tr = &self.triangles[tri as usize];
                            let Some((t, b1, b2)) = pre.triangle(
                                tr.v0.into(),
                                tr.v1.into(),
                                tr.v2.into(),
                                ray.tmin,
                                tmax,
                            ) else {
                                continue;
                            };
                            let prim = tr.primitive;
                            if on_hit(i, prim, t, Vec2::new(b1, b2), alpha_test) {
                                if any {
                                    return;
                                }
                                tmax = t;
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Brute force over every instance and triangle of `scene` with the same watertight test:
/// the reference the BVH results are compared with. Instances whose transform cannot be
/// inverted are skipped, as the BVH skips them.
pub fn brute_force_closest(
    scene: &Scene,
    ray: &Ray,
    mut accepts: impl FnMut(u32, u32, Vec2) -> bool,
) -> Option<HostHit> {
    let mut best: Option<HostHit> = None;
    let mut tmax = ray.tmax;
    for (ii, inst) in scene.instances.iter().enumerate() {
        let Some(rows) = world_to_object_rows(&inst.transform) else {
            continue;
        };
        let Some(geom) = scene.geometries.get(inst.geometry as usize) else {
            continue;
        };
        let pre = RayPre::new(
            transform_rows(&rows, ray.origin, 1.0),
            transform_rows(&rows, ray.dir, 0.0),
        );
        for (prim, tri) in geom.indices.chunks_exact(3).enumerate() {
            let p = |k: usize| geom.positions.get(tri[k] as usize).copied();
            let (Some(v0), Some(v1), Some(v2)) = (p(0), p(1), p(2)) else {
                continue;
            };
            if let Some((t, b1, b2)) = pre.triangle(v0, v1, v2, ray.tmin, tmax) {
                let bary = Vec2::new(b1, b2);
                if accepts(ii as u32, prim as u32, bary) {
                    tmax = t;
                    best = Some(HostHit {
                        t,
                        instance: ii as u32,
                        primitive: prim as u32,
                        barycentrics: bary,
                    });
                }
            }
        }
    }
    best
}
