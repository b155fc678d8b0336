#version 460
// Temporal reprojection, the stages that trace no rays (src/render/passes/reproject/ records them):
// scatter/resolve of the previous frame's samples into this camera, per-pixel decisions,
// the frameless selection, job lists for the tracing passes, adaptive sub-sampling's
// interpolation, and statistics. One thread per pixel (per cached sample for the scatter),
// 8x8-pixel workgroups; the push constant picks the stage and, for the stages that decide
// what the next tracing pass does, which job list they append to (fused, so that deciding
// and listing cost one pass over the image, not two).
#extension GL_GOOGLE_include_directive : require
#include "scene.glsl"
#include "frame.glsl"
#include "counters.glsl"
#include "reproject.glsl"

#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_clustered : require

layout(local_size_x = 8, local_size_y = 8) in;
// The stage that runs (STAGE_* of src/interface/reproject.rs): a specialization constant, so
// that each stage's pipeline holds its own code only (src/render/passes/reproject/ builds one
// pipeline per stage).
layout(constant_id = 0) const uint STAGE = 0u;
// ReprojectPush: level, the adaptive level the stage works at (interpolate); gather, the level
// whose pixels to trace the stage lists (GATHER_NONE: it lists none).
layout(push_constant) uniform Push { ReprojectPush pc; };

// The colour of a pixel settled earlier this frame: every pixel that has one (reused, traced,
// interpolated) has it in its next cache entry, so adaptive sub-sampling needs no separate
// colour buffer.
vec3 color_at(uint x, uint y) { return CACHE_NEXT(y * frame.width + x).color; }

// The records of the samples a pixel's 4 edge-sharing neighbours show (Shown, written by the
// previous stage; empty outside the image), in pixel order, for the edge test.
struct Neighbours {
    Shown shown[4];
};

const ivec2 EDGE_NEIGHBOURS[4] = ivec2[4](ivec2(0, -1), ivec2(-1, 0), ivec2(1, 0), ivec2(0, 1));

Neighbours load_neighbours(ivec2 pix) {
    Neighbours nb;
    [[unroll]] for (uint k = 0u; k < 4u; ++k) {
        ivec2 n = pix + EDGE_NEIGHBOURS[k];
        bool inside = n.x >= 0 && n.y >= 0 && n.x < int(frame.width) && n.y < int(frame.height);
        nb.shown[k] = Shown(0.0, 0u);
        if (inside) {
            nb.shown[k] = SHOWN(uint(n.y) * frame.width + uint(n.x));
        }
    }
    return nb;
}

// Render Cache-style edge test for the rt path without a full primary-visibility pass: a
// sample is trusted when the samples of its edge-sharing neighbours lie on the same smooth
// surface (an edge that is a continuous curve passes between a pixel and one of them). A
// surface that was hidden comes into view next to the silhouette that hid it, a depth edge,
// so the pixels there get a primary ray. (A hidden surface coming out from behind an edge
// faster than a pixel per frame can show the farther surface for a few frames beyond that
// band: the price of the mode; --rt-visibility full and the hybrid path check every pixel.)
//
// The plane distance is measured from the neighbour's tangent plane (Shown keeps two words per
// pixel: the plane's offset and the normal); where the normals pass the normal test, the two
// samples' planes nearly agree, so which one is used hardly matters.
//
// Every neighbour is tested and the results combined, without early exits or divisions: on a
// CPU device (lavapipe) a branch that some lanes leave costs more than the arithmetic it skips.
bool near_edge(CacheEntry e, Neighbours nb) {
    bool miss = cache_miss(e);
    vec3 from_camera = e.position - frame.camera_pos;
    // The plane distance relative to the view depth, compared as a distance.
    float limit = params.edge_threshold * (miss ? 1.0 : max(view_depth(e.position), 1e-6));
    vec3 en = unpack_normal(e.normal);
    bool edge = false;
    [[unroll]] for (uint k = 0u; k < 4u; ++k) {
        uint bits = nb.shown[k].normal;
        // An empty neighbour is traced this frame anyway (or filled from its own neighbours).
        // Counting it as an edge would verify the neighbourhood of every pixel a stretched
        // surface leaves empty: on an orbit, most of the rays this mode saves.
        bool landed = (bits & SHOWN_SAMPLE) != 0u;
        bool other_miss = (bits & SHOWN_MISS) != 0u;
        vec3 on = unpack_normal(bits);
        bool apart = abs(dot(from_camera, on) - nb.shown[k].plane) > limit || dot(on, en) < params.normal_threshold;
        edge = edge || (landed && (other_miss != miss || (!miss && apart)));
    }
    return edge;
}

// Reprojected point samples leave empty pixels where a surface is seen a little larger than
// before, and along the seams between regions whose samples have different sub-pixel offsets
// (samples keep the world position their colour belongs to). Left alone, each such pixel is
// traced at its centre, starts a region with yet another offset, and empty pixels multiply
// frame after frame. So an empty pixel takes the sample of an edge-sharing neighbour that
// falls nearest to its centre, within fill_radius pixels (nearest first, then the lowest
// source index): a splat footprint, as in the Render Cache. Only samples that sit where their
// colour was computed are copied (not fills or interpolations), so a colour moves at most one
// fill radius. The pixel still goes through the visibility tests (the G-buffer; on the rt
// path the edge test or a primary ray), so a disocclusion is not filled with whatever lies
// next to it. Returns the chosen sample's index, NO_SAMPLE when none qualifies.
//
// Run by the shown stage, so that classify (and the frameless threshold before it: the holes
// left count toward the budget) knows every pixel's sample. The neighbours' samples are read
// from their depth keys (where each falls, whether it may be copied): a fill gathers and
// projects nothing.
uint fill(ivec2 pix) {
    vec2 centre = vec2(pix) + 0.5;
    uint best = NO_SAMPLE;
    // Squared distances: no square roots.
    float best_d2 = params.fill_radius * params.fill_radius;
    [[unroll]] for (uint k = 0u; k < 4u; ++k) {
        ivec2 n = pix + EDGE_NEIGHBOURS[k];
        bool inside = n.x >= 0 && n.y >= 0 && n.x < int(frame.width) && n.y < int(frame.height);
        uint q = uint(n.y) * frame.width + uint(n.x);
        uint w = NO_SAMPLE;
        if (inside) {
            w = WINNER(q);
        }
        if (w != NO_SAMPLE) {
            // (Read only where a sample won: an empty neighbour's key is being rewritten.)
            uint key = DEPTH_KEY(q);
            vec2 d = key_film(uvec2(n), key) - centre;
            float d2 = dot(d, d);
            if ((key & KEY_NOT_COPYABLE) == 0u && (d2 < best_d2 || (d2 == best_d2 && w < best))) {
                best_d2 = d2;
                best = w;
            }
        }
    }
    return best;
}

uint refresh_bin(uvec2 pix);
bool frameless_selects(uvec2 pix);

// Frameless rendering: whether a pixel showing sample `e` may keep it this frame (the
// refresh sweep decides), as opposed to pixels that must be traced anyway. The samples that
// classify then rejects (G-buffer, visibility) are traced on top of the budget.
bool frameless_candidate(CacheEntry e) {
    uint age = cache_age(e.meta);
    return (params.flags & RP_FRAMELESS) != 0u && (e.meta & CACHE_VIEW_DEPENDENT) == 0u && age < params.max_age
        && ((e.meta & CACHE_MOVED) == 0u || age < MOVED_MAX_AGE);
}

// Records the sample pixel q shows (the scatter's winner) in pixel order, for the stage that
// looks at neighbours, and fills an empty pixel from its neighbours' samples. With frameless
// rendering it also counts the candidates and the filled pixels, so that the budget's refresh
// window is known before classify, which then selects the pixels to refresh itself (one pass
// over the image, not two).
void record_shown(uint q, uvec2 pix) {
    uint w = WINNER(q);
    bool candidate = false;
    bool filled = false;
    if (w == NO_SAMPLE) {
        // The edge test sees a filled pixel as empty too (its sample is a neighbour's).
        SHOWN(q).normal = 0u;
        uint f = fill(ivec2(pix));
        if (f != NO_SAMPLE) {
            // Later stages read the choice through resolved_winner(): the depth key is free
            // on a pixel no sample landed on (and fills read the keys of winners only).
            DEPTH_KEY(q) = FILLED_KEY | f;
            filled = true;
        }
    } else {
        CacheEntry e = CACHE_PREV(w);
        uint bits = SHOWN_SAMPLE | (cache_miss(e) ? SHOWN_MISS : 0u);
        float plane = cache_miss(e) ? 0.0 : dot(e.position - frame.camera_pos, unpack_normal(e.normal));
        SHOWN(q) = Shown(plane, e.normal | bits);
        candidate = frameless_candidate(e);
    }
    if ((params.flags & RP_FRAMELESS) != 0u) {
        // The candidates of this row segment (which shares a refresh bin) go into the
        // histogram, and the filled pixels (kept out of both the candidates and the pixels
        // that must be traced) into this workgroup's stripe: one reduction (8-bit fields; a
        // segment has 8 pixels) and one or two atomics per segment. Invocations of a subgroup
        // cover the workgroup's rows in order (lavapipe: a subgroup is one row; NVIDIA: four),
        // so a cluster of REFRESH_SEGMENT invocations is one segment.
        uint sums = subgroupClusteredAdd((candidate ? 1u : 0u) | (filled ? 256u : 0u), REFRESH_SEGMENT);
        if ((gl_SubgroupInvocationID & (REFRESH_SEGMENT - 1u)) == 0u) {
            if ((sums & 255u) != 0u) {
                atomicAdd(counters[C_HISTOGRAM + refresh_bin(pix)], sums & 255u);
            }
            if ((sums >> 8) != 0u) {
                atomicAdd(counters[stat_slot(C_SHOWN_FILLED)], sums >> 8);
            }
        }
    }
}

// Decides pixel q and, unless it is a candidate for the visibility pass, commits it with the
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

// Frameless refresh order: a fixed interleaved-gradient-noise rank (Jimenez 2014) of the
// pixel's row segment (REFRESH_SEGMENT pixels), quantized to REFRESH_BINS bins: a stratified
// permutation of the image. Each frame refreshes the candidates in a window of bins that
// starts where the previous frame's ended (a sweep, as in Bishop et al.'s frameless
// rendering, but stratified instead of random): what one frame refreshes is spread evenly, and
// every candidate is refreshed once per pass of the sweep. Segments, not pixels: the shown
// stage counts a segment's candidates with one atomic (a per-pixel atomic cost 0.7 ms of a
// 13 ms frame on lavapipe), and the tracing pass traces neighbouring pixels together. (Oldest
// first by an age x rank histogram chose the same pixels on a still camera.)
uint refresh_bin(uvec2 pix) {
    vec2 segment = vec2(pix.x / REFRESH_SEGMENT, pix.y);
    float rank = fract(52.9829189 * fract(0.06711056 * segment.x + 0.00583715 * segment.y));
    return min(uint(int(rank * float(REFRESH_BINS))), REFRESH_BINS - 1u);
}

// Frameless budget: re-trace frameless_fraction of all pixels per frame. Pixels that must be
// traced anyway count first; the rest of the budget goes to candidates in the sweep's window,
// whole bins from where the sweep stands until the window holds the rest (so at least the
// budget is traced, and at most one bin more).
void threshold() {
    uint budget = uint(ceil(params.frameless_fraction * float(pixel_count())));
    uint candidates = 0u;
    for (uint b = 0u; b < REFRESH_BINS; ++b) {
        candidates += counters[C_HISTOGRAM + b];
    }
    uint filled = 0u;
    for (uint s = 0u; s < COUNTER_STRIPES; ++s) {
        filled += counters[(s + 1u) * COUNTER_STRIPE_WORDS + C_SHOWN_FILLED];
    }
    // Every pixel that showed a sample and is no candidate must be traced, and so must every
    // empty pixel no neighbour filled (a hole): they count first. Filled pixels keep a
    // neighbour's copy, outside the budget.
    uint forced = pixel_count() - candidates - filled;
    uint extra = budget > forced ? budget - forced : 0u;
    uint start = counters[C_SWEEP];
    uint bins = 0u;
    for (uint taken = 0u; taken < extra && bins < REFRESH_BINS; ++bins) {
        taken += counters[C_HISTOGRAM + ((start + bins) & (REFRESH_BINS - 1u))];
    }
    counters[C_WINDOW_START] = start;
    counters[C_WINDOW_BINS] = bins;
    counters[C_SWEEP] = (start + bins) & (REFRESH_BINS - 1u);
}

// Whether the frameless budget refreshes a candidate pixel: its bin lies in this frame's
// window (which wraps around).
bool frameless_selects(uvec2 pix) {
    return ((refresh_bin(pix) - counters[C_WINDOW_START]) & (REFRESH_BINS - 1u)) < counters[C_WINDOW_BINS];
}

// Compared as displayed, roughly (Reinhard, gamma 2): a linear difference that is invisible
// in a bright region is a visible step in a dark one. A square root, not pow(1 / 2.2): every
// pending pixel compares five colours at each level, and on a CPU device (lavapipe) a pow is
// a polynomial exp2/log2 pair per channel (interpolation 23 % cheaper there; rays and FLIP
// the same to the third digit).
vec3 display(vec3 c) {
    vec3 v = max(c, vec3(0.0));
    return sqrt(v / (1.0 + v));
}

float differ(vec3 x, vec3 y) {
    vec3 d = abs(display(x) - display(y));
    return max(d.x, max(d.y, d.z));
}

// Tent weight that is 1 at `c` and 0 at both ends of [0, 1].
float tent(float u, float c) {
    return u <= c ? (c > 0.0 ? u / c : 1.0) : (c < 1.0 ? (1.0 - u) / (1.0 - c) : 1.0);
}

// Whether the samples of an interpolated block (its corners and centre, cached this frame)
// lie on one smooth opaque surface: the centre's tangent plane within the plane threshold,
// normals within the normal threshold, one material, none a miss or view-dependent. Then
// `entry` is pixel `pix`'s entry on that plane (where its ray meets it), one hop from where
// colour was computed, so fills do not copy it. (On the rt path an interpolated pixel has no
// primary hit of its own. Moving geometry would need the hit's anchor.)
bool block_on_one_plane(uvec2 sx, uvec2 sy, uvec2 centre, uvec2 pix, out CacheEntry entry) {
    entry = CACHE_NEXT(centre.y * frame.width + centre.x);
    uint required = CACHE_VALID | CACHE_MISS | CACHE_VIEW_DEPENDENT;
    if (tracks_motion() || (entry.meta & required) != CACHE_VALID) {
        return false;
    }
    vec3 n = unpack_normal(entry.normal);
    float limit = params.plane_threshold * max(view_depth(entry.position), 1e-6);
    uint material = cache_material(entry);
    bool planar = true;
    [[unroll]] for (uint k = 0u; k < 4u; ++k) {
        uvec2 corner = uvec2((k & 1u) != 0u ? sx.y : sx.x, (k & 2u) != 0u ? sy.y : sy.x);
        CacheEntry o = CACHE_NEXT(corner.y * frame.width + corner.x);
        planar = planar && (o.meta & required) == CACHE_VALID && cache_material(o) == material
            && abs(dot(o.position - entry.position, n)) <= limit && dot(unpack_normal(o.normal), n) >= params.normal_threshold;
    }
    vec3 hit;
    if (!planar || !pixel_ray_meets_plane(pix, entry.position, n, hit)) {
        return false;
    }
    entry.position = hit;
    entry.meta = new_cache_meta(CACHE_VALID, 1u, material);
    return true;
}

// Adaptive sub-sampling (the seed's): a block whose four corners and centre differ by at most
// the threshold is filled by interpolation: bilinear between the corners plus the centre's
// deviation from it, fading out towards the block edges (quincunx). Other blocks stay for the
// next level.
bool interpolate(uint q) {
    uint st = STATE(q);
    if ((st & PX_KIND_MASK) != PX_TRACE) {
        return false;
    }
    uvec2 pix = pixel_of(q);
    uint l = pc.level;
    uvec2 sx = block_span(pix.x, frame.width, l);
    uvec2 sy = block_span(pix.y, frame.height, l);
    uvec2 centre = uvec2((sx.x + sx.y) / 2u, (sy.x + sy.y) / 2u);
    vec3 c00 = color_at(sx.x, sy.x), c10 = color_at(sx.y, sy.x);
    vec3 c01 = color_at(sx.x, sy.y), c11 = color_at(sx.y, sy.y);
    vec3 cc = color_at(centre.x, centre.y);
    float d = max(max(differ(c00, c10), differ(c00, c01)), max(differ(c00, c11), differ(c00, cc)));
    d = max(d, max(max(differ(c10, c01), differ(c10, c11)), max(differ(c10, cc), differ(c01, c11))));
    d = max(d, max(differ(c01, cc), differ(c11, cc)));
    if (d > params.subsample_threshold) {
        return false;
    }
    vec2 span = vec2(max(sx.y - sx.x, 1u), max(sy.y - sy.x, 1u));
    vec2 uv = (vec2(pix) - vec2(sx.x, sy.x)) / span;
    vec2 uvc = (vec2(centre) - vec2(sx.x, sy.x)) / span;
    vec3 bil_c = mix(mix(c00, c10, uvc.x), mix(c01, c11, uvc.x), uvc.y);
    vec3 bil = mix(mix(c00, c10, uv.x), mix(c01, c11, uv.x), uv.y);
    vec3 c = bil + (cc - bil_c) * tent(uv.x, uvc.x) * tent(uv.y, uvc.y);
    c = max(c, vec3(0.0));
    uint display = store_color(q, c);
    STATE(q) = (st & ~PX_KIND_MASK) | PX_INTERP;
    bool rt = (params.flags & RP_GBUFFER) == 0u;
    CacheEntry planar;
    if (rt && block_on_one_plane(sx, sy, centre, pix, planar)) {
        // The block's samples lie on one plane: cached where this pixel's ray meets it.
        planar.color = c;
        planar.display = display;
        CACHE_NEXT(q) = planar;
    } else if (rt) {
        // No primary hit to cache the colour at: the colour is for the next level's
        // interpolation only, and the entry stays empty, so next frame the pixel is filled
        // from a neighbour's sample or traced. (A primary ray per such pixel, for its entry,
        // cost more than the rays it spared later, and the interpolated colours it kept
        // showed for frames: 0.213 -> 0.189 of the rays at FLIP 0.048 -> 0.045, built-in.)
        CACHE_NEXT(q).color = c;
        CACHE_NEXT(q).display = display;
        CACHE_NEXT(q).meta = 0u;
    } else {
        // Hybrid path: cached at the pixel's primary hit in the G-buffer, flagged so that
        // fills do not copy it.
        ivec2 ip = ivec2(pix);
        uvec4 ids = imageLoad(g_ids, ip);
        CacheEntry e;
        e.color = c;
        e.display = display;
        if (ids.x == 0xFFFFFFFFu) {
            e.position = camera_ray(vec2(pix) + 0.5).dir;
            e.normal = 0u;
            e.meta = CACHE_VALID | CACHE_MISS;
        } else {
            vec4 n = imageLoad(g_normal, ip);
            vec4 ng = imageLoad(g_geometric, ip);
            vec4 base = imageLoad(g_base, ip);
            uint material = ids.z & 0x7FFFFFFFu;
            bool vd = surface_view_dependent(ng.w, n.w, uintBitsToFloat(ids.w), scene_material(material).alpha_mode, base.a);
            e.position = imageLoad(g_position, ip).xyz;
            e.normal = pack_normal(ng.xyz);
            e.meta = new_cache_meta(CACHE_VALID | (vd ? CACHE_VIEW_DEPENDENT : 0u), 1u, material);
        }
        CACHE_NEXT(q) = e;
        anchor_from_gbuffer(q, ip);
    }
    return true;
}

// The state classify counts for pixel q: 0 while the pixel is undecided (a candidate for the
// visibility pass, which settles it).
uint settled_state(uint st) {
    return (st & PX_KIND_MASK) == PX_VERIFY ? 0u : st;
}

// Whether the visibility pass (rt path) looks at pixel q: the candidates. (Pixels that need new
// colour trace their own primary ray: a visibility round trip for every such pixel cost more
// than it saved.)
bool wants_visibility(uint st) {
    return (st & PX_KIND_MASK) == PX_VERIFY;
}

void main() {
    if (STAGE == STAGE_THRESHOLD) {
        if (gl_GlobalInvocationID.x == 0u && gl_GlobalInvocationID.y == 0u) {
            threshold();
        }
        return;
    }
    uvec2 pix = gl_GlobalInvocationID.xy;
    bool inside = pix.x < frame.width && pix.y < frame.height;
    uint q = pix.y * frame.width + pix.x;
    if (STAGE == STAGE_INTERPOLATE) {
        // Dispatched over the pending pixels' job list (one job per invocation), not the image.
        uint i = linear_invocation(gl_WorkGroupSize.x * gl_WorkGroupSize.y);
        inside = i < job_count(LIST_PENDING);
        q = inside ? job_at(LIST_PENDING, i) : 0u;
        pix = pixel_of(q);
    }
    bool settling = STAGE == STAGE_CLASSIFY;
    uint settled = 0u;
    uint st = 0u;
    bool interpolated = false;
    if (inside) {
        switch (STAGE) {
        case STAGE_SCATTER:
        case STAGE_RESOLVE: {
            // Thread q reprojects the sample cached at pixel q of the previous frame. Nearest
            // depth wins; equal depths go to the lowest source index, so the result is
            // deterministic.
            // The scatter moves samples on moving geometry with their objects first.
            // (No ?: between the two: glslang mistypes a buffer struct against a local one.)
            CacheEntry e;
            if (STAGE == STAGE_SCATTER) {
                e = moved_entry(q);
            } else {
                e = CACHE_PREV(q);
            }
            uint target, key;
            if ((e.meta & CACHE_VALID) != 0u && project_sample(e, target, key)) {
                if (STAGE == STAGE_SCATTER) {
                    atomicMin(DEPTH_KEY(target), key);
                } else if (DEPTH_KEY(target) == key) {
                    atomicMin(WINNER(target), q);
                }
            }
            break;
        }
        case STAGE_SHOWN: record_shown(q, pix); break;
        case STAGE_CLASSIFY: st = classify(q, ivec2(pix)); break;
        case STAGE_INTERPOLATE: interpolated = interpolate(q); break;
        default: break;
        }
        if (settling) {
            settled = settled_state(st);
        }
    }
    if (settling) {
        // Settled pixels are counted, and the pixels left for rays are listed: those the
        // visibility pass looks at first, and the others to trace at the first level.
        bool look = inside && wants_visibility(st);
        bool adaptive = (params.flags & RP_ADAPTIVE) != 0u;
        bool leader = subgroupElect();
        settle_and_list(settled, uvec3(LIST_VERIFY, LIST_TRACE, LIST_PENDING),
                        bvec3(look, inside && !look && traced_at(st, pix, pc.gather), adaptive && inside && (st & PX_KIND_MASK) == PX_TRACE),
                        adaptive ? 3u : 2u, q, leader);
        lists_done((1u << LIST_VERIFY) | (1u << LIST_TRACE) | (adaptive ? 1u << LIST_PENDING : 0u), leader);
    } else if (STAGE == STAGE_INTERPOLATE) {
        COUNTER_ADD(counters[stat_slot(C_INTERP)], interpolated ? 1u : 0u);
        // The next level's pixels to trace; the interpolation counts itself above, so
        // nothing settles here.
        if (pc.gather != GATHER_NONE) {
            bool leader = subgroupElect();
            settle_and_list(0u, uvec3(LIST_VERIFY), bvec3(inside && traced_at(STATE(q), pix, pc.gather), false, false), 2u, q, leader);
            lists_done(1u << LIST_VERIFY, leader);
        }
    }
}
