#version 460
// Leaf setup: box, SAH cost and leaf record of every triangle, and the 30-bit Morton code of
// its centroid in the centroid bounds (key) with the triangle index (value) for the sort.
#include "bvh_build/build_common.glsl"
layout(local_size_x = 256) in;

// Spreads the low 10 bits of x to every third bit.
uint spread_bits(uint x) {
    x &= 0x3FFu;
    x = (x | (x << 16)) & 0x030000FFu;
    x = (x | (x << 8)) & 0x0300F00Fu;
    x = (x | (x << 4)) & 0x030C30C3u;
    x = (x | (x << 2)) & 0x09249249u;
    return x;
}

void main() {
    BvhBuildRefs r = BUILD_REFS;
    uint i = gl_GlobalInvocationID.x;
    if (i >= r.n) {
        return;
    }
    BuildTri t = Tris(r.tris_in).v[i];
    vec3 lo = min(min(t.v0, t.v1), t.v2);
    vec3 hi = max(max(t.v0, t.v1), t.v2);
    store_box(r.boxes, i, lo, hi);
    U32s(r.info).v[i] = 1u | INFO_LEAF;
    F32s(r.cost).v[i] = half_area(lo, hi);
    vec3 p = clamp(((lo + hi) * 0.5 - r.centroid_min) * r.centroid_inv_extent, 0.0, 1.0);
    uvec3 q = min(uvec3(p * 1024.0), uvec3(1023u));
    U32s(r.keys0).v[i] = (spread_bits(q.x) << 2) | (spread_bits(q.y) << 1) | spread_bits(q.z);
    U32s(r.vals0).v[i] = i;
}
