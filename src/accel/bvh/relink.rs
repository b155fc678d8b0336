//! Rebuild of some bottom levels of a built BVH, keeping the others: an animation's deformed
//! geometry is built again once its refitted trees degraded, and static geometry is never
//! built again.
//!
//! The bottom levels to rebuild are built alone (from a scene holding only their geometries,
//! with the chosen builder); the node and triangle arrays are then put together again on the
//! host: the top-level region as it was, then every bottom level in geometry order, the kept
//! ones copied from the current arrays and the rebuilt ones from the new build, each with its
//! inner links and leaf triangle offsets shifted to its new place. Both builders emit each
//! bottom level as one contiguous run of nodes (depth-first pre-order) and of triangles, so a
//! shifted copy keeps its layout. The top level is then rebuilt over the new roots.

use glam::Mat4;

use super::layout::{decode_link, leaf_link, BvhNode, BvhTriangle, LINK_EMPTY};
use super::{gpu_build, BvhBuild, BvhBuildOptions, BvhData, BvhError, BvhStats, GpuBvh};
use crate::scene::{Geometry, Scene};
use crate::vk::{vk, Buffer, Context};

/// One bottom level's runs in its arrays: nodes `nodes.0..nodes.1` (root first), triangles
/// `tris.0..tris.1`.
struct Run {
    nodes: (u32, u32),
    tris: (u32, u32),
}

fn internal(what: String) -> BvhError {
    BvhError::InvalidScene(format!("internal: {what}"))
}

/// The runs of the bottom level rooted at `root`; refuses one that is not contiguous.
fn run_of(data: &BvhData, root: u32) -> Result<Run, BvhError> {
    let (mut node_count, mut node_max) = (0u32, root);
    let (mut tri_min, mut tri_max, mut tri_count) = (u32::MAX, 0u32, 0u32);
    let mut stack = vec![root];
    while let Some(n) = stack.pop() {
        let node = data
            .nodes
            .get(n as usize)
            .ok_or_else(|| internal(format!("bottom-level node {n} is out of range")))?;
        node_count += 1;
        node_max = node_max.max(n);
        for c in node.children() {
            match decode_link(c.link) {
                Ok(child) if child <= root => {
                    return Err(internal(format!("node {n} links back to node {child}")))
                }
                Ok(child) => stack.push(child),
                Err((first, count)) => {
                    tri_min = tri_min.min(first);
                    tri_max = tri_max.max(first + count);
                    tri_count += count;
                }
            }
        }
    }
    let tri_min = tri_min.min(tri_max);
    if node_max + 1 - root != node_count || tri_max - tri_min != tri_count {
        return Err(internal(format!(
            "the bottom level at node {root} is not contiguous ({node_count} nodes in \
             {root}..={node_max}, {tri_count} triangles in {tri_min}..{tri_max})"
        )));
    }
    Ok(Run {
        nodes: (root, node_max + 1),
        tris: (tri_min, tri_max),
    })
}

/// Appends the bottom level `run` of `data` to `nodes` and `triangles` with its links shifted;
/// returns its new root.
fn append_run(
    data: &BvhData,
    run: &Run,
    nodes: &mut Vec<BvhNode>,
    triangles: &mut Vec<BvhTriangle>,
) -> Result<u32, BvhError> {
    let node_base = u32::try_from(nodes.len()).map_err(|_| BvhError::too_many("nodes"))?;
    let tri_base = u32::try_from(triangles.len()).map_err(|_| BvhError::too_many("triangles"))?;
    for n in &data.nodes[run.nodes.0 as usize..run.nodes.1 as usize] {
        let mut n = *n;
        for link in &mut n.links {
            if *link == LINK_EMPTY {
                continue;
            }
            *link = match decode_link(*link) {
                Ok(child) => node_base + (child - run.nodes.0),
                Err((first, count)) => leaf_link(tri_base + (first - run.tris.0), count)
                    .ok_or_else(|| BvhError::too_many("triangles"))?,
            };
        }
        nodes.push(n);
    }
    triangles.extend_from_slice(&data.triangles[run.tris.0 as usize..run.tris.1 as usize]);
    Ok(node_base)
}

/// Per geometry: the root of its bottom level in `data` (`None`: it has none).
fn roots(data: &BvhData, geometries: usize) -> Vec<Option<u32>> {
    let tlas = data.stats.tlas_nodes;
    let mut roots = vec![None; geometries];
    for rec in &data.instances {
        let r = rec.blas_root as usize;
        if let Some(slot) = roots.get_mut(rec.geometry as usize) {
            if (tlas..data.nodes.len()).contains(&r) {
                *slot = Some(rec.blas_root);
            }
        }
    }
    roots
}

/// A scene holding only `rebuild`'s geometries (the others empty), each placed once with an
/// identity transform: what the builders need to build just those bottom levels.
fn sub_scene(scene: &Scene, rebuild: &[usize]) -> Scene {
    let geometries = scene
        .geometries
        .iter()
        .enumerate()
        .map(|(g, geom)| match rebuild.contains(&g) {
            true => geom.clone(),
            false => Geometry {
                material: geom.material,
                ..Default::default()
            },
        })
        .collect();
    let instances = rebuild
        .iter()
        .filter_map(|&g| {
            let mut inst = *scene.instances.iter().find(|i| i.geometry as usize == g)?;
            inst.transform = Mat4::IDENTITY;
            Some(inst)
        })
        .collect();
    Scene {
        source: scene.source.clone(),
        geometries,
        instances,
        materials: scene.materials.clone(),
        ..Default::default()
    }
}

impl GpuBvh {
    /// Builds the bottom levels of `rebuild` (geometry indices) again from their positions in
    /// `scene` with `build`, keeps every other bottom level as it is (copied, never built),
    /// and rebuilds the top level for `scene`'s instances (see the module docs).
    /// `scene` must be the scene this BVH was built from, posed (same geometries and
    /// instances). Returns the build statistics of the rebuilt bottom levels alone.
    pub fn rebuild_bottom_levels(
        &mut self,
        ctx: &Context,
        scene: &Scene,
        rebuild: &[usize],
        opts: &BvhBuildOptions,
        build: BvhBuild,
    ) -> Result<BvhStats, BvhError> {
        super::refit::check_scene_shape(self, scene)?;
        if let Some(&g) = rebuild.iter().find(|&&g| g >= scene.geometries.len()) {
            return Err(BvhError::InvalidScene(format!(
                "geometry {g} to rebuild is not in the scene ({} geometries)",
                scene.geometries.len()
            )));
        }
        let old = self.read_back(ctx)?;
        let sub = sub_scene(scene, rebuild);
        let built = match build {
            BvhBuild::Host => BvhData::build(&sub, opts)?,
            BvhBuild::Gpu => gpu_build::build(ctx, &sub, opts)?.read_back(ctx)?,
        };
        let count = scene.geometries.len();
        let (old_roots, new_roots) = (roots(&old, count), roots(&built, count));
        let tlas_nodes = old.stats.tlas_nodes;
        let mut nodes: Vec<BvhNode> = old.nodes[..tlas_nodes].to_vec();
        let mut triangles: Vec<BvhTriangle> = Vec::with_capacity(old.triangles.len());
        let mut roots: Vec<Option<u32>> = vec![None; count];
        for (g, root) in roots.iter_mut().enumerate() {
            let (source, from) = match rebuild.contains(&g) {
                true => (&built, new_roots[g]),
                false => (&old, old_roots[g]),
            };
            if let Some(r) = from {
                *root = Some(append_run(
                    source,
                    &run_of(source, r)?,
                    &mut nodes,
                    &mut triangles,
                )?);
            }
        }
        let mut instances = old.instances.clone();
        for rec in &mut instances {
            rec.blas_root = roots[rec.geometry as usize].unwrap_or(0);
        }
        let data = BvhData {
            nodes,
            triangles,
            instances,
            stats: old.stats.clone(),
        };
        super::check_fits(&ctx.info().memory_heaps, data.byte_size(), "exact")?;
        let usage = vk::BufferUsageFlags::empty();
        let nodes = Buffer::from_slice(ctx, "bvh nodes", &data.nodes, usage)?;
        let triangles = Buffer::from_slice(ctx, "bvh triangles", &data.triangles, usage)?;
        self.instances
            .upload(ctx, bytemuck::cast_slice(&data.instances))?;
        self.refs_data.nodes = nodes.address();
        self.refs_data.triangles = triangles.address();
        self.refs_data.node_count = data.nodes.len() as u32;
        self.refs_data.triangle_count = data.triangles.len() as u32;
        self.refs.write(bytemuck::bytes_of(&self.refs_data))?;
        self.nodes = nodes;
        self.triangles = triangles;
        // Depth and stack: the deeper of the kept and the rebuilt bottom levels (a bound).
        let blas_stack = |s: &BvhStats| s.max_stack.saturating_sub(s.tlas_stack);
        let stats = &mut self.stats;
        stats.max_blas_depth = stats.max_blas_depth.max(built.stats.max_blas_depth);
        stats.max_stack = stats.tlas_stack + blas_stack(stats).max(blas_stack(&built.stats));
        stats.node_count = data.nodes.len();
        stats.triangle_count = data.triangles.len();
        stats.blas_count = roots.iter().flatten().count();
        stats.bytes = data.byte_size();
        self.refit_plan = None;
        self.device_refit = None;
        self.rebuild_tlas(ctx, scene, opts)?;
        Ok(built.stats)
    }
}
