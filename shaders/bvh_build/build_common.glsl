// Shared declarations of the GPU BVH builder (src/accel/bvh/gpu_build.rs). Every pass reads
// the addresses of its arrays from one `BuildRefs` record (byte layout = `GpuBuildRefs` in
// gpu_build.rs) whose address comes in the push constants.
#ifndef RQR_BVH_BUILD_COMMON_GLSL
#define RQR_BVH_BUILD_COMMON_GLSL

#extension GL_EXT_buffer_reference : require
#extension GL_EXT_buffer_reference2 : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

struct BuildTri {
    vec3 v0;
    vec3 v1;
    vec3 v2;
    uint primitive;
};

struct BuildNode {
    vec3 origin;
    uint exponents;
    uint planes[6];
    uint links[4];
    uint reserved[2];
};

layout(buffer_reference, scalar, buffer_reference_align = 4) buffer U32s { uint v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer F32s { float v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer UVec4s { uvec4 v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer Tris { BuildTri v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer Nodes { BuildNode v[]; };

layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer BuildRefs {
    uint64_t tris_in;  // BuildTri[n] in input order (binary leaf i = triangle i)
    uint64_t tris_out; // final BvhTriangle array, this geometry's range starts at tri_base
    uint64_t boxes;    // 6 floats (min, max) per binary node: leaves 0..n, inner n..2n-1
    uint64_t children; // 2 uints per inner binary node
    uint64_t info;     // per binary node: leaf count | INFO_LEAF when emitted as a leaf
    uint64_t cost;     // per binary node: SAH cost of its subtree
    uint64_t keys0;
    uint64_t keys1;
    uint64_t vals0;
    uint64_t vals1;
    uint64_t flags;    // radix histograms, then PLOC keep flags (scanned in place)
    uint64_t sums;     // per-block sums of the scans
    uint64_t state;    // counters and indirect arguments (STATE_*)
    uint64_t nodes;    // 4-wide nodes with local indices (relocated afterwards)
    uint64_t queue0;   // collapse work items
    uint64_t queue1;
    uint n;
    uint tri_base;
    uint max_leaf;
    float traversal_cost;
    vec3 centroid_min;
    float pad_scale;
    vec3 centroid_inv_extent;
    uint radius;
    uint64_t wide;     // per inner binary node: 4-wide nodes the collapse makes of its subtree
};

layout(push_constant) uniform Push {
    uint64_t refs;
    uint a; // pass argument: radix shift, ping-pong parity
    uint b;
} pc;

// State words (keep in sync with gpu_build.rs).
#define STATE_CLUSTERS 0u
#define STATE_CLUSTERS_NEXT 1u
#define STATE_NEXT_INNER 2u
#define STATE_ROOT 3u
#define STATE_WIDE_COUNT 4u
#define STATE_QUEUE0 5u
#define STATE_QUEUE1 6u
#define STATE_MAX_DEPTH 7u
#define STATE_MAX_STACK 8u
#define STATE_ITERATIONS 9u
#define STATE_ERROR 10u
#define STATE_HIST_COUNT 11u
#define STATE_ARGS_ELEMS 16u
#define STATE_ARGS_BLOCKS 20u
#define STATE_ARGS_SINGLE 24u
#define STATE_ARGS_COLLAPSE 28u

#define INFO_LEAF 0x80000000u
#define INFO_COUNT 0x3FFFFFFFu

#define LINK_LEAF 0x80000000u
#define LINK_EMPTY 0xFFFFFFFFu

#define BUILD_REFS BuildRefs(pc.refs)

void load_box(uint64_t boxes, uint i, out vec3 lo, out vec3 hi) {
    F32s b = F32s(boxes);
    lo = vec3(b.v[6 * i], b.v[6 * i + 1], b.v[6 * i + 2]);
    hi = vec3(b.v[6 * i + 3], b.v[6 * i + 4], b.v[6 * i + 5]);
}

void store_box(uint64_t boxes, uint i, vec3 lo, vec3 hi) {
    F32s b = F32s(boxes);
    b.v[6 * i] = lo.x;
    b.v[6 * i + 1] = lo.y;
    b.v[6 * i + 2] = lo.z;
    b.v[6 * i + 3] = hi.x;
    b.v[6 * i + 4] = hi.y;
    b.v[6 * i + 5] = hi.z;
}

float half_area(vec3 lo, vec3 hi) {
    vec3 d = max(hi - lo, vec3(0.0));
    return d.x * d.y + d.y * d.z + d.z * d.x;
}

#endif
