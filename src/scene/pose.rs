//! A scene's rig and its pose at a time: the node hierarchy, node transforms from the
//! animations, joint matrices of the skins and morph weights. What posing does to the scene's
//! geometry, cameras and lights is in `deform`.

use ::gltf::json as gj;
use glam::{Mat4, Quat, Vec3};

use super::animation::{Animation, Property};
use super::skin::Skin;

/// A node's rest transform.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LocalTransform {
    /// Translation, rotation, scale (animatable).
    Trs(Vec3, Quat, Vec3),
    /// A matrix (glTF forbids animating such nodes; a channel on one animates its
    /// decomposition).
    Matrix(Mat4),
}

/// One glTF node as posing needs it.
#[derive(Clone, Debug, PartialEq)]
pub struct RigNode {
    /// Parent through which the chosen scene first reached the node.
    pub parent: Option<usize>,
    /// Rest transform.
    pub rest: LocalTransform,
    /// Skin of the node's mesh.
    pub skin: Option<usize>,
    /// Rest morph weights (node weights, else mesh weights, else zeros).
    pub weights: Vec<f32>,
}

/// Node hierarchy, skins and animations of a glTF scene.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Rig {
    /// Every glTF node, indexed like the file's.
    pub nodes: Vec<RigNode>,
    /// Nodes the chosen scene reaches, parents before children.
    pub order: Vec<usize>,
    /// Skins.
    pub skins: Vec<Skin>,
    /// Animations.
    pub animations: Vec<Animation>,
    /// Per scene instance: its transform relative to its node (EXT_mesh_gpu_instancing).
    pub instance_local: Vec<Mat4>,
    /// Node of each scene camera.
    pub camera_nodes: Vec<usize>,
    /// Node of each scene light (empty with the default light rig).
    pub light_nodes: Vec<usize>,
}

/// Node transforms and morph weights at one time.
#[derive(Clone, Debug, PartialEq)]
pub struct Pose {
    /// World transform per node (identity for nodes the scene does not reach).
    pub world: Vec<Mat4>,
    /// Morph weights per node.
    pub weights: Vec<Vec<f32>>,
}

/// The rest nodes of a glTF file (no animation applied). Parents are filled by the loader's
/// traversal.
pub(super) fn rest_nodes(root: &gj::Root) -> Vec<RigNode> {
    root.nodes
        .iter()
        .map(|n| {
            let rest = match n.matrix {
                Some(m) => LocalTransform::Matrix(Mat4::from_cols_array(&m)),
                None => LocalTransform::Trs(
                    Vec3::from(n.translation.unwrap_or([0.0; 3])),
                    n.rotation
                        .map_or(Quat::IDENTITY, |q| Quat::from_array(q.0))
                        .normalize(),
                    Vec3::from(n.scale.unwrap_or([1.0; 3])),
                ),
            };
            let mesh = n.mesh.map(|m| m.value());
            let targets = mesh.map_or(0, |m| super::animation::target_count(root, m));
            let weights = n
                .weights
                .clone()
                .or_else(|| mesh.and_then(|m| root.meshes.get(m)?.weights.clone()))
                .filter(|w| w.len() == targets)
                .unwrap_or_else(|| vec![0.0; targets]);
            RigNode {
                parent: None,
                rest,
                skin: n.skin.map(|s| s.value()),
                weights,
            }
        })
        .collect()
}

impl Rig {
    /// Whether anything can move: an animation, or a skin or morph target to pose.
    pub fn is_animated(&self) -> bool {
        !self.animations.is_empty()
    }

    /// Node transforms and weights at `time` seconds with animations `animations` applied
    /// (later animations win where two drive the same property).
    pub fn pose(&self, animations: &[usize], time: f32) -> Pose {
        let mut trs: Vec<(Vec3, Quat, Vec3)> = Vec::with_capacity(self.nodes.len());
        let mut animated = vec![false; self.nodes.len()];
        for node in &self.nodes {
            trs.push(match node.rest {
                LocalTransform::Trs(t, r, s) => (t, r, s),
                LocalTransform::Matrix(m) => {
                    let (s, r, t) = m.to_scale_rotation_translation();
                    (t, r, s)
                }
            });
        }
        let mut weights: Vec<Vec<f32>> = self.nodes.iter().map(|n| n.weights.clone()).collect();
        let mut value = Vec::new();
        for &a in animations {
            let anim = &self.animations[a];
            for ch in &anim.channels {
                let sampler = &anim.samplers[ch.sampler];
                value.resize(sampler.width, 0.0);
                sampler.sample(time, ch.property == Property::Rotation, &mut value);
                let n = ch.node;
                animated[n] = true;
                match ch.property {
                    Property::Translation => trs[n].0 = Vec3::from_slice(&value),
                    Property::Rotation => trs[n].1 = Quat::from_slice(&value),
                    Property::Scale => trs[n].2 = Vec3::from_slice(&value),
                    Property::Weights => {
                        let w = &mut weights[n];
                        let k = w.len().min(value.len());
                        w[..k].copy_from_slice(&value[..k]);
                    }
                }
            }
        }
        let mut world = vec![Mat4::IDENTITY; self.nodes.len()];
        for &n in &self.order {
            let node = &self.nodes[n];
            let local = match (node.rest, animated[n]) {
                (LocalTransform::Matrix(m), false) => m,
                _ => {
                    let (t, r, s) = trs[n];
                    Mat4::from_scale_rotation_translation(s, r, t)
                }
            };
            let parent = node.parent.map_or(Mat4::IDENTITY, |p| world[p]);
            world[n] = parent * local;
        }
        Pose { world, weights }
    }

    /// Skinning matrices of skin `skin` (joint world × inverse bind), which take bind-space
    /// vertices to world space.
    pub fn joint_matrices(&self, skin: usize, pose: &Pose) -> Vec<Mat4> {
        let s = &self.skins[skin];
        s.joints
            .iter()
            .zip(&s.inverse_bind)
            .map(|(&j, ibm)| pose.world[j] * *ibm)
            .collect()
    }
}
