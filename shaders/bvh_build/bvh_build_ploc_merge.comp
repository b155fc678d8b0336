#version 460
// PLOC step 2: mutual nearest neighbours merge into a new inner node (the lower index keeps
// it, the higher one is dropped); every other cluster is kept. Also computes the new node's
// leaf count and SAH cost, and whether its subtree is better emitted as one leaf (at most
// `max_leaf` triangles and a leaf cost not above the subtree's), and how many 4-wide nodes the
// collapse will make of it (so the collapse can lay them out depth-first). Writes the
// surviving cluster to keys0[i] and the keep flag to flags[i]. `pc.a`: source cluster array.
#include "bvh_build/gather.glsl"
layout(local_size_x = 256) in;

void main() {
    BvhBuildRefs r = BUILD_REFS;
    U32s state = U32s(r.state);
    uint count = state.v[STATE_CLUSTERS];
    uint i = gl_GlobalInvocationID.x;
    if (i >= count) {
        return;
    }
    U32s clusters = U32s(pc.a == 0u ? r.vals0 : r.vals1);
    U32s nn = U32s(r.keys1);
    U32s survivor = U32s(r.keys0);
    U32s keep = U32s(r.flags);
    uint j = nn.v[i];
    if (nn.v[j] != i) {
        survivor.v[i] = clusters.v[i];
        keep.v[i] = 1u;
        return;
    }
    if (i > j) {
        keep.v[i] = 0u;
        return;
    }
    uint left = clusters.v[i];
    uint right = clusters.v[j];
    uint node = r.n + atomicAdd(state.v[STATE_NEXT_INNER], 1u);
    U32s children = U32s(r.children);
    children.v[2u * (node - r.n)] = left;
    children.v[2u * (node - r.n) + 1u] = right;
    vec3 lo_l, hi_l, lo_r, hi_r;
    load_box(r.boxes, left, lo_l, hi_l);
    load_box(r.boxes, right, lo_r, hi_r);
    vec3 lo = min(lo_l, lo_r);
    vec3 hi = max(hi_l, hi_r);
    store_box(r.boxes, node, lo, hi);
    U32s info = U32s(r.info);
    F32s cost = F32s(r.cost);
    uint leaves = (info.v[left] & INFO_COUNT) + (info.v[right] & INFO_COUNT);
    float area = half_area(lo, hi);
    float inner_cost = r.traversal_cost * area + cost.v[left] + cost.v[right];
    float leaf_cost = float(leaves) * area;
    bool as_leaf = leaves <= r.max_leaf && leaf_cost <= inner_cost;
    info.v[node] = leaves | (as_leaf ? INFO_LEAF : 0u);
    cost.v[node] = as_leaf ? leaf_cost : inner_cost;
    // Every node below is final: the collapse's wide node for this one plus those of the
    // inner children it gathers. A subtree emitted as one leaf makes none (count unused).
    uint wide_nodes = 0u;
    if (!as_leaf) {
        uint kids[4];
        uint gathered = gather_children(left, right, kids);
        wide_nodes = 1u;
        for (uint k = 0u; k < gathered; ++k) {
            if (is_inner(kids[k])) {
                wide_nodes += U32s(r.wide).v[kids[k] - r.n];
            }
        }
    }
    U32s(r.wide).v[node - r.n] = wide_nodes;
    survivor.v[i] = node;
    keep.v[i] = 1u;
}
