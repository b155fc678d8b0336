//! GPU records of the compute BVH, shared with `shaders/common/bvh_layout.glsl` (scalar block
//! layout). Every struct is `#[repr(C)]` with explicit padding so its bytes equal the GLSL struct
//! of the same name; `tests/bvh_gpu.rs` reads each field back on the GPU.
//!
//! # Node layout (64 bytes)
//!
//! A [`BvhNode`] is an inner node of a binary BVH that stores the boxes of **both** children
//! (`min0 max0 min1 max1`, 48 bytes), then their links (8 bytes) and primitive counts (8 bytes),
//! so one node fetch lets traversal slab-test two boxes and descend into the nearer one first.
//! A child is addressed by a 32-bit link:
//!
//! | bit 31 | bits 27..=30 | bits 0..=26 |
//! |---|---|---|
//! | 0 | node index (bits 0..=30) | |
//! | 1 | `count - 1` (1..=16 primitives) | first primitive |
//!
//! In the top level a leaf is one instance (`count = 1`, first = scene instance index); in a
//! bottom level it is `count` consecutive [`BvhTriangle`]s. An absent child (the second child of a
//! root that is a single leaf, or of an empty top level) has an inverted box (`min = +inf`,
//! `max = -inf`), which the sign-selected slab test never hits. All nodes of the top level and of
//! every bottom level live in one array; the top-level root is node 0.

use bytemuck::{Pod, Zeroable};

/// [`BvhChild::link`] bit marking a leaf.
pub const LINK_LEAF: u32 = 1 << 31;
/// Shift of `count - 1` in a leaf link.
pub const LINK_COUNT_SHIFT: u32 = 27;
/// Mask of the first-primitive field of a leaf link.
pub const LINK_FIRST_MASK: u32 = (1 << LINK_COUNT_SHIFT) - 1;
/// Most primitives one leaf link can address.
pub const MAX_LEAF_PRIMITIVES: u32 = 16;
/// Link of an absent child (a leaf of one primitive at 0, behind an inverted box).
pub const LINK_EMPTY: u32 = LINK_LEAF;

/// [`BvhInstance::flags`] bit: the geometry's material is alpha MASK, so candidate hits go
/// through `alpha_accepts()`.
pub const BVH_INSTANCE_ALPHA_TEST: u32 = 1;

/// Depth of the traversal stack in `trace_bvh.glsl`; the builder refuses deeper trees.
pub const BVH_STACK_SIZE: u32 = 64;

/// Encodes a leaf link; `None` when `first` or `count` do not fit.
pub fn leaf_link(first: u32, count: u32) -> Option<u32> {
    (first <= LINK_FIRST_MASK && (1..=MAX_LEAF_PRIMITIVES).contains(&count))
        .then(|| LINK_LEAF | ((count - 1) << LINK_COUNT_SHIFT) | first)
}

/// Decodes a link: `Ok(node)` for an inner node, `Err((first, count))` for a leaf.
pub fn decode_link(link: u32) -> Result<u32, (u32, u32)> {
    if link & LINK_LEAF == 0 {
        Ok(link)
    } else {
        Err((
            link & LINK_FIRST_MASK,
            ((link >> LINK_COUNT_SHIFT) & (MAX_LEAF_PRIMITIVES - 1)) + 1,
        ))
    }
}

/// An axis-aligned box of a node's child (24 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct BvhBox {
    /// Minimum corner (conservatively padded, see the builder).
    pub min: [f32; 3],
    /// Maximum corner.
    pub max: [f32; 3],
}

impl BvhBox {
    /// The inverted box of an absent child: no ray hits it.
    pub const EMPTY: Self = Self {
        min: [f32::INFINITY; 3],
        max: [f32::NEG_INFINITY; 3],
    };
}

/// One child of a node as the builder and the CPU traversal see it (not a GPU record: the
/// node stores its two children's fields interleaved, see [`BvhNode`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhChild {
    /// The child's box.
    pub bounds: BvhBox,
    /// Inner node index or packed leaf (see [`decode_link`]).
    pub link: u32,
    /// Triangles (bottom level) or instances (top level) below this child; 0 for an absent
    /// child.
    pub prim_count: u32,
}

impl BvhChild {
    /// The absent child: an inverted box no ray hits.
    pub const EMPTY: Self = Self {
        bounds: BvhBox::EMPTY,
        link: LINK_EMPTY,
        prim_count: 0,
    };

    /// Whether this is the absent child.
    pub fn is_empty(&self) -> bool {
        self.prim_count == 0
    }
}

/// An inner node: both children's boxes and links (64 bytes, one cache line). Traversal
/// reads only the first 56 bytes (boxes and links, as seven 64-bit loads); `prim_counts`
/// serve statistics and tests.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct BvhNode {
    /// Boxes of child 0 and child 1.
    pub boxes: [BvhBox; 2],
    /// Links of child 0 and child 1.
    pub links: [u32; 2],
    /// Primitives below each child (0: absent child).
    pub prim_counts: [u32; 2],
}

impl BvhNode {
    /// A node from its two children.
    pub fn from_children(c: [BvhChild; 2]) -> Self {
        Self {
            boxes: [c[0].bounds, c[1].bounds],
            links: [c[0].link, c[1].link],
            prim_counts: [c[0].prim_count, c[1].prim_count],
        }
    }

    /// Child `k` (0 or 1).
    pub fn child(&self, k: usize) -> BvhChild {
        BvhChild {
            bounds: self.boxes[k],
            link: self.links[k],
            prim_count: self.prim_counts[k],
        }
    }

    /// Both children.
    pub fn children(&self) -> [BvhChild; 2] {
        [self.child(0), self.child(1)]
    }
}

/// A triangle in leaf order: its three object-space vertices, copied bit-exactly from the
/// geometry so that triangles sharing an edge see identical vertex values (watertightness
/// depends on it; an edge-vector form `v0, v1 - v0` would not be exact), and its index in the
/// geometry's original index order (40 bytes: five 64-bit loads).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct BvhTriangle {
    /// Vertex 0 (glTF index order).
    pub v0: [f32; 3],
    /// Vertex 1.
    pub v1: [f32; 3],
    /// Vertex 2.
    pub v2: [f32; 3],
    /// Triangle index within the geometry (original index order).
    pub primitive: u32,
}

/// Per scene instance: what traversal needs to enter its bottom level (64 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct BvhInstance {
    /// Rows of the world-to-object affine transform: `object = row · (world, 1)`.
    pub world_to_object: [[f32; 4]; 3],
    /// Node index of the bottom-level root (in the shared node array).
    pub blas_root: u32,
    /// `BVH_INSTANCE_*` bits.
    pub flags: u32,
    /// Geometry index (scene order).
    pub geometry: u32,
    /// Padding.
    pub pad: u32,
}

/// Addresses and counts of the BVH buffers: the uniform at set 0, binding 2.
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

const _: () = {
    assert!(std::mem::size_of::<BvhNode>() == 64);
    assert!(std::mem::size_of::<BvhTriangle>() == 40);
    assert!(std::mem::size_of::<BvhInstance>() == 64);
    assert!(std::mem::size_of::<GpuBvhRefs>() == 40);
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn links_round_trip_and_reject_what_does_not_fit() {
        assert_eq!(decode_link(5), Ok(5));
        for (first, count) in [(0, 1), (7, 16), (LINK_FIRST_MASK, 3)] {
            let link = leaf_link(first, count).unwrap();
            assert_eq!(decode_link(link), Err((first, count)));
        }
        assert_eq!(leaf_link(0, 0), None);
        assert_eq!(leaf_link(0, 17), None);
        assert_eq!(leaf_link(LINK_FIRST_MASK + 1, 1), None);
        assert_eq!(decode_link(LINK_EMPTY), Err((0, 1)));
    }
}
