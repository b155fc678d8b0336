#version 460
// Collapse setup (one invocation): the first work item is the binary root as wide node 0.
// A root that is a leaf (one triangle, or a subtree emitted as one leaf) becomes the single
// child of node 0, as in the host build.
#include "bvh_build/build_common.glsl"
layout(local_size_x = 1) in;

void main() {
    BvhBuildRefs r = BUILD_REFS;
    U32s state = U32s(r.state);
    uint root = state.v[STATE_ROOT];
    bool single = (U32s(r.info).v[root] & INFO_LEAF) != 0u;
    // Item: binary node, wide node, first triangle (relative), depth | pushed << 8 | single << 31.
    UVec4s(r.queue0).v[0] = uvec4(root, 0u, 0u, 1u | (single ? 0x80000000u : 0u));
    state.v[STATE_QUEUE0] = 1u;
    state.v[STATE_QUEUE1] = 0u;
    // Nodes of the whole tree, placed depth-first by the collapse.
    state.v[STATE_WIDE_COUNT] = single ? 1u : U32s(r.wide).v[root - r.n];
    state.v[STATE_ARGS_COLLAPSE] = 1u;
    state.v[STATE_ARGS_COLLAPSE + 1u] = 1u;
    state.v[STATE_ARGS_COLLAPSE + 2u] = 1u;
}
