// variants: hw bvh
#version 460
// Temporal reuse, verify (rt path): primary visibility for the pixels that hold a candidate
// sample but cannot trust it without a look (all candidates, or those next to a depth edge,
// per --rt-visibility).
// One primary ray per listed pixel; its hit decides between reusing the sample (committed
// here; a fill is cached at that hit) and tracing the pixel (listed here for the tracing pass,
// which traces the primary ray again: storing every hit for it in G-buffer images took this
// pass a quarter of its time on lavapipe, while only the rejected few need it).
#extension GL_GOOGLE_include_directive : require
#include "scene.glsl"
#include "trace.glsl"
#include "frame.glsl"
#include "surface.glsl"
#include "counters.glsl"
#include "temporal.glsl"

layout(local_size_x = 64) in;
// VerifyPush: the adaptive level (1, 2, 4) whose pixels to trace this pass lists.
layout(push_constant) uniform Push { VerifyPush pc; };

void main() {
    // Job lists longer than a device launches in one dimension come in rows of workgroups.
    uint i = linear_invocation(gl_WorkGroupSize.x);
    bool listed = i < job_count(LIST_VERIFY);
    uint q = listed ? job_at(LIST_VERIFY, i) : 0u;
    uint settled = 0u;
    bool trace = false;
    bool rejected = false;
    if (listed) {
        ivec2 pix = ivec2(pixel_of(q));
        Ray r = camera_ray(vec2(pix) + 0.5);
        Hit h = trace_closest(r.origin, r.dir, 0.0, BIG_FLOAT);
        COUNTER_ADD(counters[stat_slot(0u)], 1u);
        COUNTER_ADD(counters[stat_slot(C_VERIFY_RAYS)], 1u);
        uint w = resolved_winner(q);
        CacheEntry e = CACHE_PREV(w == NO_SAMPLE ? 0u : w);
        // Every listed pixel is a candidate (wants_verify() of temporal_classify.comp).
        uint st = STATE(q);
        bool hit = hit_found(h);
        PixelHit ph = unknown_pixel_hit();
        ph.known = true;
        ph.found = hit;
        uint verdict;
        if (hit) {
            Surface s = surface_at(uint(h.instance), uint(h.primitive), h.barycentrics, r.dir, frame.pixel_spread * h.t);
            verdict = judge_primary(e, true, s.position, s.ng_front, s.material, s.metallic, s.roughness, s.transmission, s.alpha);
            ph.position = s.position;
            ph.ng_front = s.ng_front;
            ph.instance = uint(h.instance);
            ph.primitive = uint(h.primitive);
            ph.bary = h.barycentrics;
        } else {
            verdict = judge_primary(e, false, vec3(0.0), vec3(0.0), 0u, 0.0, 1.0, 0.0, 1.0);
        }
        st = verdict | (st & PX_FILLED);
        STATE(q) = st;
        // The stage before settled every other pixel; this pass settles the candidates.
        commit_entry(q, st, e, ph);
        settled = st;
        rejected = (st & PX_KIND_MASK) == PX_TRACE;
        trace = traced_at(st, uvec2(pix), pc.level);
    }
    // Rejected candidates join the pixels the interpolation passes look at.
    bool adaptive = (params.flags & RP_ADAPTIVE) != 0u;
    bool leader = subgroupElect();
    settle_and_list(settled, uvec3(LIST_TRACE, LIST_PENDING, LIST_PENDING), bvec3(trace, adaptive && rejected, false), 2u, q, leader);
    lists_done((1u << LIST_TRACE) | (adaptive ? 1u << LIST_PENDING : 0u), leader);
}
