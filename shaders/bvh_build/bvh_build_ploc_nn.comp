#version 460
// PLOC step 1 (Meister & Bittner 2018): every cluster's nearest neighbour among the `radius`
// clusters on either side in Morton order, by the surface area of the merged box. Ties are
// broken by a key symmetric in the pair that prefers the pairs (2k, 2k + 1), so that equal
// distances (e.g. every triangle at one point) still merge half the clusters per iteration.
// `pc.a`: which value array holds the clusters (0: vals0, 1: vals1).
#include "bvh_build/build_common.glsl"
layout(local_size_x = 256) in;

void main() {
    BvhBuildRefs r = BUILD_REFS;
    U32s state = U32s(r.state);
    uint count = state.v[STATE_CLUSTERS];
    uint i = gl_GlobalInvocationID.x;
    if (i >= count) {
        return;
    }
    U32s clusters = U32s(pc.a == 0u ? r.vals0 : r.vals1);
    vec3 lo, hi;
    load_box(r.boxes, clusters.v[i], lo, hi);
    uint first = i > r.radius ? i - r.radius : 0u;
    uint last = min(count - 1u, i + r.radius);
    uint64_t best = ~0ul;
    uint best_j = i;
    for (uint j = first; j <= last; ++j) {
        if (j == i) {
            continue;
        }
        vec3 lo_j, hi_j;
        load_box(r.boxes, clusters.v[j], lo_j, hi_j);
        float area = half_area(min(lo, lo_j), max(hi, hi_j));
        uint a = min(i, j);
        uint b = max(i, j);
        uint paired = (b == a + 1u && (a & 1u) == 0u) ? 0u : 1u;
        uint tie = (paired << 31) | ((a & 0x03FFFFFFu) << 5) | (b - a);
        uint64_t key = (uint64_t(floatBitsToUint(area)) << 32) | uint64_t(tie);
        if (key < best) {
            best = key;
            best_j = j;
        }
    }
    U32s(r.keys1).v[i] = best_j;
}
