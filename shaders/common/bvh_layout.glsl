// Records of the compute BVH; byte layout equals src/accel/bvh/layout.rs (scalar block layout).
// The ray backend's uniform (`GpuBvhRefs`, binding BINDING_RAY_BACKEND) comes from
// src/interface/bvh.rs. See the README section
// "Ray backends: compute BVH" for the node layout.
#ifndef RQR_BVH_LAYOUT_GLSL
#define RQR_BVH_LAYOUT_GLSL

#extension GL_EXT_buffer_reference : require
#extension GL_EXT_buffer_reference2 : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

// Inner node (64 bytes) of the 4-wide BVH: child boxes quantized to 8 bits per plane in the
// node's frame (box = origin + q * scale, scale = 2^(exponent - 127) per axis), and links.
// Link bit 31 clear: inner node index. Bit 31 set: leaf of ((link >> 27) & 15) + 1 primitives
// starting at (link & 0x07FFFFFF) (triangles in a bottom level, one scene instance in the top
// level). Unused slots: link 0xFFFFFFFF, inverted box (q_min 255, q_max 0).
struct BvhNode {
    vec3 origin;
    uint exponents; // byte k: biased exponent of axis k's scale
    uint planes[6]; // min_x max_x min_y max_y min_z max_z; byte c = child c
    uint links[4];
    uint reserved0;
    uint reserved1;
};

// Three exact vertex copies (object space) and the triangle's original index (40 bytes).
struct BvhTriangle {
    vec3 v0;
    vec3 v1;
    vec3 v2;
    uint primitive;
};

struct BvhInstance {
    vec4 world_to_object[3]; // rows: object = dot(row, vec4(world, 1))
    uint blas_root;
    uint flags;
    uint geometry;
    uint pad;
};

#define BVH_LINK_LEAF 0x80000000u
#define BVH_LINK_COUNT_SHIFT 27
#define BVH_LINK_FIRST_MASK 0x07FFFFFFu
#define BVH_INSTANCE_ALPHA_TEST 1u
#define BVH_STACK_SIZE 96
#define BVH_LINK_EMPTY 0xFFFFFFFFu

#include "interface_shared.glsl"
#include "interface_bvh.glsl"

// The ray backend's uniform: addresses and counts of the BVH buffers (`GpuBvhRefs`).
layout(set = 0, binding = BINDING_RAY_BACKEND, scalar) uniform BvhRefs { GpuBvhRefs bvh; };

// Records are read as 64-bit words: a CPU Vulkan (lavapipe) turns every component of a
// per-lane load into one scalar load per SIMD lane, so two floats per load halve that work.
// The arrays are 8-byte aligned (GpuBvh checks).
layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer BvhWords { uint64_t w[]; };

vec2 bvh_floats(uint64_t x) { return uintBitsToFloat(unpackUint2x32(x)); }
uvec2 bvh_uints(uint64_t x) { return unpackUint2x32(x); }

// Node `i` without its reserved words (read as 0).
BvhNode bvh_load_node(uint i) {
    BvhWords p = BvhWords(bvh.nodes + uint64_t(i) * 64ul);
    BvhNode n;
    vec2 o = bvh_floats(p.w[0]);
    uvec2 oe = bvh_uints(p.w[1]);
    n.origin = vec3(o, uintBitsToFloat(oe.x));
    n.exponents = oe.y;
    for (int k = 0; k < 3; ++k) {
        uvec2 q = bvh_uints(p.w[2 + k]);
        n.planes[2 * k] = q.x;
        n.planes[2 * k + 1] = q.y;
    }
    uvec2 l01 = bvh_uints(p.w[5]);
    uvec2 l23 = bvh_uints(p.w[6]);
    n.links[0] = l01.x;
    n.links[1] = l01.y;
    n.links[2] = l23.x;
    n.links[3] = l23.y;
    n.reserved0 = 0u;
    n.reserved1 = 0u;
    return n;
}

BvhTriangle bvh_load_triangle(uint i) {
    BvhWords p = BvhWords(bvh.triangles + uint64_t(i) * 40ul);
    vec2 a = bvh_floats(p.w[0]), b = bvh_floats(p.w[1]), c = bvh_floats(p.w[2]);
    vec2 d = bvh_floats(p.w[3]), e = bvh_floats(p.w[4]);
    BvhTriangle t;
    t.v0 = vec3(a, b.x);
    t.v1 = vec3(b.y, c);
    t.v2 = vec3(d, e.x);
    t.primitive = floatBitsToUint(e.y);
    return t;
}

// Transform rows, BLAS root and flags of instance `i` (geometry and pad read as 0).
BvhInstance bvh_load_instance(uint i) {
    BvhWords p = BvhWords(bvh.instances + uint64_t(i) * 64ul);
    BvhInstance inst;
    for (int r = 0; r < 3; ++r) {
        inst.world_to_object[r] = vec4(bvh_floats(p.w[2 * r]), bvh_floats(p.w[2 * r + 1]));
    }
    uvec2 rf = bvh_uints(p.w[6]);
    inst.blas_root = rf.x;
    inst.flags = rf.y;
    inst.geometry = 0u;
    inst.pad = 0u;
    return inst;
}

#endif
