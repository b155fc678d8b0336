#version 460
// PLOC step 3: after the exclusive scan of the keep flags, kept clusters move to their new
// position in the other cluster array, in order. When one cluster remains it is the root.
// `pc.a`: source cluster array (the destination is the other one).
#include "bvh_build/build_common.glsl"
layout(local_size_x = 256) in;

void main() {
    BvhBuildRefs r = BUILD_REFS;
    U32s state = U32s(r.state);
    uint count = state.v[STATE_CLUSTERS];
    uint total = state.v[STATE_CLUSTERS_NEXT];
    uint i = gl_GlobalInvocationID.x;
    if (i >= count) {
        return;
    }
    U32s offsets = U32s(r.flags);
    uint at = offsets.v[i];
    uint next = i + 1u < count ? offsets.v[i + 1u] : total;
    if (next != at) {
        uint cluster = U32s(r.keys0).v[i];
        U32s(pc.a == 0u ? r.vals1 : r.vals0).v[at] = cluster;
        if (total == 1u) {
            state.v[STATE_ROOT] = cluster;
        }
    }
}
