// Records of the compute BVH; byte layout equals src/accel/bvh/layout.rs (scalar block layout).
// BvhRefs is the ray backend's uniform at set 0, binding 2. See the README section
// "Ray backends: compute BVH" for the node layout.
#ifndef RQR_BVH_LAYOUT_GLSL
#define RQR_BVH_LAYOUT_GLSL

#extension GL_EXT_buffer_reference : require
#extension GL_EXT_buffer_reference2 : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

// Inner node (64 bytes): boxes of child 0 and 1, their links, their primitive counts.
// Link bit 31 clear: inner node index. Bit 31 set: leaf of ((link >> 27) & 15) + 1 primitives
// starting at (link & 0x07FFFFFF) (triangles in a bottom level, one scene instance in the top
// level). Absent children have inverted boxes (min = +inf, max = -inf).
struct BvhNode {
    vec3 min0;
    vec3 max0;
    vec3 min1;
    vec3 max1;
    uint link0;
    uint link1;
    uint count0; // statistics and tests only; traversal never loads the counts
    uint count1;
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
#define BVH_STACK_SIZE 64

layout(set = 0, binding = 2, scalar) uniform BvhRefs {
    uint64_t nodes;     // BvhNode[]: top level (root = node 0), then every bottom level
    uint64_t triangles; // BvhTriangle[] in leaf order
    uint64_t instances; // BvhInstance[], one per scene instance
    uint node_count;
    uint triangle_count;
    uint instance_count;
    uint tlas_root;
} bvh;

// Records are read as 64-bit words: a CPU Vulkan (lavapipe) turns every component of a
// per-lane load into one scalar load per SIMD lane, so two floats per load halve that work.
// The arrays are 8-byte aligned (GpuBvh checks).
layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer BvhWords { uint64_t w[]; };

vec2 bvh_floats(uint64_t x) { return uintBitsToFloat(unpackUint2x32(x)); }
uvec2 bvh_uints(uint64_t x) { return unpackUint2x32(x); }

// Boxes and links of node `i` (the counts are not loaded and read as 0).
BvhNode bvh_load_node(uint i) {
    BvhWords p = BvhWords(bvh.nodes + uint64_t(i) * 64ul);
    vec2 a = bvh_floats(p.w[0]), b = bvh_floats(p.w[1]), c = bvh_floats(p.w[2]);
    vec2 d = bvh_floats(p.w[3]), e = bvh_floats(p.w[4]), f = bvh_floats(p.w[5]);
    BvhNode n;
    n.min0 = vec3(a, b.x);
    n.max0 = vec3(b.y, c);
    n.min1 = vec3(d, e.x);
    n.max1 = vec3(e.y, f);
    uvec2 links = bvh_uints(p.w[6]);
    n.link0 = links.x;
    n.link1 = links.y;
    n.count0 = 0u;
    n.count1 = 0u;
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
