//! Triangle-list conversion and the attributes a file may omit: flat normals and
//! MikkTSpace tangents.

use std::collections::HashMap;

use glam::{Vec2, Vec3, Vec4};

use super::types::Geometry;

/// glTF primitive topology that yields triangles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Topology {
    /// `TRIANGLES` (mode 4).
    List,
    /// `TRIANGLE_STRIP` (mode 5).
    Strip,
    /// `TRIANGLE_FAN` (mode 6).
    Fan,
}

/// Converts a vertex sequence to a triangle list, keeping the glTF winding: strip triangle
/// `i` is `(p[i], p[i + 1 + i % 2], p[i + 2 - i % 2])`, fan triangle `i` is
/// `(p[i + 1], p[i + 2], p[0])`. A list's trailing partial triangle is dropped.
pub fn triangulate(topology: Topology, seq: &[u32]) -> Vec<u32> {
    match topology {
        Topology::List => seq[..seq.len() / 3 * 3].to_vec(),
        Topology::Strip => {
            let n = seq.len().saturating_sub(2);
            let mut out = Vec::with_capacity(n * 3);
            for i in 0..n {
                let odd = i % 2;
                out.extend_from_slice(&[seq[i], seq[i + 1 + odd], seq[i + 2 - odd]]);
            }
            out
        }
        Topology::Fan => {
            let n = seq.len().saturating_sub(2);
            let mut out = Vec::with_capacity(n * 3);
            for i in 0..n {
                out.extend_from_slice(&[seq[i + 1], seq[i + 2], seq[0]]);
            }
            out
        }
    }
}

/// Expands `items` so that corner `k` of the triangle list gets `items[indices[k]]`.
fn unweld<T: Copy>(items: &mut Vec<T>, indices: &[u32]) {
    if items.is_empty() {
        return;
    }
    *items = indices.iter().map(|&i| items[i as usize]).collect();
}

/// Gives every triangle its own three vertices with the face normal, as the glTF spec asks
/// for primitives without `NORMAL` ("flat normals"). Degenerate triangles get +Z.
pub fn compute_flat_normals(g: &mut Geometry) {
    let indices = std::mem::take(&mut g.indices);
    unweld(&mut g.positions, &indices);
    unweld(&mut g.tangents, &indices);
    unweld(&mut g.uv0, &indices);
    unweld(&mut g.uv1, &indices);
    unweld(&mut g.colors, &indices);
    unweld(&mut g.joints, &indices);
    unweld(&mut g.weights, &indices);
    for t in &mut g.morph_targets {
        unweld(&mut t.positions, &indices);
        unweld(&mut t.normals, &indices);
        unweld(&mut t.tangents, &indices);
    }
    g.normals = g
        .positions
        .chunks_exact(3)
        .flat_map(|t| {
            let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or(Vec3::Z);
            [n, n, n]
        })
        .collect();
    g.indices = (0..g.positions.len() as u32).collect();
}

struct Mikk<'a> {
    indices: &'a [u32],
    positions: Vec<Vec3>,
    normals: &'a [Vec3],
    uv: Vec<Vec2>,
    /// Triangles handed to MikkTSpace (index into the triangle list).
    faces: Vec<usize>,
    corner_tangents: Vec<Vec4>,
}

impl Mikk<'_> {
    fn vertex(&self, face: usize, vert: usize) -> usize {
        self.indices[self.faces[face] * 3 + vert] as usize
    }
}

impl mikktspace::Geometry for Mikk<'_> {
    fn num_faces(&self) -> usize {
        self.faces.len()
    }
    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }
    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.positions[self.vertex(face, vert)].to_array()
    }
    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        self.normals[self.vertex(face, vert)].to_array()
    }
    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        self.uv[self.vertex(face, vert)].to_array()
    }
    fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
        // MikkTSpace assumes a bottom-left UV origin; glTF's is top-left, so the bitangent
        // (direction of increasing v) is mirrored and the handedness sign flips.
        let [x, y, z, w] = tangent;
        self.corner_tangents[self.faces[face] * 3 + vert] = Vec4::new(x, y, z, -w);
    }
}

/// Divides by the largest magnitude so that MikkTSpace's products stay finite; tangent
/// directions and signs do not change under a uniform positive scale.
fn normalized<T: Copy + std::ops::Mul<f32, Output = T>>(
    v: &[T],
    max_abs: impl Fn(&T) -> f32,
) -> Vec<T> {
    let m = v.iter().map(max_abs).fold(0.0f32, f32::max);
    let k = if m > 0.0 && m.is_finite() {
        1.0 / m
    } else {
        1.0
    };
    v.iter().map(|&x| x * k).collect()
}

/// Computes MikkTSpace tangents from the normals and UV set `uv_set` (0 or 1). Corners of
/// a shared vertex that get different tangents are split into separate vertices; the rest
/// stay shared. Triangles with no area (which the `mikktspace` crate cannot handle) get an
/// arbitrary tangent perpendicular to the normal. Returns false (tangents left empty) when
/// the UV set is missing or the generator fails.
pub fn compute_tangents(g: &mut Geometry, uv_set: u32) -> bool {
    let uv = if uv_set == 1 { &g.uv1 } else { &g.uv0 };
    if uv.len() != g.positions.len() || g.normals.len() != g.positions.len() {
        return false;
    }
    let positions = normalized(&g.positions, |p| p.abs().max_element());
    let uv = normalized(uv, |t| t.abs().max_element());
    let faces: Vec<usize> = g
        .indices
        .chunks_exact(3)
        .enumerate()
        .filter(|(_, t)| {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| positions[i as usize]);
            let area = (b - a).cross(c - a).length_squared();
            area > 0.0 && area.is_finite()
        })
        .map(|(f, _)| f)
        .collect();
    let mut m = Mikk {
        indices: &g.indices,
        positions,
        normals: &g.normals,
        uv,
        faces,
        corner_tangents: vec![Vec4::NAN; g.indices.len()],
    };
    if !m.faces.is_empty() && !mikktspace::generate_tangents(&mut m) {
        return false;
    }
    let mut corner_tangents = m.corner_tangents;
    for (k, t) in corner_tangents.iter_mut().enumerate() {
        if !t.is_finite() || t.truncate().length_squared() == 0.0 {
            let n = g.normals[g.indices[k] as usize];
            *t = n.any_orthonormal_vector().extend(1.0);
        }
    }
    let old_count = g.positions.len();
    let mut remap: HashMap<(u32, [u32; 4]), u32> = HashMap::new();
    let mut first: Vec<Option<[u32; 4]>> = vec![None; old_count];
    let mut tangents = vec![Vec4::new(1.0, 0.0, 0.0, 1.0); old_count];
    let mut extra: Vec<(u32, Vec4)> = Vec::new();
    for (k, t) in corner_tangents.iter().enumerate() {
        let v = g.indices[k];
        let key = t.to_array().map(f32::to_bits);
        match first[v as usize] {
            None => {
                first[v as usize] = Some(key);
                tangents[v as usize] = *t;
            }
            Some(existing) if existing == key => {}
            Some(_) => {
                let next = (old_count + extra.len()) as u32;
                let new = *remap.entry((v, key)).or_insert_with(|| {
                    extra.push((v, *t));
                    next
                });
                g.indices[k] = new;
            }
        }
    }
    for (src, t) in extra {
        let s = src as usize;
        g.positions.push(g.positions[s]);
        g.normals.push(g.normals[s]);
        if !g.uv0.is_empty() {
            g.uv0.push(g.uv0[s]);
        }
        if !g.uv1.is_empty() {
            g.uv1.push(g.uv1[s]);
        }
        if !g.colors.is_empty() {
            g.colors.push(g.colors[s]);
        }
        if !g.joints.is_empty() {
            g.joints.push(g.joints[s]);
            g.weights.push(g.weights[s]);
        }
        for m in &mut g.morph_targets {
            for attr in [&mut m.positions, &mut m.normals, &mut m.tangents] {
                if !attr.is_empty() {
                    attr.push(attr[s]);
                }
            }
        }
        tangents.push(t);
    }
    g.tangents = tangents;
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strip_alternates_winding() {
        let t = triangulate(Topology::Strip, &[0, 1, 2, 3, 4]);
        assert_eq!(t, vec![0, 1, 2, 1, 3, 2, 2, 3, 4]);
    }

    #[test]
    fn fan_pivots_on_first() {
        let t = triangulate(Topology::Fan, &[0, 1, 2, 3]);
        assert_eq!(t, vec![1, 2, 0, 2, 3, 0]);
    }

    #[test]
    fn list_drops_partial_triangle() {
        assert_eq!(triangulate(Topology::List, &[0, 1, 2, 3]), vec![0, 1, 2]);
        assert!(triangulate(Topology::Strip, &[0, 1]).is_empty());
    }

    fn quad() -> Geometry {
        // XY quad facing +Z; glTF UVs: u along +X, v grows downwards (towards -Y).
        Geometry {
            positions: vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
            ],
            uv0: vec![
                Vec2::new(0.0, 1.0),
                Vec2::new(1.0, 1.0),
                Vec2::new(1.0, 0.0),
                Vec2::new(0.0, 0.0),
            ],
            indices: vec![0, 1, 2, 0, 2, 3],
            ..Default::default()
        }
    }

    #[test]
    fn flat_normals_unweld() {
        let mut g = quad();
        compute_flat_normals(&mut g);
        assert_eq!(g.positions.len(), 6);
        assert_eq!(g.uv0.len(), 6);
        assert_eq!(g.indices, vec![0, 1, 2, 3, 4, 5]);
        assert!(g.normals.iter().all(|n| n.abs_diff_eq(Vec3::Z, 1e-6)));
    }

    #[test]
    fn tangents_follow_u_with_gltf_handedness() {
        let mut g = quad();
        g.normals = vec![Vec3::Z; 4];
        assert!(compute_tangents(&mut g, 0));
        assert_eq!(g.tangents.len(), g.positions.len());
        for t in &g.tangents {
            assert!(t.truncate().abs_diff_eq(Vec3::X, 1e-5), "{t}");
            // Bitangent = cross(N, T) * w must point to the image's top (+Y here).
            assert_eq!(t.w, 1.0);
        }
        assert!(!compute_tangents(&mut g, 1), "no TEXCOORD_1");
    }

    #[test]
    fn tangents_survive_degenerate_and_huge_input() {
        let mut g = quad();
        g.normals = vec![Vec3::Z; 4];
        g.positions = vec![Vec3::ZERO; 4];
        assert!(compute_tangents(&mut g, 0));
        assert!(g
            .tangents
            .iter()
            .all(|t| t.is_finite() && t.truncate().dot(Vec3::Z) == 0.0));
        let mut g = quad();
        g.normals = vec![Vec3::Z; 4];
        for p in &mut g.positions {
            *p *= 1e30;
        }
        assert!(compute_tangents(&mut g, 0));
        assert!(g
            .tangents
            .iter()
            .all(|t| t.truncate().abs_diff_eq(Vec3::X, 1e-5)));
    }
}
