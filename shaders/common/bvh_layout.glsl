// Records of the compute BVH; byte layout equals src/accel/bvh/layout.rs (scalar block layout).
// BvhRefs is the ray backend's uniform at set 0, binding 2. See the README section
// "Ray backends: compute BVH" for the node layout.
#ifndef RQR_BVH_LAYOUT_GLSL
#define RQR_BVH_LAYOUT_GLSL

#extension GL_EXT_buffer_reference : require
#extension GL_EXT_buffer_reference2 : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

// A child of an inner node: its box and a link. Link bit 31 clear: inner node index.
// Bit 31 set: leaf of ((link >> 27) & 15) + 1 primitives starting at (link & 0x07FFFFFF)
// (triangles in a bottom level, one scene instance in the top level).
struct BvhChild {
    vec3 bmin;
    uint link;
    vec3 bmax;
    uint prim_count;
};

struct BvhNode {
    BvhChild c0;
    BvhChild c1;
};

// Three exact vertex copies (object space), in leaf order.
struct BvhTriangle {
    vec3 v0;
    vec3 v1;
    vec3 v2;
};

struct BvhInstance {
    vec4 world_to_object[3]; // rows: object = dot(row.xyz, world) + row.w
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

layout(buffer_reference, scalar, buffer_reference_align = 16) readonly buffer BvhNodeBuf { BvhNode v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer BvhTriangleBuf { BvhTriangle v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer BvhPrimitiveBuf { uint v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 16) readonly buffer BvhInstanceBuf { BvhInstance v[]; };

layout(set = 0, binding = 2, scalar) uniform BvhRefs {
    uint64_t nodes;
    uint64_t triangles;
    uint64_t primitives;
    uint64_t instances;
    uint node_count;
    uint triangle_count;
    uint instance_count;
    uint tlas_root;
} bvh;

#endif
