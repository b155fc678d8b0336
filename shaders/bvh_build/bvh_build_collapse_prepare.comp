#version 460
// Between collapse levels (one invocation): the queue just filled becomes the next level's
// input, the consumed one is emptied. `pc.a`: parity of the level that just ran.
#include "bvh_build/build_common.glsl"
layout(local_size_x = 1) in;

void main() {
    BvhBuildRefs r = BUILD_REFS;
    U32s state = U32s(r.state);
    uint consumed = pc.a == 0u ? STATE_QUEUE0 : STATE_QUEUE1;
    uint filled = pc.a == 0u ? STATE_QUEUE1 : STATE_QUEUE0;
    state.v[consumed] = 0u;
    state.v[STATE_ARGS_COLLAPSE] = (state.v[filled] + 63u) / 64u;
}
