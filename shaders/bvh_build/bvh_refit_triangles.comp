#version 460
// Refit, first pass: copies the moved vertices into every leaf-order triangle (the primitive
// index and the leaf order stay).
#include "bvh_build/refit_common.glsl"
layout(local_size_x = 256) in;

vec3 position(uint v) {
    F32s p = F32s(REFIT_REFS.positions);
    return vec3(p.v[3u * v], p.v[3u * v + 1u], p.v[3u * v + 2u]);
}

void main() {
    BvhRefitRefs r = REFIT_REFS;
    uint t = gl_GlobalInvocationID.x;
    if (t >= r.triangle_count) {
        return;
    }
    U32s ids = U32s(r.vertex_ids);
    Tris tris = Tris(r.triangles);
    tris.v[t].v0 = position(ids.v[3u * t]);
    tris.v[t].v1 = position(ids.v[3u * t + 1u]);
    tris.v[t].v2 = position(ids.v[3u * t + 2u]);
}
