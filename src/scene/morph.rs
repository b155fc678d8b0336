//! glTF morph targets (POSITION / NORMAL / TANGENT displacements) and the morph-target and
//! weight counts of meshes and nodes, read and validated at load time. Every error names the
//! file and the element (`mesh 0 primitive 2 target 1`, `node 4`).

use ::gltf::json as gj;
use glam::Vec3;

use super::accessor::{self, Buffers};
use super::error::SceneError;
use super::types::MorphTarget;

/// Most morph targets one mesh may have.
pub const MAX_MORPH_TARGETS: usize = 256;

/// Reads a primitive's morph targets (POSITION / NORMAL / TANGENT displacements).
pub(super) fn read_morph_targets(
    file: &str,
    root: &gj::Root,
    buffers: &Buffers,
    element: &str,
    prim: &gj::mesh::Primitive,
    vertices: usize,
) -> Result<Vec<MorphTarget>, SceneError> {
    let Some(targets) = &prim.targets else {
        return Ok(Vec::new());
    };
    if targets.len() > MAX_MORPH_TARGETS {
        return Err(SceneError::element(
            file,
            element,
            format!(
                "{} morph targets exceed rqr's limit of {MAX_MORPH_TARGETS}",
                targets.len()
            ),
        ));
    }
    let mut out = Vec::with_capacity(targets.len());
    for (t, target) in targets.iter().enumerate() {
        let read =
            |name: &str, index: Option<gj::Index<gj::Accessor>>| -> Result<Vec<Vec3>, SceneError> {
                let Some(index) = index else {
                    return Ok(Vec::new());
                };
                let index = index.value();
                let err = |m: String| {
                    SceneError::element(
                        file,
                        format!("{element} target {t}"),
                        format!("{name} accessor {index}: {m}"),
                    )
                };
                let e = accessor::read_f32(root, buffers, index).map_err(err)?;
                if e.comps != 3 || e.count() != vertices {
                    return Err(err(format!(
                        "has {} elements of {} components; expected {vertices} VEC3",
                        e.count(),
                        e.comps
                    )));
                }
                if let Some(k) = e.values.iter().position(|v| !v.is_finite()) {
                    return Err(err(format!("value {k} is not finite")));
                }
                Ok(e.values.chunks_exact(3).map(Vec3::from_slice).collect())
            };
        out.push(MorphTarget {
            positions: read("POSITION", target.positions)?,
            normals: read("NORMAL", target.normals)?,
            tangents: read("TANGENT", target.tangents)?,
        });
    }
    Ok(out)
}

/// Checks that every primitive of every mesh has the same number of morph targets, and that
/// mesh and node `weights` match it.
pub(super) fn check_morph_counts(file: &str, root: &gj::Root) -> Result<(), SceneError> {
    for (m, mesh) in root.meshes.iter().enumerate() {
        let counts: Vec<usize> = mesh
            .primitives
            .iter()
            .map(|p| p.targets.as_ref().map_or(0, Vec::len))
            .collect();
        if let Some(p) = counts.iter().position(|&c| c != counts[0]) {
            return Err(SceneError::element(
                file,
                format!("mesh {m} primitive {p}"),
                format!(
                    "has {} morph targets but primitive 0 has {} (all primitives of a mesh must have the same count)",
                    counts[p], counts[0]
                ),
            ));
        }
        let targets = counts.first().copied().unwrap_or(0);
        if let Some(w) = &mesh.weights {
            if w.len() != targets {
                return Err(SceneError::element(
                    file,
                    format!("mesh {m}"),
                    format!("has {} weights for {targets} morph targets", w.len()),
                ));
            }
        }
    }
    for (n, node) in root.nodes.iter().enumerate() {
        if let (Some(w), Some(mesh)) = (&node.weights, node.mesh) {
            let targets = super::animation::target_count(root, mesh.value());
            if w.len() != targets {
                return Err(SceneError::element(
                    file,
                    format!("node {n}"),
                    format!(
                        "has {} weights for mesh {}'s {targets} morph targets",
                        w.len(),
                        mesh.value()
                    ),
                ));
            }
        }
        if let Some(s) = node.skin {
            if s.value() >= root.skins.len() {
                return Err(SceneError::element(
                    file,
                    format!("node {n}"),
                    format!(
                        "skin {} does not exist ({} skins)",
                        s.value(),
                        root.skins.len()
                    ),
                ));
            }
        }
    }
    Ok(())
}
