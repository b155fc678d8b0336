#version 460
// Radix sort pass, step 2: stable scatter of each key/value pair to the scanned offset of
// its (digit, block) plus its rank among the block's keys with the same digit. Ranks come
// from a workgroup scan of one-hot digit counters packed 16 bits each into 8 words.
#include "bvh_build/build_common.glsl"
layout(local_size_x = 256) in;

shared uint packed_counts[256 * 8];

void main() {
    BvhBuildRefs r = BUILD_REFS;
    uint lid = gl_LocalInvocationID.x;
    uint i = gl_GlobalInvocationID.x;
    bool valid = i < r.n;
    U32s keys_in = U32s(pc.b == 0u ? r.keys0 : r.keys1);
    U32s vals_in = U32s(pc.b == 0u ? r.vals0 : r.vals1);
    uint key = valid ? keys_in.v[i] : 0u;
    uint digit = (key >> pc.a) & 15u;
    uint mine[8];
    for (uint k = 0u; k < 8u; ++k) {
        mine[k] = 0u;
    }
    if (valid) {
        mine[digit >> 1] = 1u << (16u * (digit & 1u));
    }
    for (uint k = 0u; k < 8u; ++k) {
        packed_counts[lid * 8u + k] = mine[k];
    }
    for (uint offset = 1u; offset < 256u; offset <<= 1) {
        barrier();
        uint add[8];
        for (uint k = 0u; k < 8u; ++k) {
            add[k] = lid >= offset ? packed_counts[(lid - offset) * 8u + k] : 0u;
        }
        barrier();
        for (uint k = 0u; k < 8u; ++k) {
            mine[k] += add[k];
            packed_counts[lid * 8u + k] = mine[k];
        }
    }
    if (valid) {
        uint rank = ((mine[digit >> 1] >> (16u * (digit & 1u))) & 0xFFFFu) - 1u;
        uint blocks = (r.n + 255u) / 256u;
        uint dst = U32s(r.flags).v[digit * blocks + gl_WorkGroupID.x] + rank;
        U32s(pc.b == 0u ? r.keys1 : r.keys0).v[dst] = key;
        U32s(pc.b == 0u ? r.vals1 : r.vals0).v[dst] = vals_in.v[i];
    }
}
