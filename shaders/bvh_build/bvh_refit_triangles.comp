#version 460
// Refit, first pass: copies the moved vertices into every refitted leaf-order triangle (the
// primitive index and the leaf order stay). With `gpu_scales` (positions only the GPU has:
// the skinning pass's output) it also takes each bottom level's padding scale, the largest
// absolute vertex coordinate, as an `atomicMax` of the float bits (non-negative floats order
// like their bits), and flags non-finite vertices in `status` (bit 2).
#include "bvh_build/refit_common.glsl"
layout(local_size_x = 256) in;

vec3 position(uint v) {
    F32s p = F32s(REFIT_REFS.positions);
    return vec3(p.v[3u * v], p.v[3u * v + 1u], p.v[3u * v + 2u]);
}

void main() {
    BvhRefitRefs r = REFIT_REFS;
    uint i = gl_GlobalInvocationID.x;
    if (i >= r.triangle_count) {
        return;
    }
    U32s ids = U32s(r.vertex_ids);
    uint t = U32s(r.triangle_ids).v[i];
    vec3 v0 = position(ids.v[3u * i]);
    vec3 v1 = position(ids.v[3u * i + 1u]);
    vec3 v2 = position(ids.v[3u * i + 2u]);
    Tris tris = Tris(r.triangles);
    tris.v[t].v0 = v0;
    tris.v[t].v1 = v1;
    tris.v[t].v2 = v2;
    if (r.gpu_scales != 0u) {
        bvec3 bad = bvec3(any(isnan(v0)) || any(isinf(v0)), any(isnan(v1)) || any(isinf(v1)),
                          any(isnan(v2)) || any(isinf(v2)));
        if (any(bad)) {
            atomicOr(U32s(r.status).v[0], 2u);
            return;
        }
        vec3 m = max(abs(v0), max(abs(v1), abs(v2)));
        float s = max(m.x, max(m.y, m.z));
        atomicMax(U32s(r.scales).v[U32s(r.triangle_slots).v[i]], floatBitsToUint(s));
    }
}
