//! GPU records of the compute BVH, shared with `shaders/common/bvh_layout.glsl` (scalar block
//! layout). Every struct is `#[repr(C)]` with explicit padding so its bytes equal the GLSL struct
//! of the same name; `tests/gpu/bvh_gpu.rs` reads each field back on the GPU.
//!
//! # Node layout (64 bytes, 4 children, 8-bit boxes)
//!
//! A [`BvhNode`] is an inner node of a 4-wide BVH. It stores the boxes of all its children,
//! quantized to 8 bits per plane in the node's own frame (an origin and a power-of-two scale
//! per axis), and their links, so one node fetch (seven 64-bit loads) lets traversal slab-test
//! up to four boxes and descend into the nearest. A child box is
//! `origin + q * scale` with `q` in 0..=255; the builder rounds outward and verifies in f32 that
//! every quantized box contains the exact one. A child is addressed by a 32-bit link:
//!
//! | bit 31 | bits 27..=30 | bits 0..=26 |
//! |---|---|---|
//! | 0 | node index (bits 0..=30) | |
//! | 1 | `count - 1` (1..=16 primitives) | first primitive |
//!
//! In the top level a leaf is one instance (`count = 1`, first = scene instance index); in a
//! bottom level it is `count` consecutive [`BvhTriangle`]s. Unused child slots have the link
//! [`LINK_EMPTY`] and an inverted box (`q_min = 255`, `q_max = 0`), which the sign-selected slab
//! test never hits. All nodes of the top level and of every bottom level live in one array; the
//! top-level root is node 0.

use bytemuck::{Pod, Zeroable};

/// Link bit marking a leaf.
pub const LINK_LEAF: u32 = 1 << 31;
/// Shift of `count - 1` in a leaf link.
pub const LINK_COUNT_SHIFT: u32 = 27;
/// Mask of the first-primitive field of a leaf link.
pub const LINK_FIRST_MASK: u32 = (1 << LINK_COUNT_SHIFT) - 1;
/// Most primitives one leaf link can address.
pub const MAX_LEAF_PRIMITIVES: u32 = 16;
/// Link of an unused child slot (no real leaf can end past 2^27 primitives).
pub const LINK_EMPTY: u32 = u32::MAX;
/// Children per node.
pub const BVH_WIDTH: usize = 4;

/// [`BvhInstance::flags`] bit: the geometry's material is alpha MASK, so candidate hits go
/// through `alpha_accepts()`.
pub const BVH_INSTANCE_ALPHA_TEST: u32 = 1;

/// Entries of the traversal stack in `trace_bvh.glsl`; the builder refuses trees that could
/// need more (up to three pushes per level).
pub const BVH_STACK_SIZE: u32 = 96;

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

/// An axis-aligned box (host side: builder input, dequantized child boxes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhBox {
    /// Minimum corner.
    pub min: [f32; 3],
    /// Maximum corner.
    pub max: [f32; 3],
}

impl BvhBox {
    /// Whether `p` lies inside (boundary included).
    pub fn contains(&self, p: [f32; 3]) -> bool {
        (0..3).all(|a| self.min[a] <= p[a] && p[a] <= self.max[a])
    }

    /// Whether `other` lies inside.
    pub fn contains_box(&self, other: &BvhBox) -> bool {
        self.contains(other.min) && self.contains(other.max)
    }
}

/// One used child slot of a node as the builder and the CPU traversal see it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhChild {
    /// The child's box (dequantized when read from a node).
    pub bounds: BvhBox,
    /// Inner node index or packed leaf (see [`decode_link`]).
    pub link: u32,
}

/// An inner node: quantized boxes and links of up to four children (64 bytes, one cache
/// line; traversal reads the first 56).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct BvhNode {
    /// Frame origin: the minimum corner of the union of the children's boxes.
    pub origin: [f32; 3],
    /// Biased exponents of the per-axis scales (`scale = f32::from_bits(e << 23)`); byte 3 is 0.
    pub exponents: [u8; 4],
    /// Quantized planes, plane-major: `min_x, max_x, min_y, max_y, min_z, max_z`; byte `c` of
    /// each is child `c`.
    pub planes: [[u8; 4]; 6],
    /// Child links ([`LINK_EMPTY`] for unused slots).
    pub links: [u32; 4],
    /// Zero.
    pub reserved: [u32; 2],
}

/// Why a node could not be quantized.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct QuantizeError;

impl BvhNode {
    /// A node holding no child.
    pub const EMPTY: Self = Self {
        origin: [0.0; 3],
        exponents: [127, 127, 127, 0],
        planes: [[255; 4], [0; 4], [255; 4], [0; 4], [255; 4], [0; 4]],
        links: [LINK_EMPTY; 4],
        reserved: [0; 2],
    };

    /// Per-axis scales.
    pub fn scales(&self) -> [f32; 3] {
        [0, 1, 2].map(|a| f32::from_bits(u32::from(self.exponents[a]) << 23))
    }

    /// Quantizes 1..=4 children. Every dequantized box contains the given one: planes are
    /// rounded outward and checked with the same f32 arithmetic as [`Self::child`]. Fails on
    /// empty input, more than four children or non-finite boxes.
    pub fn new(children: &[BvhChild]) -> Result<Self, QuantizeError> {
        if children.is_empty()
            || children.len() > BVH_WIDTH
            || !children
                .iter()
                .flat_map(|c| c.bounds.min.iter().chain(&c.bounds.max))
                .all(|x| x.is_finite())
        {
            return Err(QuantizeError);
        }
        let mut node = Self::EMPTY;
        for a in 0..3 {
            let lo = children
                .iter()
                .map(|c| c.bounds.min[a])
                .fold(f32::INFINITY, f32::min);
            let hi = children
                .iter()
                .map(|c| c.bounds.max[a])
                .fold(f32::NEG_INFINITY, f32::max);
            node.origin[a] = lo;
            let extent = f64::from(hi) - f64::from(lo);
            // Smallest power of two with 255 steps covering the extent (at least 2^-126).
            let mut exp = if extent > 0.0 {
                ((extent / 255.0).log2().ceil() as i32).clamp(-126, 127)
            } else {
                -126
            };
            'retry: loop {
                if exp > 127 {
                    return Err(QuantizeError);
                }
                let scale = f32::from_bits(((exp + 127) as u32) << 23);
                let deq = |q: u32| lo + q as f32 * scale;
                for (c, child) in children.iter().enumerate() {
                    let (cmin, cmax) = (child.bounds.min[a], child.bounds.max[a]);
                    let mut qmin = (((f64::from(cmin) - f64::from(lo)) / f64::from(scale)).floor()
                        as i64)
                        .clamp(0, 255) as u32;
                    while qmin > 0 && deq(qmin) > cmin {
                        qmin -= 1;
                    }
                    let mut qmax = (((f64::from(cmax) - f64::from(lo)) / f64::from(scale)).ceil()
                        as i64)
                        .clamp(0, 256) as u32;
                    while qmax <= 255 && deq(qmax) < cmax {
                        qmax += 1;
                    }
                    if qmax > 255 || deq(qmin) > cmin {
                        exp += 1;
                        continue 'retry;
                    }
                    node.planes[2 * a][c] = qmin as u8;
                    node.planes[2 * a + 1][c] = qmax as u8;
                }
                node.exponents[a] = (exp + 127) as u8;
                break;
            }
        }
        for (c, child) in children.iter().enumerate() {
            node.links[c] = child.link;
        }
        Ok(node)
    }

    /// Child `k` with its dequantized box, or `None` for an unused slot.
    pub fn child(&self, k: usize) -> Option<BvhChild> {
        if self.links[k] == LINK_EMPTY {
            return None;
        }
        let s = self.scales();
        let deq = |a: usize, plane: usize| self.origin[a] + f32::from(self.planes[plane][k]) * s[a];
        Some(BvhChild {
            bounds: BvhBox {
                min: [deq(0, 0), deq(1, 2), deq(2, 4)],
                max: [deq(0, 1), deq(1, 3), deq(2, 5)],
            },
            link: self.links[k],
        })
    }

    /// The used child slots.
    pub fn children(&self) -> impl Iterator<Item = BvhChild> + '_ {
        (0..BVH_WIDTH).filter_map(|k| self.child(k))
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

const _: () = {
    use crate::interface::bvh::GpuBvhRefs;
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
        assert!(decode_link(LINK_EMPTY).is_err());
        // No real leaf reaches the empty link's range.
        let (first, count) = decode_link(LINK_EMPTY).unwrap_err();
        assert!(u64::from(first) + u64::from(count) > u64::from(LINK_FIRST_MASK) + 1);
    }

    #[test]
    fn quantized_boxes_contain_the_exact_ones() {
        let mut seed = 12345u32;
        let mut rnd = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        for scale in [1e-6f32, 1e-3, 1.0, 3.7, 1e3, 1e6] {
            for _ in 0..200 {
                let offset = (rnd() - 0.5) * 100.0 * scale;
                let n = 1 + (rnd() * 4.0) as usize % 4;
                let children: Vec<BvhChild> = (0..n)
                    .map(|k| {
                        let min = [0, 1, 2].map(|_| offset + rnd() * scale);
                        let size = [0, 1, 2].map(|_| if rnd() < 0.2 { 0.0 } else { rnd() * scale });
                        BvhChild {
                            bounds: BvhBox {
                                min,
                                max: [0, 1, 2].map(|a| min[a] + size[a]),
                            },
                            link: k as u32,
                        }
                    })
                    .collect();
                let node = BvhNode::new(&children).unwrap();
                let got: Vec<BvhChild> = node.children().collect();
                assert_eq!(got.len(), n);
                for (want, got) in children.iter().zip(&got) {
                    assert_eq!(want.link, got.link);
                    assert!(got.bounds.contains_box(&want.bounds), "{got:?} vs {want:?}");
                    // Outward rounding costs at most a few grid steps of the node extent.
                    for a in 0..3 {
                        let s = node.scales()[a];
                        assert!(want.bounds.min[a] - got.bounds.min[a] <= 2.0 * s);
                        assert!(got.bounds.max[a] - want.bounds.max[a] <= 2.0 * s);
                    }
                }
                for k in n..BVH_WIDTH {
                    assert!(node.child(k).is_none());
                }
            }
        }
        let nan = BvhChild {
            bounds: BvhBox {
                min: [f32::NAN; 3],
                max: [0.0; 3],
            },
            link: 0,
        };
        assert_eq!(BvhNode::new(&[nan]), Err(QuantizeError));
        assert_eq!(BvhNode::new(&[]), Err(QuantizeError));
    }
}
