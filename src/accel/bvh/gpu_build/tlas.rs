//! The top level built on the GPU, by the same passes as a bottom level: each instance's world
//! box (the box of its transformed bottom-level box, computed on the host in O(instances))
//! becomes one input "triangle" `(min, max, min)` whose box is exactly that box, with the
//! instance index as its primitive; the passes build with one instance per leaf, and
//! `bvh_build_tlas_links.comp` copies the result to the front of the node array, turning each
//! leaf link into a direct instance link. [`GpuBvh::rebuild_tlas`] redoes this whenever the
//! instance transforms change.

use std::time::Instant;

use obvhs::aabb::Aabb as ObAabb;

use super::passes::TlasLinksPush;
use super::{Builder, GpuBuildPhases};
use crate::accel::bvh::builder::{self, GeometryTris};
use crate::accel::bvh::layout::{BvhInstance, BvhNode, BvhTriangle, BVH_STACK_SIZE};
use crate::accel::bvh::{BvhBuildOptions, BvhError, GpuBvh};
use crate::scene::Scene;
use crate::vk::{vk, Buffer, Context, MemoryLocation};

/// Node slots reserved for the top level at the front of the node array: a 4-wide tree over
/// `n` leaves has at most one node per binary inner node (`n - 1`), or one node in all.
pub fn tlas_region(instances: usize) -> usize {
    instances.saturating_sub(1).max(1)
}

/// Shape of a top level built on the GPU.
pub(in crate::accel::bvh) struct BuiltTlas {
    /// Nodes on the longest path.
    pub depth: u32,
    /// Most stack entries a traversal of it can hold.
    pub stack: u32,
    /// GPU time of its passes.
    pub phases: GpuBuildPhases,
}

/// Builds the top level over `boxes` (world boxes of the instances `ids`, union `world`) on
/// the GPU into `nodes[0..region]`.
pub(in crate::accel::bvh) fn build_tlas_gpu(
    ctx: &Context,
    nodes: &Buffer,
    region: usize,
    boxes: &[ObAabb],
    ids: &[u32],
    world: ObAabb,
    opts: &BvhBuildOptions,
) -> Result<BuiltTlas, BvhError> {
    let n = boxes.len();
    if n == 0 {
        nodes.upload(ctx, bytemuck::bytes_of(&BvhNode::EMPTY))?;
        return Ok(BuiltTlas {
            depth: 1,
            stack: 0,
            phases: GpuBuildPhases::default(),
        });
    }
    ctx.check_memory(
        "the GPU top-level build (scratch)",
        super::scratch_bytes(n) + (n * std::mem::size_of::<BvhTriangle>()) as u64,
    )?;
    let gt = GeometryTris {
        tris: boxes
            .iter()
            .zip(ids)
            .map(|(b, &id)| {
                let (min, max) = (b.min.to_array(), b.max.to_array());
                BvhTriangle {
                    v0: min,
                    v1: max,
                    v2: min,
                    primitive: id,
                }
            })
            .collect(),
        aabbs: boxes.to_vec(),
        bounds: world,
    };
    let leaves = Buffer::new(
        ctx,
        "bvh tlas leaves",
        (n * std::mem::size_of::<BvhTriangle>()) as u64,
        vk::BufferUsageFlags::empty(),
        MemoryLocation::GpuOnly,
    )?;
    let mut builder = Builder::new(ctx, n, leaves.address(), opts, 1)?;
    let built = builder.build_blas(&gt, 0)?;
    if built.node_count as usize > region {
        return Err(BvhError::Refit(format!(
            "the top level needs {} nodes, the BVH has room for {region} (a host-built BVH \
             reserves only its own top level)",
            built.node_count
        )));
    }
    builder.run("bvh build: top level", |b, cmd| {
        b.begin(cmd, "relocate");
        let push = TlasLinksPush {
            src: built.nodes.address(),
            dst: nodes.address(),
            leaves: leaves.address(),
            count: built.node_count,
            pad: 0,
        };
        b.p.tlas_links.dispatch(
            cmd,
            None,
            bytemuck::bytes_of(&push),
            [built.node_count.div_ceil(256), 1, 1],
        );
    })?;
    Ok(BuiltTlas {
        depth: built.depth,
        stack: built.stack,
        phases: builder.phases,
    })
}

impl GpuBvh {
    /// Rebuilds the top level on the GPU for the current instance transforms of `scene` (the
    /// scene this BVH was built from: same geometries and instances, each instance on the same
    /// geometry), keeping every bottom level; call it whenever instance transforms change.
    /// Instances whose transform became singular are left out, as in a build. Updates
    /// [`Self::stats`] (`tlas_ms`, depth, stack, `gpu_phases.tlas_ms`). A host-built BVH
    /// reserved room only for its own top level; a larger new one is refused (build with
    /// [`BvhBuild::Gpu`](crate::accel::bvh::BvhBuild::Gpu) to rebuild the top level freely).
    pub fn rebuild_tlas(
        &mut self,
        ctx: &Context,
        scene: &Scene,
        opts: &BvhBuildOptions,
    ) -> Result<(), BvhError> {
        self.rebuild_tlas_with(ctx, scene, opts, &[])
    }

    /// [`Self::rebuild_tlas`] after [`GpuBvh::refit_device`]: the bottom levels that refit
    /// moved are bounded by their refitted root boxes (read back by the refit), since
    /// `scene` does not hold the positions the GPU wrote; the other geometries by their
    /// positions in `scene`.
    pub fn rebuild_tlas_deformed(
        &mut self,
        ctx: &Context,
        scene: &Scene,
        opts: &BvhBuildOptions,
    ) -> Result<(), BvhError> {
        let known = self
            .device_refit
            .as_ref()
            .map(|p| p.root_bounds.clone())
            .unwrap_or_default();
        self.rebuild_tlas_with(ctx, scene, opts, &known)
    }

    /// Rebuilds the top level with the object boxes `known` (geometry, box) and, for every
    /// other geometry with a bottom level, the box of its positions in `scene`.
    fn rebuild_tlas_with(
        &mut self,
        ctx: &Context,
        scene: &Scene,
        opts: &BvhBuildOptions,
        known: &[(usize, ObAabb)],
    ) -> Result<(), BvhError> {
        let t_start = Instant::now();
        crate::accel::bvh::refit::check_scene_shape(self, scene)?;
        let mut records: Vec<BvhInstance> = self.instances.read(ctx)?;
        records.truncate(self.refs_data.instance_count as usize);
        for (i, (rec, inst)) in records.iter().zip(&scene.instances).enumerate() {
            if rec.geometry != inst.geometry {
                return Err(BvhError::Refit(format!(
                    "instance {i} now uses geometry {}, the BVH was built with {}",
                    inst.geometry, rec.geometry
                )));
            }
        }
        let input = builder::scene_input(scene)?;
        // Object bounds of every geometry with a bottom level (from all its positions: a
        // conservative superset of its usable triangles).
        let tlas_nodes = self.stats.tlas_nodes;
        let mut blas_bounds: Vec<Option<ObAabb>> = vec![None; scene.geometries.len()];
        for &(g, b) in known {
            if let Some(slot) = blas_bounds.get_mut(g) {
                *slot = Some(b);
            }
        }
        for rec in &records {
            let g = rec.geometry as usize;
            if (rec.blas_root as usize) < tlas_nodes || blas_bounds[g].is_some() {
                continue;
            }
            let mut b = ObAabb::empty();
            for p in &scene.geometries[g].positions {
                b.extend((*p).into());
            }
            blas_bounds[g] = Some(b);
        }
        for (rec, w2o) in records.iter_mut().zip(&input.w2o) {
            rec.world_to_object = w2o.unwrap_or([[0.0; 4]; 3]);
        }
        let mut stats = self.stats.clone();
        stats.skipped_instances = input.skipped_instances;
        let (boxes, ids, world) = builder::instance_boxes(scene, &input, &blas_bounds, &mut stats);
        let built = build_tlas_gpu(ctx, &self.nodes, tlas_nodes, &boxes, &ids, world, opts)?;
        let blas_stack = self.stats.max_stack.saturating_sub(self.stats.tlas_stack);
        if built.stack + blas_stack > BVH_STACK_SIZE {
            return Err(BvhError::TooDeep {
                entries: built.stack + blas_stack,
                limit: BVH_STACK_SIZE,
            });
        }
        self.instances.upload(ctx, bytemuck::cast_slice(&records))?;
        stats.tlas_depth = built.depth;
        stats.tlas_stack = built.stack;
        stats.max_stack = built.stack + blas_stack;
        stats.max_depth = built.depth + stats.max_blas_depth;
        stats.tlas_ms = t_start.elapsed().as_secs_f64() * 1e3;
        if let Some(phases) = &mut stats.gpu_phases {
            phases.tlas_ms = built.phases.total_ms();
        }
        self.stats = stats;
        // The top level's topology changed: the next refit plans again (a device refit's
        // plan covers bottom levels only and stays).
        self.refit_plan = None;
        Ok(())
    }
}
