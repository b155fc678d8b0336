#version 460
// Collapse, one level of the 4-wide tree per dispatch: each work item turns a binary node
// into one 4-wide node at the index its item carries. Its children are gathered as in the
// host build (gather.glsl); children emitted as leaves get their triangles copied in leaf
// order into the output array, inner children get a work item for the next level and the
// index that puts every subtree's nodes in one contiguous range, in depth-first pre-order as
// the host build lays them out (a ray's path stays in nearby cache lines and pages). Boxes are
// padded and quantized like BvhNode::new. `pc.a`: parity of the input queue.
#include "bvh_build/quantize.glsl"
#include "bvh_build/gather.glsl"
layout(local_size_x = 64) in;

// Copies the triangles under `node` (a subtree of at most 16 leaves) to tris_out[at..].
void emit_leaf(uint node, uint at) {
    BvhBuildRefs r = BUILD_REFS;
    uint stack[32];
    uint top = 0u;
    stack[top++] = node;
    Tris tris_in = Tris(r.tris_in);
    Tris tris_out = Tris(r.tris_out);
    U32s children = U32s(r.children);
    while (top > 0u) {
        uint x = stack[--top];
        if (x < r.n) {
            tris_out.v[at++] = tris_in.v[x];
        } else if (top + 2u <= 32u) {
            stack[top++] = children.v[2u * (x - r.n) + 1u];
            stack[top++] = children.v[2u * (x - r.n)];
        }
    }
}

void main() {
    BvhBuildRefs r = BUILD_REFS;
    U32s state = U32s(r.state);
    uint queue_in = pc.a == 0u ? STATE_QUEUE0 : STATE_QUEUE1;
    uint queue_out = pc.a == 0u ? STATE_QUEUE1 : STATE_QUEUE0;
    uint t = gl_GlobalInvocationID.x;
    if (t >= state.v[queue_in]) {
        return;
    }
    uvec4 item = UVec4s(pc.a == 0u ? r.queue0 : r.queue1).v[t];
    UVec4s next = UVec4s(pc.a == 0u ? r.queue1 : r.queue0);
    uint depth = item.w & 255u;
    uint pushed = (item.w >> 8) & 255u;
    U32s children = U32s(r.children);
    uint kids[4];
    uint count = 0u;
    if ((item.w & 0x80000000u) != 0u) {
        kids[0] = item.x;
        count = 1u;
    } else {
        count = gather_children(children.v[2u * (item.x - r.n)],
                                children.v[2u * (item.x - r.n) + 1u], kids);
    }
    uint child_pushed = pushed + count - 1u;
    uint first = item.z;
    uint next_wide = item.y + 1u;
    vec3 bmin[4];
    vec3 bmax[4];
    uint links[4];
    U32s info = U32s(r.info);
    for (uint k = 0u; k < 4u; ++k) {
        links[k] = LINK_EMPTY;
        bmin[k] = vec3(0.0);
        bmax[k] = vec3(0.0);
    }
    for (uint k = 0u; k < count; ++k) {
        uint c = kids[k];
        vec3 lo, hi;
        load_box(r.boxes, c, lo, hi);
        pad_box(lo, hi, r.pad_scale);
        bmin[k] = lo;
        bmax[k] = hi;
        uint leaves = info.v[c] & INFO_COUNT;
        if (is_inner(c)) {
            // Depth-first pre-order: the first inner child follows its parent, each later one
            // follows the whole subtree of the one before (sizes counted by the PLOC merge).
            links[k] = next_wide;
            uint slot = atomicAdd(state.v[queue_out], 1u);
            next.v[slot] = uvec4(c, next_wide, first, (depth + 1u) | (child_pushed << 8));
            next_wide += U32s(r.wide).v[c - r.n];
        } else {
            uint at = r.tri_base + first;
            links[k] = LINK_LEAF | ((leaves - 1u) << 27) | at;
            emit_leaf(c, at);
        }
        first += leaves;
    }

    BuildNode node;
    bool failed = !quantize_children(bmin, bmax, count, node);
    if (failed) {
        atomicOr(state.v[STATE_ERROR], 1u);
    }
    for (uint k = 0u; k < 4u; ++k) {
        node.links[k] = links[k];
    }
    node.reserved[0] = 0u;
    node.reserved[1] = 0u;
    Nodes(r.nodes).v[item.y] = node;
    atomicMax(state.v[STATE_MAX_DEPTH], depth);
    atomicMax(state.v[STATE_MAX_STACK], child_pushed);
}
