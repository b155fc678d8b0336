//! The compute BVH's interface (`interface_bvh.glsl`): the ray backend's `GpuBvhRefs` uniform
//! (binding `BINDING_RAY_BACKEND`, `bvh_layout.glsl`), and the records, push constants and
//! state words of the GPU build and refit passes (`shaders/bvh_build/`). Structs with `u64`
//! fields are `uint64_t` in GLSL: shaders enable `GL_EXT_shader_explicit_arithmetic_types_int64`
//! before including this header.

use bytemuck::{Pod, Zeroable};

/// Addresses and counts of the BVH buffers: the uniform at set 0, binding
/// `BINDING_RAY_BACKEND` (bvh backend).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuBvhRefs {
    /// `BvhNode[]`: top level first (root = node 0), then every bottom level.
    pub nodes: u64,
    /// `BvhTriangle[]` in leaf order, every bottom level one after the other.
    pub triangles: u64,
    /// `BvhInstance[]`, one per scene instance.
    pub instances: u64,
    /// Number of nodes.
    pub node_count: u32,
    /// Number of triangles.
    pub triangle_count: u32,
    /// Number of instances.
    pub instance_count: u32,
    /// Node index of the top-level root (always 0).
    pub tlas_root: u32,
}

/// The GPU build's `BuildRefs` record (scalar layout): the addresses of its arrays and the
/// geometry's parameters; every build pass reads it through the address in [`BvhBuildPush`].
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct BvhBuildRefs {
    /// `BuildTri[n]` in input order (binary leaf i = triangle i).
    pub tris_in: u64,
    /// Final `BvhTriangle` array; this geometry's range starts at `tri_base`.
    pub tris_out: u64,
    /// 6 floats (min, max) per binary node: leaves 0..n, inner n..2n-1.
    pub boxes: u64,
    /// 2 uints per inner binary node.
    pub children: u64,
    /// Per binary node: leaf count | INFO_LEAF when emitted as a leaf.
    pub info: u64,
    /// Per binary node: SAH cost of its subtree.
    pub cost: u64,
    /// Radix sort keys, ping.
    pub keys0: u64,
    /// Radix sort keys, pong.
    pub keys1: u64,
    /// Radix sort values, ping.
    pub vals0: u64,
    /// Radix sort values, pong.
    pub vals1: u64,
    /// Radix histograms, then PLOC keep flags (scanned in place).
    pub flags: u64,
    /// Per-block sums of the scans.
    pub sums: u64,
    /// Counters and indirect arguments (`STATE_*` words).
    pub state: u64,
    /// 4-wide nodes with local indices (relocated afterwards).
    pub nodes: u64,
    /// Collapse work items, ping.
    pub queue0: u64,
    /// Collapse work items, pong.
    pub queue1: u64,
    /// Triangles of the geometry.
    pub n: u32,
    /// First triangle of the geometry in the final array.
    pub tri_base: u32,
    /// Most triangles per leaf.
    pub max_leaf: u32,
    /// SAH traversal cost.
    pub traversal_cost: f32,
    /// Minimum of the triangle centroids.
    pub centroid_min: [f32; 3],
    /// Box padding scale.
    pub pad_scale: f32,
    /// 1 / extent of the centroids (Morton codes).
    pub centroid_inv_extent: [f32; 3],
    /// PLOC search radius.
    pub radius: u32,
    /// Per inner binary node: the 4-wide nodes the collapse makes of its subtree (for the
    /// depth-first layout).
    pub wide: u64,
}

/// Push constant of the build passes (and the refit passes, where `refs` is the address of a
/// [`BvhRefitRefs`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct BvhBuildPush {
    /// Address of the pass's refs record.
    pub refs: u64,
    /// Pass argument: radix shift, ping-pong parity.
    pub a: u32,
    /// Second pass argument.
    pub b: u32,
}

/// Push constant of the scan passes (`scan_common.glsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct BvhScanPush {
    /// Address of the scanned words.
    pub data: u64,
    /// Address of the per-block sums.
    pub sums: u64,
    /// Address of the element count (one `uint`).
    pub count: u64,
    /// Address of the total (one `uint`).
    pub total: u64,
}

/// Push constant of `bvh_build_relocate.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct BvhRelocatePush {
    /// Address of the built nodes (local indices).
    pub src: u64,
    /// Address of their place in the shared node array.
    pub dst: u64,
    /// Nodes to copy.
    pub count: u32,
    /// Destination node index, also added to every inner-node link.
    pub offset: u32,
}

/// Push constant of `bvh_build_tlas_links.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct BvhTlasLinksPush {
    /// Built wide nodes (local indices, root 0).
    pub src: u64,
    /// The shared node array; the top level starts at node 0.
    pub dst: u64,
    /// `BvhTriangle[]` in leaf order (10 words, primitive last).
    pub leaves: u64,
    /// Nodes of the top level.
    pub count: u32,
    /// Padding.
    pub pad: u32,
}

/// The refit passes' `RefitRefs` record (scalar layout).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct BvhRefitRefs {
    /// `BvhNode[]`: top level first, then every bottom level.
    pub nodes: u64,
    /// `BvhTriangle[]` in leaf order.
    pub triangles: u64,
    /// 6 floats per node: exact union of its children's boxes.
    pub bounds: u64,
    /// Node indices, level by level from the bottom up.
    pub order: u64,
    /// Per node: index into `scales`.
    pub owner: u64,
    /// Padding scale per bottom level, the top level's last.
    pub scales: u64,
    /// `BvhInstance[]` (16 words each, blas_root at word 12).
    pub instances: u64,
    /// 12 floats (3 rows) per instance.
    pub object_to_world: u64,
    /// 3 floats per vertex of every refitted geometry.
    pub positions: u64,
    /// 3 per refitted triangle: vertex index into `positions`.
    pub vertex_ids: u64,
    /// Word 0: bit 1 set when a node could not be quantized, bit 2 when a vertex read from
    /// `positions` was not finite.
    pub status: u64,
    /// Per refitted triangle: its index in the leaf-order triangle array.
    pub triangle_ids: u64,
    /// Per refitted triangle: its bottom level's index into `scales` (read only when
    /// `gpu_scales` is set).
    pub triangle_slots: u64,
    /// Nodes below this index belong to the top level.
    pub tlas_nodes: u32,
    /// Triangles to refit.
    pub triangle_count: u32,
    /// 1: the triangle pass computes the bottom levels' padding scales (`atomicMax` of the
    /// vertices' largest absolute coordinate into zeroed `scales`), for positions that only
    /// the GPU has; 0: the host wrote them.
    pub gpu_scales: u32,
    /// Padding.
    pub pad: u32,
}

/// Words of the GPU build's state buffer.
pub const STATE_WORDS: usize = 32;
/// State word: clusters of the current PLOC iteration.
pub const STATE_CLUSTERS: usize = 0;
/// State word: clusters after the current PLOC iteration.
pub const STATE_CLUSTERS_NEXT: usize = 1;
/// State word: binary inner nodes allocated by the PLOC merges.
pub const STATE_NEXT_INNER: usize = 2;
/// State word: binary root.
pub const STATE_ROOT: usize = 3;
/// State word: 4-wide nodes written.
pub const STATE_WIDE_COUNT: usize = 4;
/// State word: collapse work items in `queue0`.
pub const STATE_QUEUE0: usize = 5;
/// State word: collapse work items in `queue1`.
pub const STATE_QUEUE1: usize = 6;
/// State word: depth of the 4-wide tree.
pub const STATE_MAX_DEPTH: usize = 7;
/// State word: traversal stack entries the tree needs.
pub const STATE_MAX_STACK: usize = 8;
/// State word: PLOC iterations run.
pub const STATE_ITERATIONS: usize = 9;
/// State word: non-zero when a node could not be built.
pub const STATE_ERROR: usize = 10;
/// State word: entries of the radix histograms (the scans' element count).
pub const STATE_HIST_COUNT: usize = 11;
/// First word of the indirect arguments over all elements.
pub const STATE_ARGS_ELEMS: u64 = 16;
/// First word of the indirect arguments over the scan blocks.
pub const STATE_ARGS_BLOCKS: u64 = 20;
/// First word of the single-group indirect arguments.
pub const STATE_ARGS_SINGLE: u64 = 24;
/// First word of the collapse level's indirect arguments.
pub const STATE_ARGS_COLLAPSE: u64 = 28;
