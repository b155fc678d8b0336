//! glTF skins (joints and inverse bind matrices) and per-vertex joints and weights, read and
//! validated at load time (morph targets are in `morph`). Every error names the file and the
//! element (`skin 1`, `mesh 0 primitive 2`, `node 4 (skin 1)`).

use ::gltf::json as gj;
use gj::validation::Checked;
use glam::Mat4;

use super::accessor::{self, Buffers};
use super::error::SceneError;

/// Influences per vertex rqr keeps: JOINTS_0/WEIGHTS_0 and JOINTS_1/WEIGHTS_1.
pub const INFLUENCES: usize = 8;

/// Most joints one skin may have.
pub const MAX_JOINTS: usize = 1 << 16;

/// A glTF skin.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Skin {
    /// glTF node of each joint.
    pub joints: Vec<usize>,
    /// Inverse bind matrix of each joint (identity when the file has none).
    pub inverse_bind: Vec<Mat4>,
}

/// Reads and validates every skin of the file.
pub(super) fn parse_skins(
    file: &str,
    root: &gj::Root,
    buffers: &Buffers,
) -> Result<Vec<Skin>, SceneError> {
    let mut skins = Vec::with_capacity(root.skins.len());
    for (s, js) in root.skins.iter().enumerate() {
        let el = format!("skin {s}");
        let err = |m: String| SceneError::element(file, &el, m);
        if js.joints.is_empty() {
            return Err(err("has no joints".into()));
        }
        if js.joints.len() > MAX_JOINTS {
            return Err(err(format!(
                "{} joints exceed rqr's limit of {MAX_JOINTS}",
                js.joints.len()
            )));
        }
        let mut joints = Vec::with_capacity(js.joints.len());
        for (j, node) in js.joints.iter().enumerate() {
            let n = node.value();
            if n >= root.nodes.len() {
                return Err(err(format!(
                    "joint {j} is node {n}, which does not exist ({} nodes)",
                    root.nodes.len()
                )));
            }
            joints.push(n);
        }
        if let Some(sk) = js.skeleton {
            if sk.value() >= root.nodes.len() {
                return Err(err(format!(
                    "skeleton node {} does not exist ({} nodes)",
                    sk.value(),
                    root.nodes.len()
                )));
            }
        }
        let inverse_bind = match js.inverse_bind_matrices {
            None => vec![Mat4::IDENTITY; joints.len()],
            Some(a) => {
                let a = a.value();
                let e = accessor::read_f32(root, buffers, a)
                    .map_err(|m| err(format!("inverseBindMatrices accessor {a}: {m}")))?;
                if e.comps != 16 {
                    return Err(err(format!(
                        "inverseBindMatrices accessor {a} has {} components, expected MAT4",
                        e.comps
                    )));
                }
                if e.count() != joints.len() {
                    return Err(err(format!(
                        "inverseBindMatrices accessor {a} has {} matrices for {} joints",
                        e.count(),
                        joints.len()
                    )));
                }
                let mats: Vec<Mat4> = e
                    .values
                    .chunks_exact(16)
                    .map(Mat4::from_cols_slice)
                    .collect();
                if let Some(j) = mats.iter().position(|m| !m.is_finite()) {
                    return Err(err(format!("inverse bind matrix {j} is not finite")));
                }
                mats
            }
        };
        skins.push(Skin {
            joints,
            inverse_bind,
        });
    }
    Ok(skins)
}

/// Per-vertex joints and weights of a primitive: JOINTS_n/WEIGHTS_n for n = 0, 1, padded
/// with zero weights. Weights that do not sum to 1 are normalized (one warning per
/// primitive). `None` when the primitive has no JOINTS_0.
#[allow(clippy::type_complexity)]
pub(super) fn read_vertex_skin(
    file: &str,
    root: &gj::Root,
    buffers: &Buffers,
    element: &str,
    prim: &gj::mesh::Primitive,
    vertices: usize,
) -> Result<Option<(Vec<[u32; INFLUENCES]>, Vec<[f32; INFLUENCES]>)>, SceneError> {
    use gj::mesh::Semantic;
    let err = |m: String| SceneError::element(file, element, m);
    let mut joints = Vec::new();
    let mut weights = Vec::new();
    for set in 0..2u32 {
        let j = prim.attributes.get(&Checked::Valid(Semantic::Joints(set)));
        let w = prim.attributes.get(&Checked::Valid(Semantic::Weights(set)));
        let (j, w) = match (j, w) {
            (None, None) => break,
            (Some(j), Some(w)) => (j.value(), w.value()),
            _ => {
                return Err(err(format!(
                    "JOINTS_{set} and WEIGHTS_{set} must come together"
                )))
            }
        };
        let read = |name: &str, index: usize| {
            let e = accessor::read_f32(root, buffers, index)
                .map_err(|m| err(format!("{name}_{set} accessor {index}: {m}")))?;
            if e.comps != 4 || e.count() != vertices {
                return Err(err(format!(
                    "{name}_{set} accessor {index} has {} elements of {} components; expected {vertices} VEC4",
                    e.count(),
                    e.comps
                )));
            }
            Ok(e.values)
        };
        joints.push(read("JOINTS", j)?);
        weights.push(read("WEIGHTS", w)?);
    }
    if joints.is_empty() {
        return Ok(None);
    }
    let mut out_joints = vec![[0u32; INFLUENCES]; vertices];
    let mut out_weights = vec![[0f32; INFLUENCES]; vertices];
    let mut normalized = 0usize;
    for v in 0..vertices {
        for (set, (js, ws)) in joints.iter().zip(&weights).enumerate() {
            for c in 0..4 {
                let (joint, weight) = (js[v * 4 + c], ws[v * 4 + c]);
                if !(weight.is_finite() && weight >= 0.0) {
                    return Err(err(format!(
                        "WEIGHTS_{set} of vertex {v} is {weight}, not a non-negative number"
                    )));
                }
                if !(joint >= 0.0 && joint.fract() == 0.0) {
                    return Err(err(format!(
                        "JOINTS_{set} of vertex {v} is {joint}, not a joint index"
                    )));
                }
                out_joints[v][set * 4 + c] = joint as u32;
                out_weights[v][set * 4 + c] = weight;
            }
        }
        let sum: f32 = out_weights[v].iter().sum();
        if (sum - 1.0).abs() > 2e-3 {
            normalized += 1;
            if sum > 0.0 {
                out_weights[v].iter_mut().for_each(|w| *w /= sum);
            } else {
                out_weights[v] = [0.0; INFLUENCES];
                out_weights[v][0] = 1.0;
            }
        }
    }
    if normalized > 0 {
        log::warn!(
            "{file}: {element}: the skin weights of {normalized} vertices do not sum to 1; normalized"
        );
    }
    Ok(Some((out_joints, out_weights)))
}

/// Fails when a vertex of `element` names a joint beyond `skin`'s joint count.
pub(super) fn check_joint_range(
    file: &str,
    element: &str,
    joints: &[[u32; INFLUENCES]],
    weights: &[[f32; INFLUENCES]],
    skin_index: usize,
    skin: &Skin,
) -> Result<(), SceneError> {
    let count = skin.joints.len() as u32;
    for (v, (js, ws)) in joints.iter().zip(weights).enumerate() {
        for (j, w) in js.iter().zip(ws) {
            // A zero weight may carry any index (exporters pad with 0 or junk): unused.
            if *j >= count && *w > 0.0 {
                return Err(SceneError::element(
                    file,
                    element,
                    format!("vertex {v} uses joint {j}, but skin {skin_index} has {count} joints"),
                ));
            }
        }
    }
    Ok(())
}
