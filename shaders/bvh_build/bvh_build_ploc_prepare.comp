#version 460
// Between PLOC iterations (one invocation): the compacted cluster count becomes current and
// the indirect dispatch sizes of the next iteration are derived from it (0 groups once one
// cluster is left, so the remaining recorded iterations do nothing).
#include "bvh_build/build_common.glsl"
layout(local_size_x = 1) in;

void main() {
    BvhBuildRefs r = BUILD_REFS;
    U32s state = U32s(r.state);
    uint count = state.v[STATE_CLUSTERS_NEXT];
    state.v[STATE_CLUSTERS] = count;
    bool running = count > 1u;
    if (running) {
        state.v[STATE_ITERATIONS] += 1u;
    }
    state.v[STATE_ARGS_ELEMS] = running ? (count + 255u) / 256u : 0u;
    state.v[STATE_ARGS_ELEMS + 1u] = 1u;
    state.v[STATE_ARGS_ELEMS + 2u] = 1u;
    state.v[STATE_ARGS_BLOCKS] = running ? (count + 1023u) / 1024u : 0u;
    state.v[STATE_ARGS_BLOCKS + 1u] = 1u;
    state.v[STATE_ARGS_BLOCKS + 2u] = 1u;
    state.v[STATE_ARGS_SINGLE] = running ? 1u : 0u;
    state.v[STATE_ARGS_SINGLE + 1u] = 1u;
    state.v[STATE_ARGS_SINGLE + 2u] = 1u;
}
