// Shared declarations of the GPU BVH builder (src/accel/bvh/gpu_build.rs). Every pass reads
// the addresses of its arrays from one `BvhBuildRefs` record whose address comes in the push
// constants; both, and the STATE_* words, are declared in src/interface/bvh.rs.
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

#include "interface_bvh.glsl"

// The build's `BvhBuildRefs` record, read through the address in the push constants.
layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer BuildRefs {
    BvhBuildRefs refs;
};

layout(push_constant) uniform Push { BvhBuildPush pc; };

#define INFO_LEAF 0x80000000u
#define INFO_COUNT 0x3FFFFFFFu

#define LINK_LEAF 0x80000000u
#define LINK_EMPTY 0xFFFFFFFFu

#define BUILD_REFS BuildRefs(pc.refs).refs

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
