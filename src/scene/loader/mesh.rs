//! Meshes into geometry: primitives' attributes read, checked and converted (quantized,
//! Draco-decoded or plain), triangulated, with normals and tangents computed where the file
//! has none, and placed as instances.

use glam::{Mat4, Vec2, Vec3, Vec4};

use super::*;

impl Loader<'_> {
    pub(super) fn place_mesh(
        &mut self,
        n: usize,
        mesh: usize,
        world: Mat4,
    ) -> Result<(), SceneError> {
        let Some(m) = self.root.meshes.get(mesh) else {
            return Err(self.err(
                format!("node {n}"),
                format!(
                    "mesh {mesh} does not exist ({} meshes)",
                    self.root.meshes.len()
                ),
            ));
        };
        let primitives = m.primitives.len();
        let locals = self.gpu_instances(n)?;
        for p in 0..primitives {
            let Some(g) = self.geometry(mesh, p)? else {
                continue;
            };
            if let Some(s) = self.root.nodes[n].skin.map(|s| s.value()) {
                let geometry = &self.scene.geometries[g as usize];
                skin::check_joint_range(
                    &self.file,
                    &format!("node {n} (skin {s}) mesh {mesh} primitive {p}"),
                    &geometry.joints,
                    &geometry.weights,
                    s,
                    &self.scene.rig.skins[s],
                )?;
            }
            if self.scene.instances.len() + locals.len() > MAX_INSTANCES {
                return Err(self.err(
                    format!("node {n}"),
                    format!("the scene expands to more than {MAX_INSTANCES} instances"),
                ));
            }
            for local in &locals {
                self.scene.instances.push(Instance {
                    geometry: g,
                    transform: world * *local,
                    node: n,
                });
                self.scene.rig.instance_local.push(*local);
            }
        }
        Ok(())
    }

    pub(super) fn attribute(
        &self,
        element: &str,
        prim: &gj::mesh::Primitive,
        semantic: gj::mesh::Semantic,
        comps: &[usize],
        vertices: Option<usize>,
    ) -> Result<Option<Elements<f32>>, SceneError> {
        let name = match &semantic {
            gj::mesh::Semantic::Positions => "POSITION".to_string(),
            gj::mesh::Semantic::Normals => "NORMAL".to_string(),
            gj::mesh::Semantic::Tangents => "TANGENT".to_string(),
            gj::mesh::Semantic::TexCoords(i) => format!("TEXCOORD_{i}"),
            gj::mesh::Semantic::Colors(i) => format!("COLOR_{i}"),
            other => format!("{other:?}"),
        };
        let Some(index) = prim.attributes.get(&Checked::Valid(semantic)) else {
            return Ok(None);
        };
        let index = index.value();
        let e = accessor::read_f32(&self.root, &self.buffers, index)
            .map_err(|m| self.err(element, format!("{name} accessor {index}: {m}")))?;
        if !comps.contains(&e.comps) {
            return Err(self.err(
                element,
                format!(
                    "{name} accessor {index} has {} components, expected {comps:?}",
                    e.comps
                ),
            ));
        }
        if let Some(v) = vertices {
            if e.count() != v {
                return Err(self.err(
                    element,
                    format!(
                        "{name} accessor {index} has {} elements but POSITION has {v}",
                        e.count()
                    ),
                ));
            }
        }
        Ok(Some(e))
    }

    /// The geometry of (mesh, primitive), built on first use.
    pub(super) fn geometry(&mut self, mesh: usize, p: usize) -> Result<Option<u32>, SceneError> {
        if let Some(&g) = self.geometry_of.get(&(mesh, p)) {
            return Ok(g);
        }
        let g = self.build_geometry(mesh, p)?;
        if let Some((g, _)) = &g {
            self.vertices += g.positions.len();
            self.triangles += g.triangle_count();
            self.check_geometry_budget(&format!("mesh {mesh} primitive {p}"), 0)?;
        }
        let index = g.map(|(g, bounds)| {
            self.scene.geometries.push(g);
            self.geometry_bounds.push(bounds);
            (self.scene.geometries.len() - 1) as u32
        });
        self.geometry_of.insert((mesh, p), index);
        Ok(index)
    }

    pub(super) fn build_geometry(
        &mut self,
        mesh: usize,
        p: usize,
    ) -> Result<Option<(Geometry, Aabb)>, SceneError> {
        use gj::mesh::{Mode, Semantic};
        let element = format!("mesh {mesh} primitive {p}");
        let prim = self.root.meshes[mesh].primitives[p].clone();
        let topology = match checked(&prim.mode) {
            Some(Mode::Triangles) => Topology::List,
            Some(Mode::TriangleStrip) => Topology::Strip,
            Some(Mode::TriangleFan) => Topology::Fan,
            Some(other) => {
                log::warn!(
                    "{}: {element}: skipping {other:?} primitive (rqr renders triangles only)",
                    self.file
                );
                return Ok(None);
            }
            None => return Err(self.err(&element, "invalid mode")),
        };
        let Some(pos) = self.attribute(&element, &prim, Semantic::Positions, &[3], None)? else {
            log::warn!(
                "{}: {element}: skipping primitive without POSITION",
                self.file
            );
            return Ok(None);
        };
        let vertex_count = pos.count();
        self.check_geometry_budget(&element, vertex_count)?;
        let mut bounds = Aabb::EMPTY;
        let mut positions = Vec::with_capacity(vertex_count);
        for (i, c) in pos.values.chunks_exact(3).enumerate() {
            let v = Vec3::from_slice(c);
            if !v.is_finite() {
                return Err(self.err(
                    &element,
                    format!("POSITION {i} is not finite ({}, {}, {})", c[0], c[1], c[2]),
                ));
            }
            bounds.grow(v);
            positions.push(v);
        }
        let seq: Vec<u32> = match prim.indices {
            Some(ix) => {
                let ix = ix.value();
                let indices = accessor::read_indices(&self.root, &self.buffers, ix)
                    .map_err(|m| self.err(&element, format!("indices accessor {ix}: {m}")))?;
                if let Some(bad) = indices.iter().find(|&&i| i as usize >= vertex_count) {
                    return Err(self.err(
                        &element,
                        format!("index {bad} out of range ({vertex_count} vertices)"),
                    ));
                }
                indices
            }
            None => (0..vertex_count as u32).collect(),
        };
        if topology == Topology::List && seq.len() % 3 != 0 {
            log::warn!(
                "{}: {element}: {} indices is not a multiple of 3; dropping the remainder",
                self.file,
                seq.len()
            );
        }
        let indices = triangulate(topology, &seq);
        let vc = Some(vertex_count);
        let normals = self.attribute(&element, &prim, Semantic::Normals, &[3], vc)?;
        let tangents = self.attribute(&element, &prim, Semantic::Tangents, &[4], vc)?;
        let colors = self.attribute(&element, &prim, Semantic::Colors(0), &[3, 4], vc)?;

        let chosen =
            variants::primitive_material(&prim, self.scene.variant, self.scene.variants.len())
                .map_err(|e| self.err(&element, e))?;
        let material = match chosen {
            Some(m) if m >= self.root.materials.len() => {
                return Err(self.err(
                    &element,
                    format!(
                        "material {m} does not exist ({} materials)",
                        self.root.materials.len()
                    ),
                ))
            }
            m => self.material(m)?,
        };
        let mat = &self.scene.materials[material as usize];
        let normal_map_uv = mat.normal_texture.map(|t| mat.stored_uv_set(t.tex_coord));
        let [set0, set1] = mat.uv_sets.map(Semantic::TexCoords);
        let uv0 = self.attribute(&element, &prim, set0, &[2], vc)?;
        let uv1 = self.attribute(&element, &prim, set1, &[2], vc)?;

        let mut g = Geometry {
            positions,
            indices,
            material,
            mesh,
            primitive: p,
            ..Default::default()
        };
        let mut fixed = 0usize;
        if let Some(n) = normals {
            g.normals = n
                .values
                .chunks_exact(3)
                .map(|c| {
                    let v = Vec3::from_slice(c);
                    match v.try_normalize() {
                        Some(u) => u,
                        None => {
                            fixed += 1;
                            Vec3::Z
                        }
                    }
                })
                .collect();
        }
        if let (Some(t), Some(_)) = (tangents, normal_map_uv) {
            g.tangents = t
                .values
                .chunks_exact(4)
                .map(|c| {
                    let v = Vec4::from_slice(c);
                    let xyz = v.truncate().try_normalize().unwrap_or_else(|| {
                        fixed += 1;
                        Vec3::X
                    });
                    xyz.extend(if v.w < 0.0 { -1.0 } else { 1.0 })
                })
                .collect();
        }
        let uv = |e: Option<Elements<f32>>, fixed: &mut usize| -> Vec<Vec2> {
            e.map(|e| {
                e.values
                    .chunks_exact(2)
                    .map(|c| {
                        let v = Vec2::from_slice(c);
                        if v.is_finite() {
                            v
                        } else {
                            *fixed += 1;
                            Vec2::ZERO
                        }
                    })
                    .collect()
            })
            .unwrap_or_default()
        };
        g.uv0 = uv(uv0, &mut fixed);
        g.uv1 = uv(uv1, &mut fixed);
        if let Some(c) = colors {
            let comps = c.comps;
            g.colors = c
                .values
                .chunks_exact(comps)
                .map(|c| {
                    let v = if comps == 3 {
                        Vec3::from_slice(c).extend(1.0)
                    } else {
                        Vec4::from_slice(c)
                    };
                    if v.is_finite() {
                        v
                    } else {
                        fixed += 1;
                        Vec4::ONE
                    }
                })
                .collect();
        }
        if fixed > 0 {
            log::warn!(
                "{}: {element}: replaced {fixed} zero-length or non-finite normal/tangent/uv/colour values",
                self.file
            );
        }
        if let Some((joints, weights)) = skin::read_vertex_skin(
            &self.file,
            &self.root,
            &self.buffers,
            &element,
            &prim,
            vertex_count,
        )? {
            g.joints = joints;
            g.weights = weights;
        }
        g.morph_targets = morph::read_morph_targets(
            &self.file,
            &self.root,
            &self.buffers,
            &element,
            &prim,
            vertex_count,
        )?;
        if g.normals.is_empty() {
            compute_flat_normals(&mut g);
        }
        if let Some(set) = normal_map_uv {
            if g.tangents.is_empty() && !compute_tangents(&mut g, set) {
                log::warn!(
                    "{}: {element}: cannot compute tangents for the normal map (TEXCOORD_{} missing or degenerate); the normal map is ignored",
                    self.file, self.scene.materials[material as usize].uv_sets[set as usize]
                );
            }
        }
        Ok(Some((g, bounds)))
    }
}
