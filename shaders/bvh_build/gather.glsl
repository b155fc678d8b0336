// The choice of the collapse (bvh_build_collapse.comp) of which binary nodes become the
// children of one 4-wide node, shared with the PLOC merge, which counts the wide nodes each
// subtree will become so that the collapse can place them in depth-first pre-order.
#ifndef RQR_BVH_BUILD_GATHER_GLSL
#define RQR_BVH_BUILD_GATHER_GLSL

#include "bvh_build/build_common.glsl"

// An inner binary node that the collapse opens (not emitted as one leaf).
bool is_inner(uint node) {
    BvhBuildRefs r = BUILD_REFS;
    return node >= r.n && (U32s(r.info).v[node] & INFO_LEAF) == 0u;
}

// Surface area of an inner binary node the collapse may open, -1 for anything else.
float open_area(uint node) {
    BvhBuildRefs r = BUILD_REFS;
    if (!is_inner(node)) {
        return -1.0;
    }
    vec3 lo, hi;
    load_box(r.boxes, node, lo, hi);
    return half_area(lo, hi);
}

// The children of the binary node with children `left`, `right` gathered into one 4-wide
// node as in the host build (builder::open_children): the inner child with the largest
// surface area is opened until there are four. Returns the count. Each candidate's area is
// loaded once (the merge pass runs this for every new node).
uint gather_children(uint left, uint right, out uint kids[4]) {
    BvhBuildRefs r = BUILD_REFS;
    U32s children = U32s(r.children);
    float area[4];
    kids[0] = left;
    kids[1] = right;
    kids[2] = 0u;
    kids[3] = 0u;
    area[0] = open_area(left);
    area[1] = open_area(right);
    area[2] = -1.0;
    area[3] = -1.0;
    uint count = 2u;
    while (count < 4u) {
        int pos = -1;
        float best = -1.0;
        for (uint k = 0u; k < count; ++k) {
            if (area[k] > best) {
                best = area[k];
                pos = int(k);
            }
        }
        if (pos < 0) {
            break;
        }
        uint opened = kids[pos];
        for (uint k = count; k > uint(pos) + 1u; --k) {
            kids[k] = kids[k - 1u];
            area[k] = area[k - 1u];
        }
        kids[pos] = children.v[2u * (opened - r.n)];
        kids[pos + 1] = children.v[2u * (opened - r.n) + 1u];
        area[pos] = open_area(kids[pos]);
        area[pos + 1] = open_area(kids[pos + 1]);
        count += 1u;
    }
    return count;
}

#endif
