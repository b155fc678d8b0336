#version 460
// Refit, one level per dispatch (bottom up; no workgroup barriers): every node of the level
// recomputes its children's boxes (an inner child's from `bounds`, written by a lower level;
// a bottom-level leaf's from its triangles; a top-level leaf's from its instance's transformed
// bottom-level root box), stores the union of the exact boxes in `bounds` and re-quantizes the
// padded boxes into the node. Links stay. `pc.a`: first entry of `order`, `pc.b`: count.
#include "bvh_build/refit_common.glsl"
layout(local_size_x = 64) in;

vec3 row_transform(F32s m, uint inst, vec3 p) {
    uint o = 12u * inst;
    return vec3(
        m.v[o] * p.x + m.v[o + 1u] * p.y + m.v[o + 2u] * p.z + m.v[o + 3u],
        m.v[o + 4u] * p.x + m.v[o + 5u] * p.y + m.v[o + 6u] * p.z + m.v[o + 7u],
        m.v[o + 8u] * p.x + m.v[o + 9u] * p.y + m.v[o + 10u] * p.z + m.v[o + 11u]);
}

void main() {
    BvhRefitRefs r = REFIT_REFS;
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.b) {
        return;
    }
    uint idx = U32s(r.order).v[pc.a + i];
    Nodes nodes = Nodes(r.nodes);
    BuildNode node = nodes.v[idx];
    float pad_scale = F32s(r.scales).v[U32s(r.owner).v[idx]];
    bool top = idx < r.tlas_nodes;
    vec3 bmin[4];
    vec3 bmax[4];
    vec3 union_lo = vec3(uintBitsToFloat(0x7F800000u));
    vec3 union_hi = vec3(uintBitsToFloat(0xFF800000u));
    uint count = 0u;
    for (uint k = 0u; k < 4u; ++k) {
        bmin[k] = vec3(0.0);
        bmax[k] = vec3(0.0);
    }
    for (uint k = 0u; k < 4u; ++k) {
        uint link = node.links[k];
        if (link == LINK_EMPTY) {
            break; // both builders fill slots from the first
        }
        vec3 lo;
        vec3 hi;
        if ((link & LINK_LEAF) == 0u) {
            load_box(r.bounds, link, lo, hi);
        } else if (top) {
            uint inst = link & 0x07FFFFFFu;
            uint root = U32s(r.instances).v[16u * inst + 12u];
            vec3 blo;
            vec3 bhi;
            load_box(r.bounds, root, blo, bhi);
            lo = vec3(uintBitsToFloat(0x7F800000u));
            hi = vec3(uintBitsToFloat(0xFF800000u));
            F32s m = F32s(r.object_to_world);
            for (uint c = 0u; c < 8u; ++c) {
                vec3 p = vec3((c & 1u) == 0u ? blo.x : bhi.x, (c & 2u) == 0u ? blo.y : bhi.y,
                              (c & 4u) == 0u ? blo.z : bhi.z);
                vec3 w = row_transform(m, inst, p);
                lo = min(lo, w);
                hi = max(hi, w);
            }
        } else {
            uint first = link & 0x07FFFFFFu;
            uint n = ((link >> 27) & 15u) + 1u;
            Tris tris = Tris(r.triangles);
            lo = vec3(uintBitsToFloat(0x7F800000u));
            hi = vec3(uintBitsToFloat(0xFF800000u));
            for (uint t = first; t < first + n; ++t) {
                BuildTri tri = tris.v[t];
                lo = min(lo, min(tri.v0, min(tri.v1, tri.v2)));
                hi = max(hi, max(tri.v0, max(tri.v1, tri.v2)));
            }
        }
        union_lo = min(union_lo, lo);
        union_hi = max(union_hi, hi);
        pad_box(lo, hi, pad_scale);
        bmin[count] = lo;
        bmax[count] = hi;
        count += 1u;
    }
    if (count == 0u) {
        return;
    }
    store_box(r.bounds, idx, union_lo, union_hi);
    if (!quantize_children(bmin, bmax, count, node)) {
        atomicOr(U32s(r.status).v[0], 1u);
        return;
    }
    nodes.v[idx].origin = node.origin;
    nodes.v[idx].exponents = node.exponents;
    nodes.v[idx].planes = node.planes;
}
