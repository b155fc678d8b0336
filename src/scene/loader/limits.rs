//! Limits on the geometry a file may make the loader allocate.

use super::*;

impl Loader<'_> {
    /// Refuses a scene whose meshes declare more POSITION elements than
    /// [`MAX_SCENE_VERTICES`], from the JSON alone: many primitives sharing one large
    /// accessor are refused before any of them is expanded.
    pub(super) fn check_declared_vertices(&self, roots: &[usize]) -> Result<(), SceneError> {
        use gj::mesh::{Mode, Semantic};
        let nodes = &self.root.nodes;
        let mut seen = vec![false; nodes.len()];
        let mut used = vec![false; self.root.meshes.len()];
        let mut stack = roots.to_vec();
        while let Some(n) = stack.pop() {
            if std::mem::replace(&mut seen[n], true) {
                continue;
            }
            if let Some(m) = nodes[n].mesh.filter(|m| m.value() < used.len()) {
                used[m.value()] = true;
            }
            stack.extend(nodes[n].children.iter().flatten().map(|c| c.value()));
        }
        let mut vertices = 0usize;
        for (m, mesh) in self
            .root
            .meshes
            .iter()
            .enumerate()
            .filter(|(m, _)| used[*m])
        {
            for (p, prim) in mesh.primitives.iter().enumerate() {
                let triangles = matches!(
                    checked(&prim.mode),
                    Some(Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan)
                );
                let Some(index) = prim
                    .attributes
                    .get(&Checked::Valid(Semantic::Positions))
                    .map(|a| a.value())
                else {
                    continue;
                };
                let Some(acc) = self.root.accessors.get(index) else {
                    continue;
                };
                let count = acc.count.0;
                // An accessor beyond its own limits, or that its buffer view cannot hold,
                // gets a more precise error from the reader.
                let impossible = match acc.buffer_view {
                    None => count > accessor::MAX_UNBACKED_COUNT,
                    Some(v) => {
                        count > accessor::MAX_ACCESSOR_COUNT
                            || self
                                .root
                                .buffer_views
                                .get(v.value())
                                .is_none_or(|view| view.byte_length.0 < count)
                    }
                };
                if triangles && !impossible {
                    vertices = vertices.saturating_add(count as usize);
                }
                if vertices > MAX_SCENE_VERTICES {
                    return Err(self.err(
                        format!("mesh {m} primitive {p}"),
                        format!("POSITION accessor {index} brings the scene's meshes to {vertices} vertices, more than rqr's limit of {MAX_SCENE_VERTICES}"),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Fails when the scene's unique geometry, plus `more` vertices about to be read, exceeds
    /// [`MAX_SCENE_VERTICES`] or [`MAX_SCENE_TRIANGLES`].
    pub(super) fn check_geometry_budget(
        &self,
        element: &str,
        more: usize,
    ) -> Result<(), SceneError> {
        let vertices = self.vertices.saturating_add(more);
        if vertices > MAX_SCENE_VERTICES {
            return Err(self.err(
                element,
                format!("the scene's meshes reach {vertices} vertices, more than rqr's limit of {MAX_SCENE_VERTICES}"),
            ));
        }
        if self.triangles > MAX_SCENE_TRIANGLES {
            return Err(self.err(
                element,
                format!(
                    "the scene's meshes reach {} triangles, more than rqr's limit of {MAX_SCENE_TRIANGLES}",
                    self.triangles
                ),
            ));
        }
        Ok(())
    }
}
