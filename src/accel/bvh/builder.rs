//! Host build of the two-level BVH with `obvhs` (PLOC + reinsertion + SAH leaf collapse) and
//! flattening of the binary tree into the 4-wide quantized node layout of [`super::layout`].

use std::time::Instant;

use glam::{Vec3, Vec3A};
use obvhs::aabb::Aabb as ObAabb;
use obvhs::bvh2::leaf_collapser::collapse;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::bvh2::Bvh2;
use obvhs::ploc::{PlocBuilder, PlocSearchDistance, SortPrecision};

use super::cpu::world_to_object_rows;
use super::layout::{
    decode_link, leaf_link, BvhBox, BvhChild, BvhInstance, BvhNode, BvhTriangle,
    BVH_INSTANCE_ALPHA_TEST, BVH_STACK_SIZE, LINK_EMPTY, LINK_FIRST_MASK, MAX_LEAF_PRIMITIVES,
};
use super::{BvhBuildOptions, BvhData, BvhError, BvhStats, PlocSearch};
use crate::scene::{AlphaMode, Scene};

/// Relative padding of every box: slab distances come from `fma(p, inv_d, -o * inv_d)` whose
/// rounding can put a vertex lying exactly on a box face a few ulps outside it; growing boxes
/// by ~8 ulps of their coordinates plus ~1e-6 of the level's extent keeps the box test
/// conservative for ray origins up to ~10x the scene's size away (see README).
const PAD_RELATIVE: f32 = 1.0 / (1 << 20) as f32;

fn pad_box(b: &ObAabb, scale: f32) -> BvhBox {
    let (min, max) = (Vec3::from(b.min), Vec3::from(b.max));
    let m = min.abs().max(max.abs());
    let pad = (m + Vec3::splat(scale)) * PAD_RELATIVE;
    BvhBox {
        min: (min - pad).to_array(),
        max: (max + pad).to_array(),
    }
}

fn search(s: PlocSearch) -> PlocSearchDistance {
    match s {
        PlocSearch::Minimum => PlocSearchDistance::Minimum,
        PlocSearch::Low => PlocSearchDistance::Low,
        PlocSearch::Medium => PlocSearchDistance::Medium,
        PlocSearch::High => PlocSearchDistance::High,
    }
}

/// PLOC, reinsertion, SAH collapse into leaves of at most `max_leaf`, reinsertion again.
fn build_bvh2(aabbs: &[ObAabb], opts: &BvhBuildOptions, max_leaf: u32) -> Bvh2 {
    let mut bvh = PlocBuilder::with_capacity(aabbs.len()).build(
        search(opts.search),
        aabbs,
        (0..aabbs.len() as u32).collect(),
        SortPrecision::U64,
        opts.search_depth_threshold,
    );
    let mut reinsertion = ReinsertionOptimizer::default();
    if opts.reinsertion_ratio > 0.0 {
        reinsertion.run(&mut bvh, opts.reinsertion_ratio, None);
    }
    if max_leaf > 1 {
        collapse(&mut bvh, max_leaf, opts.collapse_traversal_cost);
        if opts.reinsertion_ratio > 0.0 {
            reinsertion.run(&mut bvh, opts.reinsertion_ratio * 2.0, None);
        }
    }
    bvh
}

/// Shape of a flattened level: root node, levels of 4-wide nodes on the longest path, and
/// the most stack entries a traversal of it can hold.
struct Flattened {
    root: u32,
    depth: u32,
    stack: u32,
}

/// The children of binary node `src` gathered into one 4-wide node: the inner child with the
/// largest surface area is opened until there are four (or only leaves remain).
fn open_children(bvh: &Bvh2, src: usize) -> Vec<usize> {
    let first = bvh.nodes[src].first_index as usize;
    let mut kids = vec![first, first + 1];
    while kids.len() < 4 {
        let Some((pos, _)) = kids
            .iter()
            .enumerate()
            .filter(|(_, &k)| !bvh.nodes[k].is_leaf())
            .max_by(|a, b| {
                let area = |i: usize| bvh.nodes[i].aabb().half_area();
                area(*a.1).total_cmp(&area(*b.1))
            })
        else {
            break;
        };
        let f = bvh.nodes[kids[pos]].first_index as usize;
        kids.splice(pos..=pos, [f, f + 1]);
    }
    kids
}

/// Appends the flattened form of `bvh` to `nodes`. `leaf(prims)` turns a leaf's primitives
/// (values of `bvh.primitive_indices`) into a link. A root that is itself a leaf gets a node of
/// its own with one child.
fn flatten(
    bvh: &Bvh2,
    scale: f32,
    nodes: &mut Vec<BvhNode>,
    leaf: &mut dyn FnMut(&[u32]) -> Result<u32, BvhError>,
) -> Result<Flattened, BvhError> {
    let node_index = |len: usize| u32::try_from(len).map_err(|_| BvhError::too_many("nodes"));
    let root = node_index(nodes.len())?;
    let quantize = |children: &[BvhChild]| {
        BvhNode::new(children).map_err(|_| {
            BvhError::InvalidScene("bounds too large to quantize (beyond ~1e38)".into())
        })
    };
    let mut child = |src: usize| -> Result<(BvhChild, bool), BvhError> {
        let n = &bvh.nodes[src];
        let inner = !n.is_leaf();
        let link = if inner {
            u32::MAX // patched when the child node is emitted
        } else {
            let first = n.first_index as usize;
            leaf(&bvh.primitive_indices[first..first + n.prim_count as usize])?
        };
        let bounds = pad_box(n.aabb(), scale);
        Ok((BvhChild { bounds, link }, inner))
    };
    if bvh.nodes[0].is_leaf() {
        let (c, _) = child(0)?;
        nodes.push(quantize(&[c])?);
        return Ok(Flattened {
            root,
            depth: 1,
            stack: 0,
        });
    }
    // Depth-first pre-order: a node is followed by its first subtree, so the path a coherent
    // ray takes stays in neighbouring cache lines. Entries: (source node, parent slot, depth,
    // stack entries pushed above it).
    type Pending = (usize, Option<(usize, usize)>, u32, u32);
    let mut out = Flattened {
        root,
        depth: 1,
        stack: 0,
    };
    let mut stack: Vec<Pending> = vec![(0, None, 1, 0)];
    while let Some((src, parent, depth, pushed)) = stack.pop() {
        out.depth = out.depth.max(depth);
        let index = nodes.len();
        if let Some((p, k)) = parent {
            nodes[p].links[k] = node_index(index)?;
        }
        let kids = open_children(bvh, src);
        let mut children = Vec::with_capacity(kids.len());
        let mut inner = Vec::new();
        for (k, &c) in kids.iter().enumerate() {
            let (record, is_inner) = child(c)?;
            children.push(record);
            if is_inner {
                inner.push((c, k));
            }
        }
        nodes.push(quantize(&children)?);
        // A visit pushes every hit child but the nearest.
        let pushed = pushed + kids.len() as u32 - 1;
        out.stack = out.stack.max(pushed);
        for &(c, k) in inner.iter().rev() {
            stack.push((c, Some((index, k)), depth + 1, pushed));
        }
    }
    Ok(out)
}

/// One geometry's usable triangles: exact vertex copies with their original primitive index.
pub(super) struct GeometryTris {
    /// Usable triangles in index order.
    pub tris: Vec<BvhTriangle>,
    /// Their boxes.
    pub aabbs: Vec<ObAabb>,
    /// Union of the boxes.
    pub bounds: ObAabb,
}

pub(super) fn gather_geometry(scene: &Scene, g: usize) -> Result<GeometryTris, BvhError> {
    let geom = &scene.geometries[g];
    if geom.indices.len() % 3 != 0 {
        return Err(BvhError::InvalidScene(format!(
            "geometry {g}: {} indices is not a multiple of 3",
            geom.indices.len()
        )));
    }
    let n = geom.indices.len() / 3;
    let mut out = GeometryTris {
        tris: Vec::with_capacity(n),
        aabbs: Vec::with_capacity(n),
        bounds: ObAabb::empty(),
    };
    for (prim, idx) in geom.indices.chunks_exact(3).enumerate() {
        let mut v = [Vec3::ZERO; 3];
        for k in 0..3 {
            v[k] = *geom.positions.get(idx[k] as usize).ok_or_else(|| {
                BvhError::InvalidScene(format!(
                    "geometry {g}, triangle {prim}: index {} is out of range ({} positions)",
                    idx[k],
                    geom.positions.len()
                ))
            })?;
        }
        // Non-finite vertices cannot be bounded and repeated vertices cannot be hit by the
        // watertight test (zero determinant): neither can change any ray's result.
        if !v.iter().all(|p| p.is_finite()) || v[0] == v[1] || v[1] == v[2] || v[0] == v[2] {
            continue;
        }
        let a: [Vec3A; 3] = v.map(Vec3A::from);
        let bb = ObAabb::from_points(&a);
        out.bounds = out.bounds.union(&bb);
        out.aabbs.push(bb);
        out.tris.push(BvhTriangle {
            v0: v[0].to_array(),
            v1: v[1].to_array(),
            v2: v[2].to_array(),
            primitive: prim as u32,
        });
    }
    Ok(out)
}

pub(super) fn max_abs(b: &ObAabb) -> f32 {
    b.min.abs().max(b.max.abs()).max_element()
}

/// What both builders need from the scene before building: which geometries are used by an
/// instance with an invertible transform, the world-to-object rows of every instance, and
/// which geometries are alpha tested.
pub(super) struct SceneInput {
    /// Per geometry: used by at least one instance with an invertible transform.
    pub used: Vec<bool>,
    /// Per instance: world-to-object rows (`None`: singular or non-finite transform).
    pub w2o: Vec<Option<[[f32; 4]; 3]>>,
    /// Per geometry: alpha MASK material.
    pub alpha: Vec<bool>,
    /// Instances left out (singular or non-finite transform).
    pub skipped_instances: usize,
}

/// Validates instance and material references and collects [`SceneInput`].
pub(super) fn scene_input(scene: &Scene) -> Result<SceneInput, BvhError> {
    let mut input = SceneInput {
        used: vec![false; scene.geometries.len()],
        w2o: Vec::with_capacity(scene.instances.len()),
        alpha: vec![false; scene.geometries.len()],
        skipped_instances: 0,
    };
    for (i, inst) in scene.instances.iter().enumerate() {
        let g = inst.geometry as usize;
        if g >= scene.geometries.len() {
            return Err(BvhError::InvalidScene(format!(
                "instance {i} uses geometry {g}, but the scene has {}",
                scene.geometries.len()
            )));
        }
        let rows = world_to_object_rows(&inst.transform);
        if rows.is_some() {
            input.used[g] = true;
        } else {
            input.skipped_instances += 1;
        }
        input.w2o.push(rows);
    }
    if scene.instances.len() > LINK_FIRST_MASK as usize + 1 {
        return Err(BvhError::too_many("instances"));
    }
    for (g, geom) in scene.geometries.iter().enumerate() {
        if !input.used[g] {
            continue;
        }
        let mat = scene.materials.get(geom.material as usize).ok_or_else(|| {
            BvhError::InvalidScene(format!(
                "geometry {g} uses material {}, but the scene has {}",
                geom.material,
                scene.materials.len()
            ))
        })?;
        input.alpha[g] = mat.alpha_mode == AlphaMode::Mask;
    }
    Ok(input)
}

/// World boxes of the instances whose geometry has a bottom level (`blas_bounds[g]`: object
/// bounds of geometry `g`): each the box of the transformed corners of its object box. Returns
/// the boxes, their instance indices and their union; counts instances whose box is not finite
/// in `stats.skipped_instances`.
pub(super) fn instance_boxes(
    scene: &Scene,
    input: &SceneInput,
    blas_bounds: &[Option<ObAabb>],
    stats: &mut BvhStats,
) -> (Vec<ObAabb>, Vec<u32>, ObAabb) {
    let mut inst_aabbs = Vec::new();
    let mut inst_ids = Vec::new();
    let mut world = ObAabb::empty();
    for (i, inst) in scene.instances.iter().enumerate() {
        let (Some(_), Some(b)) = (input.w2o[i], blas_bounds[inst.geometry as usize]) else {
            continue;
        };
        let mut wb = ObAabb::empty();
        for c in 0..8 {
            let p = Vec3::new(
                if c & 1 == 0 { b.min.x } else { b.max.x },
                if c & 2 == 0 { b.min.y } else { b.max.y },
                if c & 4 == 0 { b.min.z } else { b.max.z },
            );
            wb.extend(inst.transform.transform_point3(p).into());
        }
        if !(wb.min.is_finite() && wb.max.is_finite()) {
            stats.skipped_instances += 1;
            continue;
        }
        world = world.union(&wb);
        inst_aabbs.push(wb);
        inst_ids.push(i as u32);
    }
    (inst_aabbs, inst_ids, world)
}

/// Builds and flattens the top level over the instances whose geometry has a bottom level
/// (`blas_bounds[g]`: object bounds of geometry `g`'s bottom level). Returns the nodes (root
/// first) and the most stack entries a traversal of it can hold; fills the top-level stats.
pub(super) fn build_tlas(
    scene: &Scene,
    input: &SceneInput,
    blas_bounds: &[Option<ObAabb>],
    opts: &BvhBuildOptions,
    stats: &mut BvhStats,
) -> Result<(Vec<BvhNode>, u32), BvhError> {
    let t_tlas = Instant::now();
    let (inst_aabbs, inst_ids, world) = instance_boxes(scene, input, blas_bounds, stats);
    let mut nodes: Vec<BvhNode> = Vec::new();
    let mut tlas_stack = 0;
    if inst_aabbs.is_empty() {
        nodes.push(BvhNode::EMPTY);
        stats.tlas_depth = 1;
    } else {
        let tlas = build_bvh2(&inst_aabbs, opts, 1);
        let scale = max_abs(&world);
        let shape = flatten(&tlas, scale, &mut nodes, &mut |prims| {
            // Top-level leaves hold exactly one instance (max leaf size 1), addressed directly.
            let [p] = prims else {
                return Err(BvhError::InvalidScene(
                    "internal: top-level leaf with several instances".into(),
                ));
            };
            leaf_link(inst_ids[*p as usize], 1).ok_or_else(|| BvhError::too_many("instances"))
        })?;
        stats.tlas_depth = shape.depth;
        tlas_stack = shape.stack;
    }
    stats.tlas_nodes = nodes.len();
    stats.tlas_ms = t_tlas.elapsed().as_secs_f64() * 1e3;
    Ok((nodes, tlas_stack))
}

/// One [`BvhInstance`] per scene instance; `blas_roots[g]` is the absolute root node of
/// geometry `g`'s bottom level.
pub(super) fn instance_records(
    scene: &Scene,
    input: &SceneInput,
    blas_roots: &[Option<u32>],
) -> Vec<BvhInstance> {
    scene
        .instances
        .iter()
        .enumerate()
        .map(|(i, inst)| {
            let g = inst.geometry as usize;
            BvhInstance {
                world_to_object: input.w2o[i].unwrap_or([[0.0; 4]; 3]),
                // Instances left out of the top level are never entered.
                blas_root: blas_roots[g].unwrap_or(0),
                flags: if input.alpha[g] {
                    BVH_INSTANCE_ALPHA_TEST
                } else {
                    0
                },
                geometry: g as u32,
                pad: 0,
            }
        })
        .collect()
}

/// Fills the depth/stack stats and refuses trees deeper than the traversal stack.
pub(super) fn finish_stats(
    stats: &mut BvhStats,
    tlas_stack: u32,
    max_blas_stack: u32,
) -> Result<(), BvhError> {
    stats.max_depth = stats.tlas_depth + stats.max_blas_depth;
    stats.tlas_stack = tlas_stack;
    stats.max_stack = tlas_stack + max_blas_stack;
    if stats.max_stack > BVH_STACK_SIZE {
        return Err(BvhError::TooDeep {
            entries: stats.max_stack,
            limit: BVH_STACK_SIZE,
        });
    }
    Ok(())
}

/// Builds the two-level BVH of `scene` on the host.
pub(super) fn build(scene: &Scene, opts: &BvhBuildOptions) -> Result<BvhData, BvhError> {
    let t_start = Instant::now();
    let max_leaf = opts.max_leaf_size.clamp(1, MAX_LEAF_PRIMITIVES);
    let input = scene_input(scene)?;
    let mut stats = BvhStats {
        skipped_instances: input.skipped_instances,
        builder: "host".into(),
        ..Default::default()
    };

    // Bottom levels (built first: the top level needs their bounds).
    let t_blas = Instant::now();
    let mut blas_nodes: Vec<BvhNode> = Vec::new();
    let mut triangles: Vec<BvhTriangle> = Vec::new();
    // Per geometry: root node index relative to blas_nodes, and object bounds.
    let mut blas_roots: Vec<Option<u32>> = vec![None; scene.geometries.len()];
    let mut blas_bounds: Vec<Option<ObAabb>> = vec![None; scene.geometries.len()];
    let mut max_blas_stack = 0u32;
    for g in 0..scene.geometries.len() {
        if !input.used[g] {
            continue;
        }
        let geom = &scene.geometries[g];
        let gt = gather_geometry(scene, g)?;
        stats.skipped_triangles += geom.triangle_count() - gt.tris.len();
        if gt.tris.is_empty() {
            continue;
        }
        if triangles.len() + gt.tris.len() > LINK_FIRST_MASK as usize + 1 {
            return Err(BvhError::too_many("triangles"));
        }
        let bvh = build_bvh2(&gt.aabbs, opts, max_leaf);
        let scale = max_abs(&gt.bounds);
        let shape = flatten(&bvh, scale, &mut blas_nodes, &mut |prims| {
            let first = triangles.len() as u32;
            for &p in prims {
                triangles.push(gt.tris[p as usize]);
            }
            leaf_link(first, prims.len() as u32).ok_or_else(|| BvhError::too_many("triangles"))
        })?;
        stats.blas_count += 1;
        stats.max_blas_depth = stats.max_blas_depth.max(shape.depth);
        max_blas_stack = max_blas_stack.max(shape.stack);
        blas_roots[g] = Some(shape.root);
        blas_bounds[g] = Some(gt.bounds);
    }
    stats.blas_ms = t_blas.elapsed().as_secs_f64() * 1e3;

    // Top level over instances: world boxes of the transformed bottom-level root boxes.
    let (mut nodes, tlas_stack) = build_tlas(scene, &input, &blas_bounds, opts, &mut stats)?;

    // Append the bottom levels behind the top level and shift their inner links.
    let offset = nodes.len() as u32;
    if (nodes.len() + blas_nodes.len()) > (1usize << 31) {
        return Err(BvhError::too_many("nodes"));
    }
    for mut n in blas_nodes {
        for link in &mut n.links {
            if *link != LINK_EMPTY && decode_link(*link).is_ok() {
                *link += offset;
            }
        }
        nodes.push(n);
    }
    let roots: Vec<Option<u32>> = blas_roots.iter().map(|r| r.map(|r| r + offset)).collect();
    let instances = instance_records(scene, &input, &roots);

    finish_stats(&mut stats, tlas_stack, max_blas_stack)?;
    stats.node_count = nodes.len();
    stats.triangle_count = triangles.len();
    stats.instance_count = scene.instances.len();
    stats.max_leaf_size = max_leaf;
    stats.build_ms = t_start.elapsed().as_secs_f64() * 1e3;
    let mut data = BvhData {
        nodes,
        triangles,
        instances,
        stats,
    };
    data.stats.bytes = data.byte_size();
    Ok(data)
}
