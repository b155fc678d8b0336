//! The scene's raster draws, one per instance: what both visibility rasterizers (the graphics
//! pipeline of [`super::gbuffer`] and the compute rasterizer of [`super::raster_compute`])
//! draw.

use crate::scene::Scene;

/// One draw per scene instance.
#[derive(Clone, Copy, Debug)]
pub struct Draw {
    /// Scene instance index (push constant).
    pub instance: u32,
    /// 3 × triangles.
    pub vertex_count: u32,
    /// Back-face culling (single-sided material).
    pub cull_back: bool,
    /// Mirrored transform: clockwise triangles are front-facing.
    pub mirrored: bool,
    /// Alpha-MASK material: drawn with the alpha-testing pipeline.
    pub alpha_test: bool,
    /// World-space centre of the instance's bounds (front-to-back ordering).
    pub center: glam::Vec3,
}

/// Per-instance draws of a scene, in instance order.
pub fn draws(scene: &Scene) -> Vec<Draw> {
    scene
        .instances
        .iter()
        .enumerate()
        .filter_map(|(i, inst)| {
            let g = scene.geometries.get(inst.geometry as usize)?;
            let material = scene.materials.get(g.material as usize);
            let double_sided = material.is_some_and(|m| m.double_sided);
            let mut bounds = crate::scene::Aabb::EMPTY;
            for p in &g.positions {
                bounds.grow(inst.transform.transform_point3(*p));
            }
            (g.triangle_count() > 0).then(|| Draw {
                instance: i as u32,
                vertex_count: (g.triangle_count() * 3) as u32,
                cull_back: !double_sided,
                mirrored: inst.flips_winding(),
                alpha_test: material.is_some_and(|m| m.alpha_mode == crate::scene::AlphaMode::Mask),
                center: bounds.center(),
            })
        })
        .collect()
}
