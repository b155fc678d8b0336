#version 460
// Radix sort pass, step 1: per 256-key block, how many keys have each 4-bit digit at bit
// `pc.a`; written digit-major (hist[digit * blocks + block]) so one exclusive scan gives every
// block's output offset per digit. `pc.b`: which key array is the source (0 or 1).
#include "bvh_build/build_common.glsl"
layout(local_size_x = 256) in;

shared uint digit_counts[16];

void main() {
    BvhBuildRefs r = BUILD_REFS;
    uint lid = gl_LocalInvocationID.x;
    if (lid < 16u) {
        digit_counts[lid] = 0u;
    }
    barrier();
    uint i = gl_GlobalInvocationID.x;
    if (i < r.n) {
        uint key = U32s(pc.b == 0u ? r.keys0 : r.keys1).v[i];
        atomicAdd(digit_counts[(key >> pc.a) & 15u], 1u);
    }
    barrier();
    uint blocks = (r.n + 255u) / 256u;
    if (lid < 16u) {
        U32s(r.flags).v[lid * blocks + gl_WorkGroupID.x] = digit_counts[lid];
    }
}
