// Shared declarations of the refit passes (src/accel/bvh/refit.rs). The push constants are
// build_common.glsl's `BvhBuildPush`: `refs` is the address of a `BvhRefitRefs` record
// (src/interface/bvh.rs), `a` and `b` are per-pass arguments.
#ifndef RQR_BVH_REFIT_COMMON_GLSL
#define RQR_BVH_REFIT_COMMON_GLSL

#include "bvh_build/quantize.glsl"

layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer RefitRefs {
    BvhRefitRefs refs;
};

#define REFIT_REFS RefitRefs(pc.refs).refs

#endif
