#version 460
// Temporal reuse, classify: decides every pixel (reuse, verify with a primary ray on the rt path,
// or trace, and why), selects the frameless refresh, commits the reused pixels, counts the
// settled ones, and lists the pixels left for rays: for the verify pass (rt path) and the
// first trace (fused, so that deciding and listing cost one pass over the image, not two). One
// thread per pixel, 8x8-pixel workgroups.
#extension GL_GOOGLE_include_directive : require
#include "scene.glsl"
#include "frame.glsl"
#include "counters.glsl"
#include "temporal.glsl"
#include "neighbours.glsl"
#include "frameless.glsl"

#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_clustered : require

layout(local_size_x = 8, local_size_y = 8) in;
// ReprojectPush: level, the adaptive level the stage works at (interpolate); gather, the level
// whose pixels to trace the stage lists (GATHER_NONE: it lists none).
layout(push_constant) uniform Push { ReprojectPush pc; };

// Decides pixel q and, unless it is a candidate for the verify pass, commits it with the
// entry it has read anyway. Returns the state.
uint classify(uint q, ivec2 pix) {
    uint w = WINNER(q);
    bool reuse = (params.flags & RP_REUSE) != 0u;
    bool frameless = (params.flags & RP_FRAMELESS) != 0u;
    // The edge test (rt path) looks at the neighbours.
    Neighbours nb;
    if (reuse && (params.flags & (RP_GBUFFER | RP_VERIFY_ALL)) == 0u) {
        nb = load_neighbours(pix);
    }
    // An empty pixel shows the sample the shown stage's fill chose, if any.
    bool filled = false;
    if (reuse && w == NO_SAMPLE) {
        w = resolved_winner(q);
        filled = w != NO_SAMPLE;
    }
    uint st;
    uint age = 0u;
    CacheEntry e;
    if (!reuse) {
        st = PX_TRACE;
    } else if (w == NO_SAMPLE) {
        st = PX_TRACE | PX_HOLE;
    } else {
        e = CACHE_PREV(w);
        age = cache_age(e.meta);
        if ((e.meta & CACHE_VIEW_DEPENDENT) != 0u) {
            st = PX_TRACE | PX_VIEW_DEPENDENT;
        } else if (age >= params.max_age || ((e.meta & CACHE_MOVED) != 0u && age >= MOVED_MAX_AGE)) {
            st = PX_TRACE | PX_EXPIRED;
        } else if ((params.flags & RP_GBUFFER) != 0u) {
            st = judge_against_gbuffer(pix, e);
        } else if ((params.flags & RP_VERIFY_ALL) != 0u || near_edge(e, nb)) {
            st = PX_VERIFY;
        } else {
            st = PX_REUSE;
        }
    }
    if (filled) {
        st |= PX_FILLED;
    }
    uint kind = st & PX_KIND_MASK;
    // Frameless: a filled pixel is outside the budget's count (kept, or traced on top of it),
    // so only samples that landed are selected.
    if (frameless && !filled && (kind == PX_REUSE || kind == PX_VERIFY) && frameless_selects(uvec2(pix))) {
        st = PX_TRACE | PX_FRAMELESS;
        kind = PX_TRACE;
    }
    // The frame starts every state as PX_REUSE (a buffer fill).
    if (st != PX_REUSE) {
        STATE(q) = st;
    }
    if (kind != PX_VERIFY) {
        commit_entry(q, st, e, unknown_pixel_hit());
    }
    return st;
}

// The state classify counts for pixel q: 0 while the pixel is undecided (a candidate for the
// verify pass, which settles it).
uint settled_state(uint st) {
    return (st & PX_KIND_MASK) == PX_VERIFY ? 0u : st;
}

// Whether the verify pass (rt path) looks at pixel q: the candidates. (Pixels that need new
// colour trace their own primary ray: a verify round trip for every such pixel cost more
// than it saved.)
bool wants_verify(uint st) {
    return (st & PX_KIND_MASK) == PX_VERIFY;
}

void main() {
    uvec2 pix = gl_GlobalInvocationID.xy;
    bool inside = pix.x < frame.width && pix.y < frame.height;
    uint q = pix.y * frame.width + pix.x;
    uint settled = 0u;
    uint st = 0u;
    if (inside) {
        st = classify(q, ivec2(pix));
        settled = settled_state(st);
    }
    // Settled pixels are counted, and the pixels left for rays are listed: those the
    // verify pass looks at first, and the others to trace at the first level.
    bool look = inside && wants_verify(st);
    bool adaptive = (params.flags & RP_ADAPTIVE) != 0u;
    bool leader = subgroupElect();
    settle_and_list(settled, uvec3(LIST_VERIFY, LIST_TRACE, LIST_PENDING),
                    bvec3(look, inside && !look && traced_at(st, pix, pc.gather), adaptive && inside && (st & PX_KIND_MASK) == PX_TRACE),
                    adaptive ? 3u : 2u, q, leader);
    lists_done((1u << LIST_VERIFY) | (1u << LIST_TRACE) | (adaptive ? 1u << LIST_PENDING : 0u), leader);
}
