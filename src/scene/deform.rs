//! Posing a scene at a time: instance, camera and light transforms from the animated nodes,
//! and the CPU skinning and morphing of geometry, the reference the GPU pass
//! (`render::passes::skin`) is tested against.

use glam::{Mat3, Mat4, Vec3, Vec4};

use super::animation::{AnimationSelection, Property};
use super::camera::camera_pose;
use super::error::SceneError;
use super::pose::Pose;
use super::types::{Aabb, Geometry, Scene};

/// Skinned or morphed vertex attributes of one geometry.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Deformed {
    /// Positions.
    pub positions: Vec<Vec3>,
    /// Unit normals.
    pub normals: Vec<Vec3>,
    /// Tangents (unit xyz, w = handedness); empty when the geometry has none.
    pub tangents: Vec<Vec4>,
}

/// The normal matrix of `m`: its cofactor matrix, signed so that a mirroring `m` keeps
/// normals pointing out (equals the inverse transpose up to a positive scale; stays defined
/// when `m` is singular).
pub fn normal_matrix(m: &Mat3) -> Mat3 {
    let cof = Mat3::from_cols(
        m.y_axis.cross(m.z_axis),
        m.z_axis.cross(m.x_axis),
        m.x_axis.cross(m.y_axis),
    );
    if m.determinant() < 0.0 {
        -cof
    } else {
        cof
    }
}

/// CPU skinning and morphing of `g`: morph targets with `weights` first, then linear blend
/// skinning with `joints` (skinning matrices; `None`: the geometry is not skinned). Normals
/// go through the blended matrix's [`normal_matrix`], tangents through the matrix itself;
/// both are renormalized. The reference the GPU pass is tested against.
pub fn deform(g: &Geometry, joints: Option<&[Mat4]>, weights: &[f32]) -> Deformed {
    let n = g.positions.len();
    let mut out = Deformed {
        positions: g.positions.clone(),
        normals: g.normals.clone(),
        tangents: g.tangents.clone(),
    };
    for (t, w) in g.morph_targets.iter().zip(weights) {
        if *w == 0.0 {
            continue;
        }
        for (p, d) in out.positions.iter_mut().zip(&t.positions) {
            *p += *w * *d;
        }
        for (p, d) in out.normals.iter_mut().zip(&t.normals) {
            *p += *w * *d;
        }
        for (p, d) in out.tangents.iter_mut().zip(&t.tangents) {
            *p += (*w * *d).extend(0.0);
        }
    }
    let skin = joints.filter(|_| g.joints.len() == n && g.weights.len() == n);
    for v in 0..n {
        let m = match skin {
            Some(mats) => blend(mats, &g.joints[v], &g.weights[v]),
            None => Mat4::IDENTITY,
        };
        let m3 = Mat3::from_mat4(m);
        out.positions[v] = m.transform_point3(out.positions[v]);
        if let Some(nrm) = out.normals.get_mut(v) {
            *nrm = (normal_matrix(&m3) * *nrm).normalize_or(Vec3::Z);
        }
        if let Some(t) = out.tangents.get_mut(v) {
            *t = (m3 * t.truncate()).normalize_or(Vec3::X).extend(t.w);
        }
    }
    out
}

/// Σ weight × joint matrix over a vertex's influences (zero-weight influences are skipped,
/// so their joint index may be anything).
fn blend(mats: &[Mat4], joints: &[u32; 8], weights: &[f32; 8]) -> Mat4 {
    let mut m = Mat4::ZERO;
    for (j, w) in joints.iter().zip(weights) {
        if *w > 0.0 {
            if let Some(jm) = mats.get(*j as usize) {
                m += *jm * *w;
            }
        }
    }
    m
}

impl Scene {
    /// Adds `geometry` (built for the index of `material`) made of `material` at `transform`,
    /// under a rig node of its own that no scene root reaches, so that posing an animated
    /// scene leaves it where it is (a floor or a prop added to a loaded file). `bounds` stays
    /// the file's, which callers place the object by.
    pub fn add_still_object(
        &mut self,
        material: super::types::Material,
        geometry: impl FnOnce(u32) -> Geometry,
        transform: Mat4,
    ) {
        let material_index = self.materials.len() as u32;
        self.materials.push(material);
        let geometry_index = self.geometries.len() as u32;
        self.geometries.push(geometry(material_index));
        let node = self.rig.nodes.len();
        self.rig.nodes.push(super::pose::RigNode {
            parent: None,
            rest: super::pose::LocalTransform::Matrix(Mat4::IDENTITY),
            skin: None,
            weights: Vec::new(),
        });
        self.rig.instance_local.push(transform);
        self.instances.push(super::types::Instance {
            geometry: geometry_index,
            transform,
            node,
        });
    }

    /// Indices of the animations `selection` plays, or an error naming the file.
    pub fn select_animations(
        &self,
        selection: &AnimationSelection,
    ) -> Result<Vec<usize>, SceneError> {
        selection.resolve(&self.source, &self.rig.animations)
    }

    /// Length in seconds of the selected animations (the latest last key).
    pub fn animation_duration(&self, animations: &[usize]) -> f32 {
        animations
            .iter()
            .map(|&a| self.rig.animations[a].duration())
            .fold(0.0, f32::max)
    }

    /// Whether [`Scene::posed`] can change anything: the file has animations, skins or
    /// morph targets.
    pub fn is_animated(&self) -> bool {
        self.rig.is_animated()
            || (!self.rig.instance_local.is_empty()
                && self
                    .instances
                    .iter()
                    .any(|i| self.geometries[i.geometry as usize].is_deformable()))
    }

    /// Whether animations `animations` move anything but cameras: an instance's node or an
    /// ancestor, a joint of a skinned instance (or its ancestors), a light, or morph weights.
    /// Sequences whose animation moves only the camera keep reusing samples between frames.
    pub fn animation_moves_geometry(&self, animations: &[usize]) -> bool {
        let nodes = &self.rig.nodes;
        let mut animated = vec![false; nodes.len()];
        for &a in animations {
            for ch in &self.rig.animations[a].channels {
                if ch.property == Property::Weights {
                    return true;
                }
                animated[ch.node] = true;
            }
        }
        // Parents were checked acyclic by the loader; the step bound is only a safeguard.
        let moved = |mut n: usize| {
            for _ in 0..=nodes.len() {
                if animated[n] {
                    return true;
                }
                match nodes[n].parent {
                    Some(p) => n = p,
                    None => return false,
                }
            }
            false
        };
        let instance_moves = self.instances.iter().any(|inst| {
            let joints_move = nodes[inst.node]
                .skin
                .is_some_and(|s| self.rig.skins[s].joints.iter().any(|&j| moved(j)));
            moved(inst.node) || joints_move
        });
        let light_moves = !self.default_lights && self.rig.light_nodes.iter().any(|&n| moved(n));
        instance_moves || light_moves
    }

    /// Skinning matrices and morph weights of instance `k` at `pose`: `(joints, weights)`;
    /// joints is `None` when the instance is not skinned.
    pub fn instance_deformation<'p>(
        &self,
        k: usize,
        pose: &'p Pose,
    ) -> (Option<Vec<Mat4>>, &'p [f32]) {
        let inst = &self.instances[k];
        let g = &self.geometries[inst.geometry as usize];
        let skin = self.rig.nodes[inst.node]
            .skin
            .filter(|_| !g.joints.is_empty());
        (
            skin.map(|s| self.rig.joint_matrices(s, pose)),
            &pose.weights[inst.node],
        )
    }

    /// The scene at `time` seconds of the animations `animations` (indices, see
    /// [`Scene::select_animations`]): instance, camera and light transforms from the
    /// animated nodes; skinned and morphed geometry deformed on the CPU (skinned instances
    /// get world-space vertices and an identity transform, as glTF ignores the skinned mesh
    /// node's own transform). A deformed geometry that several instances share is copied
    /// per instance. Scenes without a rig come back unchanged.
    pub fn posed(&self, animations: &[usize], time: f32) -> Scene {
        let mut out = self.clone();
        if self.rig.nodes.is_empty() || self.rig.instance_local.len() != self.instances.len() {
            return out;
        }
        let pose = self.rig.pose(animations, time);
        let mut users = vec![0usize; self.geometries.len()];
        for i in &self.instances {
            users[i.geometry as usize] += 1;
        }
        for k in 0..self.instances.len() {
            let inst = self.instances[k];
            let g = &self.geometries[inst.geometry as usize];
            let (joints, weights) = self.instance_deformation(k, &pose);
            out.instances[k].transform = match joints {
                Some(_) => Mat4::IDENTITY,
                None => pose.world[inst.node] * self.rig.instance_local[k],
            };
            if !g.is_deformable() {
                continue;
            }
            let d = deform(g, joints.as_deref(), weights);
            let mut posed = Geometry {
                positions: d.positions,
                normals: d.normals,
                tangents: d.tangents,
                ..g.clone()
            };
            // Posed vertices are final: posing them again must not deform them twice.
            posed.joints.clear();
            posed.weights.clear();
            posed.morph_targets.clear();
            if users[inst.geometry as usize] == 1 {
                out.geometries[inst.geometry as usize] = posed;
            } else {
                out.geometries.push(posed);
                out.instances[k].geometry = (out.geometries.len() - 1) as u32;
            }
        }
        for (cam, &n) in out.cameras.iter_mut().zip(&self.rig.camera_nodes) {
            cam.camera_to_world = camera_pose(pose.world[n]);
        }
        if !self.default_lights {
            for (light, &n) in out.lights.iter_mut().zip(&self.rig.light_nodes) {
                light.position = pose.world[n].transform_point3(Vec3::ZERO);
                light.direction = pose.world[n]
                    .transform_vector3(Vec3::NEG_Z)
                    .normalize_or(Vec3::NEG_Z);
            }
        }
        for (slot, w) in out.node_world.iter_mut().zip(&pose.world) {
            if slot.is_some() {
                *slot = Some(*w);
            }
        }
        let mut bounds = Aabb::EMPTY;
        for inst in &out.instances {
            for p in &out.geometries[inst.geometry as usize].positions {
                bounds.grow(inst.transform.transform_point3(*p));
            }
        }
        out.bounds = bounds;
        out
    }
}
