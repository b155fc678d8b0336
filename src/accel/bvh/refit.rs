//! Refit of a built BVH after its geometry moved: the vertices of every bottom level and the
//! transforms of the instances change, the topology (which triangles sit in which leaf, which
//! nodes are whose children) stays, and the boxes of both levels are recomputed on the GPU.
//!
//! The first refit of a [`GpuBvh`] reads the node array back once and derives a `RefitPlan`
//! on the host: every node's level counted from the bottom (bottom levels first, then the top
//! level, whose leaves need the refitted bottom-level roots), the padding scale it belongs to,
//! and the three vertex indices of every leaf-order triangle. Each refit then uploads the new
//! positions and transforms and records, in one submission, one pass that copies the moved
//! vertices into the triangle array (`bvh_refit_triangles.comp`) and one dispatch per level
//! (`bvh_refit_nodes.comp`: one thread per node, no workgroup barriers) that rebuilds each
//! node's padded, quantized child boxes exactly as the builders do.
//!
//! A refit keeps the tree, so its quality decays as the geometry moves away from the shape it
//! was built for; [`RefitReport`] gives the SAH cost before and after so that a caller can
//! rebuild when the growth passes its threshold. Triangles left out at build time (degenerate
//! or non-finite then) stay out; rebuild when such triangles matter.

use glam::Vec3;

use super::cpu::world_to_object_rows;
use super::layout::{decode_link, BvhInstance, BvhNode, LINK_EMPTY};
use super::{sah, BvhError, GpuBvh, TLAS_ROOT};
use crate::interface::bvh::{BvhBuildPush as Push, BvhRefitRefs as GpuRefitRefs};
use crate::scene::Scene;
use crate::vk::{
    memory_barrier, vk, Buffer, ComputePipeline, Context, GpuProfiler, MemoryLocation,
};

/// SAH costs of a BVH before and after a refit (see [`super::sah`]), and the refit's GPU time.
#[derive(Clone, Debug, PartialEq)]
pub struct RefitReport {
    /// Summed SAH cost of the bottom levels before the refit.
    pub blas_sah_before: f64,
    /// ... and after it.
    pub blas_sah_after: f64,
    /// SAH cost of the top level before the refit.
    pub tlas_sah_before: f64,
    /// ... and after it.
    pub tlas_sah_after: f64,
    /// GPU milliseconds of the refit passes (`None` without timestamp support).
    pub gpu_ms: Option<f64>,
    /// Level dispatches recorded (bottom levels plus top level).
    pub levels: u32,
}

impl RefitReport {
    /// Largest relative SAH growth of either level (`0.05`: 5 % costlier). A caller rebuilds
    /// when this passes its threshold, since the refitted tree no longer suits the geometry.
    pub fn sah_growth(&self) -> f64 {
        let growth = |before: f64, after: f64| {
            if before > 0.0 {
                after / before - 1.0
            } else {
                0.0
            }
        };
        growth(self.blas_sah_before, self.blas_sah_after)
            .max(growth(self.tlas_sah_before, self.tlas_sah_after))
    }
}

/// Vertex positions that only the GPU has (the skinning pass's output in the scene's vertex
/// buffer), for [`GpuBvh::refit_device`].
pub struct DeviceVertices<'a> {
    /// Tightly packed `vec3` positions of every geometry (`GpuScene::positions`).
    pub positions: &'a Buffer,
    /// Per scene geometry: its first vertex in `positions`.
    pub first_vertex: Vec<u32>,
    /// Geometries whose bottom levels are refitted (the deformed ones); the others, and the
    /// top level, are not touched.
    pub geometries: Vec<usize>,
}

impl<'a> DeviceVertices<'a> {
    /// The vertex buffer of an uploaded scene (where the skinning pass writes), for the bottom
    /// levels of `geometries`.
    pub fn of_scene(gpu: &'a crate::scene::gpu::GpuScene, geometries: Vec<usize>) -> Self {
        Self {
            positions: &gpu.positions,
            first_vertex: gpu
                .geometry_records
                .iter()
                .map(|r| r.first_vertex)
                .collect(),
            geometries,
        }
    }
}

/// One refitted geometry: where its positions start in the position array.
struct RefitGeometry {
    geometry: usize,
    first_vertex: u32,
    vertices: usize,
    indices: usize,
}

/// What the refit derives once from a BVH's topology, with its device arrays.
pub(super) struct RefitPlan {
    geometries: Vec<RefitGeometry>,
    /// Per scene instance: geometry index and whether the top level holds it.
    instance_geometry: Vec<u32>,
    in_tlas: Vec<bool>,
    /// Host copy of the instance records (world-to-object rows are rewritten per refit).
    instances: Vec<BvhInstance>,
    /// `(first, count)` ranges of `order`, bottom level first.
    levels: Vec<(u32, u32)>,
    node_count: usize,
    /// Root node of each refitted bottom level, in `geometries` order.
    roots: Vec<u32>,
    /// The geometries a device plan was asked for (`DeviceVertices::geometries`).
    planned_for: Vec<usize>,
    /// Positions read from a device buffer ([`DeviceVertices`]): only the listed bottom
    /// levels are refitted and their padding scales computed on the GPU.
    device: bool,
    /// Refitted triangles (entries of `triangle_ids`).
    triangle_count: u32,
    /// Exact object box of each refitted bottom level after the last refit, in `geometries`
    /// order (device refits only: the top-level rebuild needs them).
    pub(super) root_bounds: Vec<(usize, obvhs::aabb::Aabb)>,
    blas_sah: f64,
    tlas_sah: f64,
    nodes_pass: std::sync::Arc<ComputePipeline>,
    triangles_pass: std::sync::Arc<ComputePipeline>,
    /// Host-written positions (`None` when they come from a device buffer).
    positions: Option<Buffer>,
    object_to_world: Buffer,
    scales: Buffer,
    status: Buffer,
    refs: Buffer,
    // Read by the shaders through `refs` only; kept alive here.
    _order: Buffer,
    _owner: Buffer,
    bounds: Buffer,
    _vertex_ids: Buffer,
    _triangle_ids: Buffer,
    _triangle_slots: Buffer,
}

fn refit_error(what: String) -> BvhError {
    BvhError::Refit(what)
}

/// Refuses `scene` unless its geometries have the vertex and index counts `bvh` was built with.
pub(super) fn check_scene_shape(bvh: &GpuBvh, scene: &Scene) -> Result<(), BvhError> {
    let shape = bvh.built_shape.as_ref().ok_or_else(|| {
        refit_error("the BVH was uploaded from host data without its scene".into())
    })?;
    if shape.len() != scene.geometries.len() {
        return Err(refit_error(format!(
            "the BVH was built for {} geometries, the scene has {}",
            shape.len(),
            scene.geometries.len()
        )));
    }
    for (g, (geom, &(vertices, indices))) in scene.geometries.iter().zip(shape).enumerate() {
        check_shape(g, geom, vertices, indices)?;
    }
    Ok(())
}

/// Refuses geometry `g` when its vertex or index count differs from the built one.
fn check_shape(
    g: usize,
    geom: &crate::scene::Geometry,
    vertices: usize,
    indices: usize,
) -> Result<(), BvhError> {
    if (geom.positions.len(), geom.indices.len()) == (vertices, indices) {
        return Ok(());
    }
    Err(refit_error(format!(
        "geometry {g} changed shape ({} vertices and {} indices, built with {vertices} and {indices})",
        geom.positions.len(),
        geom.indices.len(),
    )))
}

/// Summed SAH cost of the bottom levels rooted at `roots`.
fn roots_cost(nodes: &[BvhNode], roots: &[u32]) -> f64 {
    roots.iter().map(|&r| sah::subtree_cost(nodes, r)).sum()
}

/// SAH costs of the bottom levels and the top level of `nodes`.
fn costs(nodes: &[BvhNode], instances: &[BvhInstance], tlas_nodes: usize) -> (f64, f64) {
    let mut roots: Vec<u32> = instances
        .iter()
        .map(|i| i.blas_root)
        .filter(|&r| r as usize >= tlas_nodes && (r as usize) < nodes.len())
        .collect();
    roots.sort_unstable();
    roots.dedup();
    let blas = roots.iter().map(|&r| sah::subtree_cost(nodes, r)).sum();
    (blas, sah::subtree_cost(nodes, TLAS_ROOT))
}

impl RefitPlan {
    /// Plans a refit of every bottom level in the top level and of the top level, from the
    /// scene's positions (`device: None`), or of the bottom levels of `device.geometries` only,
    /// from positions on the device.
    fn new(
        ctx: &Context,
        bvh: &GpuBvh,
        scene: &Scene,
        device: Option<&DeviceVertices>,
    ) -> Result<Self, BvhError> {
        check_scene_shape(bvh, scene)?;
        let data = bvh.read_back(ctx)?;
        let nodes = &data.nodes;
        let tlas_nodes = data.stats.tlas_nodes;
        if data.instances.len() != scene.instances.len() {
            return Err(refit_error(format!(
                "the BVH was built for {} instances, the scene has {}",
                data.instances.len(),
                scene.instances.len()
            )));
        }
        // Heights (levels above the deepest child); both builders emit children after parents.
        let mut height = vec![0u32; nodes.len()];
        for i in (0..nodes.len()).rev() {
            for c in nodes[i].children() {
                if let Ok(child) = decode_link(c.link) {
                    if child as usize <= i || child as usize >= nodes.len() {
                        return Err(refit_error(format!(
                            "internal: node {i} links to node {child}"
                        )));
                    }
                    height[i] = height[i].max(height[child as usize] + 1);
                }
            }
        }
        // Bottom levels in use, in geometry order, each with its padding scale slot.
        let mut slot_of_geometry = vec![None; scene.geometries.len()];
        let mut in_tlas = vec![false; scene.instances.len()];
        for node in &nodes[..tlas_nodes] {
            for c in node.children() {
                if let Err((first, _)) = decode_link(c.link) {
                    in_tlas[first as usize] = true;
                }
            }
        }
        let mut roots: Vec<(usize, u32)> = Vec::new();
        for (i, rec) in data.instances.iter().enumerate() {
            let g = rec.geometry as usize;
            let selected = match device {
                None => in_tlas[i],
                Some(d) => {
                    d.geometries.contains(&g)
                        && (tlas_nodes..nodes.len()).contains(&(rec.blas_root as usize))
                }
            };
            if selected && slot_of_geometry[g].is_none() {
                slot_of_geometry[g] = Some(roots.len() as u32);
                roots.push((g, rec.blas_root));
            }
        }
        roots.sort_unstable();
        for (slot, &(g, _)) in roots.iter().enumerate() {
            slot_of_geometry[g] = Some(slot as u32);
        }
        let tlas_slot = roots.len() as u32;
        let mut geometries = Vec::with_capacity(roots.len());
        let mut first_vertex = 0u32;
        for &(g, _) in &roots {
            let geom = &scene.geometries[g];
            let first = match device {
                None => first_vertex,
                Some(d) => {
                    let first = *d.first_vertex.get(g).ok_or_else(|| {
                        refit_error(format!("geometry {g} has no first vertex on the device"))
                    })?;
                    let end = (first as u64 + geom.positions.len() as u64) * 12;
                    if end > d.positions.size() {
                        return Err(refit_error(format!(
                            "geometry {g}'s vertices end at byte {end} of a {}-byte position buffer",
                            d.positions.size()
                        )));
                    }
                    first
                }
            };
            geometries.push(RefitGeometry {
                geometry: g,
                first_vertex: first,
                vertices: geom.positions.len(),
                indices: geom.indices.len(),
            });
            first_vertex = u32::try_from(first_vertex as usize + geom.positions.len())
                .map_err(|_| BvhError::too_many("vertices"))?;
        }
        // Owner slots and vertex indices from a walk of every bottom level.
        let mut owner = vec![tlas_slot; nodes.len()];
        let mut used = vec![false; nodes.len()];
        // Per refitted triangle: leaf-order index, bottom-level slot, three vertex indices.
        let mut triangle_ids = Vec::new();
        let mut triangle_slots = Vec::new();
        let mut vertex_ids = Vec::new();
        let mut max_blas_height = 0;
        for (slot, &(g, root)) in roots.iter().enumerate() {
            let geom = &scene.geometries[g];
            let first_vertex = geometries[slot].first_vertex;
            max_blas_height = max_blas_height.max(height[root as usize]);
            let mut stack = vec![root];
            while let Some(n) = stack.pop() {
                owner[n as usize] = slot as u32;
                used[n as usize] = true;
                for c in nodes[n as usize].children() {
                    match decode_link(c.link) {
                        Ok(child) => stack.push(child),
                        Err((first, count)) => {
                            for t in first..first + count {
                                triangle_ids.push(t);
                                triangle_slots.push(slot as u32);
                                let p = data.triangles[t as usize].primitive as usize;
                                for k in 0..3 {
                                    let v = *geom.indices.get(3 * p + k).ok_or_else(|| {
                                        refit_error(format!(
                                            "geometry {g} has {} indices, triangle {p} is in the BVH",
                                            geom.indices.len()
                                        ))
                                    })?;
                                    if v as usize >= geom.positions.len() {
                                        return Err(refit_error(format!(
                                            "geometry {g}, triangle {p}: index {v} is out of range"
                                        )));
                                    }
                                    vertex_ids.push(first_vertex + v);
                                }
                            }
                        }
                    }
                }
            }
        }
        // Top-level nodes reachable from the root (a GPU-built top level leaves unused slots);
        // a device refit leaves the top level to a rebuild.
        let mut stack = match device {
            None => vec![TLAS_ROOT],
            Some(_) => Vec::new(),
        };
        while let Some(n) = stack.pop() {
            let node = &nodes[n as usize];
            used[n as usize] = node.links[0] != LINK_EMPTY;
            stack.extend(node.children().filter_map(|c| decode_link(c.link).ok()));
        }
        // Order: bottom levels by height, then the top level by height.
        let key = |i: usize| {
            if i < tlas_nodes {
                max_blas_height + 1 + height[i]
            } else {
                height[i]
            }
        };
        let mut by_level: Vec<Vec<u32>> = Vec::new();
        for i in (0..nodes.len()).filter(|&i| used[i]) {
            let k = key(i) as usize;
            if by_level.len() <= k {
                by_level.resize(k + 1, Vec::new());
            }
            by_level[k].push(i as u32);
        }
        let mut order = Vec::with_capacity(nodes.len());
        let mut levels = Vec::new();
        for level in by_level.iter().filter(|l| !l.is_empty()) {
            levels.push((order.len() as u32, level.len() as u32));
            order.extend_from_slice(level);
        }
        let root_nodes: Vec<u32> = roots.iter().map(|r| r.1).collect();
        let (blas_sah, tlas_sah) = match device {
            None => costs(nodes, &data.instances, tlas_nodes),
            Some(_) => (roots_cost(nodes, &root_nodes), 0.0),
        };

        let usage = vk::BufferUsageFlags::empty();
        let host = |name: &str, bytes: usize| {
            Buffer::new(ctx, name, bytes as u64, usage, MemoryLocation::CpuToGpu)
        };
        let order_buf = Buffer::from_slice(ctx, "bvh refit order", &order, usage)?;
        let owner_buf = Buffer::from_slice(ctx, "bvh refit owner", &owner, usage)?;
        let vertex_ids_buf = Buffer::from_slice(ctx, "bvh refit vertex ids", &vertex_ids, usage)?;
        let triangle_ids_buf =
            Buffer::from_slice(ctx, "bvh refit triangle ids", &triangle_ids, usage)?;
        let triangle_slots_buf =
            Buffer::from_slice(ctx, "bvh refit triangle slots", &triangle_slots, usage)?;
        let bounds = Buffer::new(
            ctx,
            "bvh refit bounds",
            24 * nodes.len() as u64,
            usage,
            MemoryLocation::GpuOnly,
        )?;
        let positions = match device {
            None => Some(host("bvh refit positions", 12 * first_vertex as usize)?),
            Some(_) => None,
        };
        let object_to_world = host("bvh refit object-to-world", 48 * scene.instances.len())?;
        let scales = host("bvh refit scales", 4 * (roots.len() + 1))?;
        let status = host("bvh refit status", 4)?;
        let mut refs = host("bvh refit refs", std::mem::size_of::<GpuRefitRefs>())?;
        let refs_data = GpuRefitRefs {
            nodes: bvh.nodes.address(),
            triangles: bvh.triangles.address(),
            bounds: bounds.address(),
            order: order_buf.address(),
            owner: owner_buf.address(),
            scales: scales.address(),
            instances: bvh.instances.address(),
            object_to_world: object_to_world.address(),
            positions: match (&positions, device) {
                (Some(p), _) => p.address(),
                (None, Some(d)) => d.positions.address(),
                (None, None) => unreachable!("host refits upload their positions"),
            },
            vertex_ids: vertex_ids_buf.address(),
            status: status.address(),
            triangle_ids: triangle_ids_buf.address(),
            triangle_slots: triangle_slots_buf.address(),
            tlas_nodes: tlas_nodes as u32,
            triangle_count: triangle_ids.len() as u32,
            gpu_scales: u32::from(device.is_some()),
            pad: 0,
        };
        refs.write(bytemuck::bytes_of(&refs_data))?;
        let push = std::mem::size_of::<Push>() as u32;
        use crate::shaders as s;
        Ok(Self {
            geometries,
            instance_geometry: data.instances.iter().map(|i| i.geometry).collect(),
            in_tlas,
            instances: data.instances.clone(),
            levels,
            node_count: nodes.len(),
            roots: root_nodes,
            planned_for: device.map(|d| d.geometries.clone()).unwrap_or_default(),
            device: device.is_some(),
            triangle_count: triangle_ids.len() as u32,
            root_bounds: Vec::new(),
            blas_sah,
            tlas_sah,
            nodes_pass: ComputePipeline::cached(
                ctx,
                "bvh refit nodes",
                s::BVH_REFIT_NODES_COMP,
                &[],
                push,
            )?,
            triangles_pass: ComputePipeline::cached(
                ctx,
                "bvh refit triangles",
                s::BVH_REFIT_TRIANGLES_COMP,
                &[],
                push,
            )?,
            positions,
            object_to_world,
            scales,
            status,
            refs,
            _order: order_buf,
            _owner: owner_buf,
            bounds,
            _vertex_ids: vertex_ids_buf,
            _triangle_ids: triangle_ids_buf,
            _triangle_slots: triangle_slots_buf,
        })
    }

    /// Checks that `scene` has the topology the plan was made for and writes its positions,
    /// transforms and padding scales into the upload buffers.
    fn upload(&mut self, scene: &Scene) -> Result<(), BvhError> {
        if scene.instances.len() != self.instance_geometry.len() {
            return Err(refit_error(format!(
                "the BVH was built for {} instances, the scene has {}",
                self.instance_geometry.len(),
                scene.instances.len()
            )));
        }
        if self.device {
            // Positions are on the device; the triangle pass takes the maxima into zeros.
            for (i, inst) in scene.instances.iter().enumerate() {
                if inst.geometry != self.instance_geometry[i] {
                    return Err(refit_error(format!(
                        "instance {i} now uses geometry {}, the BVH was built with {}",
                        inst.geometry, self.instance_geometry[i]
                    )));
                }
            }
            self.scales
                .write(&vec![0; 4 * (self.geometries.len() + 1)])?;
            self.status.write(&[0; 4])?;
            return Ok(());
        }
        let mut positions: Vec<f32> = Vec::new();
        let mut scales: Vec<f32> = Vec::with_capacity(self.geometries.len() + 1);
        let mut bounds = vec![(Vec3::INFINITY, Vec3::NEG_INFINITY); scene.geometries.len()];
        for rg in &self.geometries {
            let g = rg.geometry;
            let geom = scene.geometries.get(g).ok_or_else(|| {
                refit_error(format!("geometry {g} of the BVH is missing from the scene"))
            })?;
            check_shape(g, geom, rg.vertices, rg.indices)?;
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for (v, p) in geom.positions.iter().enumerate() {
                if !p.is_finite() {
                    return Err(refit_error(format!(
                        "geometry {g}, vertex {v}: position {p} is not finite"
                    )));
                }
                lo = lo.min(*p);
                hi = hi.max(*p);
                positions.extend_from_slice(&p.to_array());
            }
            bounds[g] = (lo, hi);
            scales.push(lo.abs().max(hi.abs()).max_element());
        }
        let mut rows: Vec<f32> = Vec::with_capacity(12 * scene.instances.len());
        let mut world = 0.0f32;
        for (i, inst) in scene.instances.iter().enumerate() {
            if inst.geometry != self.instance_geometry[i] {
                return Err(refit_error(format!(
                    "instance {i} now uses geometry {}, the BVH was built with {}",
                    inst.geometry, self.instance_geometry[i]
                )));
            }
            let m = inst.transform;
            rows.extend((0..3).flat_map(|r| m.row(r).to_array()));
            if !self.in_tlas[i] {
                continue;
            }
            let w2o = world_to_object_rows(&m).ok_or_else(|| {
                refit_error(format!(
                    "instance {i}: the new transform is singular or not finite"
                ))
            })?;
            self.instances[i].world_to_object = w2o;
            let (lo, hi) = bounds[inst.geometry as usize];
            for c in 0..8 {
                let p = Vec3::new(
                    if c & 1 == 0 { lo.x } else { hi.x },
                    if c & 2 == 0 { lo.y } else { hi.y },
                    if c & 4 == 0 { lo.z } else { hi.z },
                );
                world = world.max(m.transform_point3(p).abs().max_element());
            }
        }
        if !world.is_finite() {
            return Err(refit_error(
                "the moved instances' bounds are not finite".into(),
            ));
        }
        scales.push(world);
        if let Some(buffer) = &mut self.positions {
            buffer.write(bytemuck::cast_slice(&positions))?;
        }
        self.object_to_world.write(bytemuck::cast_slice(&rows))?;
        self.scales.write(bytemuck::cast_slice(&scales))?;
        self.status.write(&[0; 4])?;
        Ok(())
    }
}

impl GpuBvh {
    /// Refits this BVH to `scene`, the scene it was built from with moved vertices and/or
    /// changed instance transforms (same geometries, index buffers, instances and instance
    /// geometries): recomputes the boxes of every bottom level and of the top level on the
    /// GPU, keeping the tree (see the [`refit`](super::refit) module). Call it once per frame of an
    /// animation; rebuild instead when [`RefitReport::sah_growth`] passes your threshold.
    ///
    /// The first call reads the nodes back once to plan the refit; every call reads them back
    /// to report the SAH cost. Errors name the geometry, vertex or instance that does not fit
    /// (changed topology, non-finite positions, singular transforms).
    pub fn refit(&mut self, ctx: &Context, scene: &Scene) -> Result<RefitReport, BvhError> {
        let mut plan = match self.refit_plan.take() {
            Some(plan) => plan,
            None => Box::new(RefitPlan::new(ctx, self, scene, None)?),
        };
        let result = self.refit_with(ctx, scene, &mut plan);
        self.refit_plan = Some(plan);
        result
    }

    /// Refits the bottom levels of `vertices.geometries` to positions the GPU wrote (the
    /// skinning pass's output): the triangle copy reads them from `vertices.positions` and
    /// takes the padding scales on the GPU, so the host never sees the moved vertices. Static
    /// bottom levels and the top level are not touched: rebuild the top level afterwards
    /// ([`GpuBvh::rebuild_tlas_deformed`], which uses the refitted bottom levels' boxes). The
    /// report's SAH costs are those of the refitted bottom levels (top level: 0).
    ///
    /// `scene` gives the topology (index buffers, instance geometries), not the positions.
    /// The plan is made once (one read-back of the BVH) and kept across top-level rebuilds.
    pub fn refit_device(
        &mut self,
        ctx: &Context,
        scene: &Scene,
        vertices: &DeviceVertices,
    ) -> Result<RefitReport, BvhError> {
        let mut plan = match self.device_refit.take() {
            Some(plan) if plan.planned_for == vertices.geometries => plan,
            _ => Box::new(RefitPlan::new(ctx, self, scene, Some(vertices))?),
        };
        let result = self.refit_with(ctx, scene, &mut plan);
        self.device_refit = Some(plan);
        result
    }

    fn refit_with(
        &mut self,
        ctx: &Context,
        scene: &Scene,
        plan: &mut RefitPlan,
    ) -> Result<RefitReport, BvhError> {
        plan.upload(scene)?;
        if !plan.device {
            self.instances
                .upload(ctx, bytemuck::cast_slice(&plan.instances))?;
        }
        let mut profiler = if ctx.features().timestamps {
            Some(GpuProfiler::new(ctx, 4)?)
        } else {
            None
        };
        let refs = plan.refs.address();
        let triangles = plan.triangle_count;
        ctx.run("bvh refit", |cmd| {
            memory_barrier(ctx.device(), cmd);
            if let Some(p) = &mut profiler {
                p.reset(cmd);
                p.begin(cmd, "refit");
            }
            let push = Push { refs, a: 0, b: 0 };
            plan.triangles_pass.dispatch(
                cmd,
                None,
                bytemuck::bytes_of(&push),
                [triangles.div_ceil(256).max(1), 1, 1],
            );
            memory_barrier(ctx.device(), cmd);
            for &(first, count) in &plan.levels {
                let push = Push {
                    refs,
                    a: first,
                    b: count,
                };
                plan.nodes_pass.dispatch(
                    cmd,
                    None,
                    bytemuck::bytes_of(&push),
                    [count.div_ceil(64), 1, 1],
                );
                memory_barrier(ctx.device(), cmd);
            }
            if let Some(p) = &mut profiler {
                p.end(cmd);
            }
            Ok(())
        })?;
        let gpu_ms = match &profiler {
            Some(p) => Some(p.results()?.iter().map(|r| r.1).sum()),
            None => None,
        };
        let status = plan.status.read::<u32>(ctx)?.first().copied().unwrap_or(0);
        if status & 2 != 0 {
            return Err(refit_error(
                "a vertex written on the GPU (skinning output) is not finite".into(),
            ));
        }
        if status != 0 {
            return Err(refit_error(
                "moved bounds too large to quantize (beyond ~1e38)".into(),
            ));
        }
        let mut nodes: Vec<BvhNode> = self.nodes.read(ctx)?;
        nodes.truncate(plan.node_count);
        let (blas, tlas) = match plan.device {
            false => costs(&nodes, &plan.instances, self.stats.tlas_nodes),
            true => (roots_cost(&nodes, &plan.roots), 0.0),
        };
        if plan.device {
            let bounds: Vec<[f32; 6]> = plan.bounds.read(ctx)?;
            plan.root_bounds = plan
                .geometries
                .iter()
                .zip(&plan.roots)
                .map(|(g, &root)| {
                    let b = bounds[root as usize];
                    let mut aabb = obvhs::aabb::Aabb::empty();
                    aabb.extend(Vec3::new(b[0], b[1], b[2]).into());
                    aabb.extend(Vec3::new(b[3], b[4], b[5]).into());
                    (g.geometry, aabb)
                })
                .collect();
        }
        let report = RefitReport {
            blas_sah_before: plan.blas_sah,
            blas_sah_after: blas,
            tlas_sah_before: plan.tlas_sah,
            tlas_sah_after: tlas,
            gpu_ms,
            levels: plan.levels.len() as u32,
        };
        plan.blas_sah = blas;
        plan.tlas_sah = tlas;
        Ok(report)
    }
}
