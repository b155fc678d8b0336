// Shared declarations of the refit passes (src/accel/bvh/refit.rs). The push constants are
// build_common.glsl's `Push`: `refs` is the address of a `RefitRefs` record (byte layout =
// `GpuRefitRefs` in refit.rs), `a` and `b` are per-pass arguments.
#ifndef RQR_BVH_REFIT_COMMON_GLSL
#define RQR_BVH_REFIT_COMMON_GLSL

#include "bvh_build/quantize.glsl"

layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer RefitRefs {
    uint64_t nodes;           // BvhNode[]: top level first, then every bottom level
    uint64_t triangles;       // BvhTriangle[] in leaf order
    uint64_t bounds;          // 6 floats per node: exact union of its children's boxes
    uint64_t order;           // node indices, level by level from the bottom up
    uint64_t owner;           // per node: index into `scales`
    uint64_t scales;          // padding scale per bottom level, the top level's last
    uint64_t instances;       // BvhInstance[] (16 words each, blas_root at word 12)
    uint64_t object_to_world; // 12 floats (3 rows) per instance
    uint64_t positions;       // 3 floats per vertex of every refitted geometry
    uint64_t vertex_ids;      // 3 per leaf-order triangle: vertex index into `positions`
    uint64_t status;          // word 0: set when a node could not be quantized
    uint tlas_nodes;          // nodes below this index belong to the top level
    uint triangle_count;
};

#define REFIT_REFS RefitRefs(pc.refs)

#endif
