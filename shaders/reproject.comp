#version 460
// Temporal reprojection, the stages that trace no rays (src/render/reproject.rs records them):
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

layout(local_size_x = 8, local_size_y = 8) in;
// stage: what runs; level: the adaptive level it works at (interpolate); gather: the job list
// it appends to afterwards (GATHER_NONE, GATHER_VERIFY, or a trace level 1, 2, 4).
layout(push_constant) uniform Push { uint stage; uint level; uint gather; } pc;

#define STAGE_SCATTER 0u
#define STAGE_RESOLVE 1u
#define STAGE_CLASSIFY 2u
#define STAGE_THRESHOLD 3u
#define STAGE_SELECT 4u
#define STAGE_COMMIT 6u
#define STAGE_INTERPOLATE 7u
#define STAGE_STATS 8u
#define STAGE_FILL 9u

// Job list selector (pc.gather): 0 = pixels to verify; 1, 2, 4 = pixels to trace at that level.
#define GATHER_VERIFY 0u
#define GATHER_NONE 0xFFFFFFFFu

CacheEntry empty_entry() {
    return CacheEntry(vec4(0.0), vec4(0.0), vec4(0.0), uvec4(0u));
}

// Adaptive sub-sampling blocks of L x L pixels share their corners with their neighbours:
// block b spans pixels [b L, min(b L + L, n - 1)], and pixel x belongs to block
// min(x / L, blocks - 1) (so the last row/column closes the last block).
uint block_count(uint n, uint l) { return max(1u, (n - 1u + l - 1u) / l); }

uvec2 block_span(uint x, uint n, uint l) {
    uint x0 = min(x / l, block_count(n, l) - 1u) * l;
    return uvec2(x0, min(x0 + l, n - 1u));
}

bool is_block_sample(uvec2 pix, uint l) {
    uvec2 sx = block_span(pix.x, frame.width, l);
    uvec2 sy = block_span(pix.y, frame.height, l);
    bool corner = (pix.x == sx.x || pix.x == sx.y) && (pix.y == sy.x || pix.y == sy.y);
    bool centre = pix.x == (sx.x + sx.y) / 2u && pix.y == (sy.x + sy.y) / 2u;
    return corner || centre;
}

vec3 color_at(uint x, uint y) { return color[y * frame.width + x].rgb; }

// Render Cache-style edge test for the rt path without a full primary-visibility pass: a
// sample is trusted when the samples of its 3x3 neighbourhood lie on the same smooth surface.
// A surface that was hidden comes into view next to the silhouette that hid it, a depth edge,
// so the pixels there get a primary ray. (A hidden surface coming out from behind an edge
// faster than a pixel per frame can show the farther surface for a few frames beyond that
// band: the price of the mode; --rt-visibility full and the hybrid path check every pixel.)
bool near_edge(ivec2 pix, CacheEntry e) {
    bool miss = (e.meta.x & CACHE_MISS) != 0u;
    float z = miss ? 1.0 : max(view_depth(e.position.xyz), 1e-6);
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 n = pix + ivec2(dx, dy);
            if ((dx == 0 && dy == 0) || n.x < 0 || n.y < 0 || n.x >= int(frame.width) || n.y >= int(frame.height)) {
                continue;
            }
            Shown o = shown[uint(n.y) * frame.width + uint(n.x)];
            if (o.meta.x == 0u) {
                // An empty neighbour is traced this frame anyway. Counting it as an edge
                // would verify the neighbourhood of every pixel a stretched surface leaves
                // empty: on an orbit, most of the rays this mode saves.
                continue;
            }
            bool other_miss = (o.meta.x & CACHE_MISS) != 0u;
            if (other_miss != miss) {
                return true;
            }
            if (!miss && (abs(dot(o.position.xyz - e.position.xyz, e.normal.xyz)) / z > params.edge_threshold
                    || dot(o.normal.xyz, e.normal.xyz) < params.normal_threshold)) {
                return true;
            }
        }
    }
    return false;
}

// Reprojected point samples leave empty pixels where a surface is seen a little larger than
// before, and along the seams between regions whose samples have different sub-pixel offsets
// (samples keep the world position their colour belongs to). Left alone, each such pixel is
// traced at its centre, starts a region with yet another offset, and empty pixels multiply
// frame after frame. So an empty pixel takes the neighbouring pixel's sample that projects
// nearest to its centre, within fill_radius pixels (nearest first, then the lowest source
// index): a splat footprint, as in the Render Cache. The pixel still goes through the
// visibility tests (the G-buffer; on the rt path the edge test or a primary ray), so a
// disocclusion is not filled with whatever lies next to it.
void fill(uint q) {
    if (WINNER(q) != NO_SAMPLE) {
        return;
    }
    vec2 centre = vec2(pixel_of(q)) + 0.5;
    ivec2 pix = ivec2(pixel_of(q));
    uint best = NO_SAMPLE;
    float best_d = params.fill_radius;
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 n = pix + ivec2(dx, dy);
            if ((dx == 0 && dy == 0) || n.x < 0 || n.y < 0 || n.x >= int(frame.width) || n.y >= int(frame.height)) {
                continue;
            }
            uint w = WINNER(uint(n.y) * frame.width + uint(n.x));
            uint target, key;
            vec2 film;
            if (w == NO_SAMPLE) {
                continue;
            }
            CacheEntry e = cache_prev[w];
            // Copies are made of samples that sit where their colour was computed (not of
            // fills or interpolations), so a colour moves at most one fill radius.
            if (cache_hops(e) >= params.max_hops || !project_sample(e, target, key, film)) {
                continue;
            }
            float d = distance(film, centre);
            if (d < best_d || (d == best_d && w < best)) {
                best_d = d;
                best = w;
            }
        }
    }
    if (best != NO_SAMPLE) {
        // The fill pass reads neighbours' winners, so its choice waits in the depth key
        // (free on empty pixels); later stages read it through resolved_winner().
        DEPTH_KEY(q) = FILLED_KEY | best;
    }
}

// The fill stage's second half: records the sample pixel q shows (its winner, or the fill's
// choice) in pixel order for the stages after it.
void record_shown(uint q) {
    uint w = resolved_winner(q);
    Shown sh;
    if (w == NO_SAMPLE) {
        sh.position = vec4(0.0);
        sh.normal = vec4(0.0);
        sh.meta = uvec4(0u);
    } else {
        CacheEntry e = cache_prev[w];
        sh.position = e.position;
        sh.normal = e.normal;
        sh.meta = e.meta;
    }
    shown[q] = sh;
}

bool is_filled(uint q) {
    uint k = DEPTH_KEY(q);
    return k != NO_SAMPLE && k >= FILLED_KEY;
}

void count_candidate(uint q, uint age);

void classify(uint q) {
    uint w = resolved_winner(q);
    uint st;
    CacheEntry e = empty_entry();
    if ((params.flags & RP_REUSE) == 0u) {
        st = PX_TRACE;
    } else if (w == NO_SAMPLE) {
        st = PX_TRACE | PX_HOLE;
    } else {
        e = shown_entry(q);
        if ((e.meta.x & CACHE_VIEW_DEPENDENT) != 0u) {
            st = PX_TRACE | PX_VIEW_DEPENDENT;
        } else if (e.meta.w >= params.max_age) {
            st = PX_TRACE | PX_EXPIRED;
        } else if ((params.flags & RP_GBUFFER) != 0u) {
            st = judge_against_gbuffer(ivec2(pixel_of(q)), e);
        } else if ((params.flags & RP_VERIFY_ALL) != 0u || near_edge(ivec2(pixel_of(q)), e)) {
            st = PX_VERIFY;
        } else {
            st = PX_REUSE;
        }
    }
    if (w != NO_SAMPLE && is_filled(q)) {
        st |= PX_FILLED;
    }
    state[q] = st;
    uint kind = st & PX_KIND_MASK;
    if ((params.flags & RP_FRAMELESS) != 0u) {
        if (kind == PX_REUSE || kind == PX_VERIFY) {
            count_candidate(q, e.meta.w);
        } else {
            atomicAdd(counters[C_FORCED], 1u);
        }
    }
}

// Frameless refresh order: oldest first, and among samples of one age by a fixed
// interleaved-gradient-noise rank of the pixel (Jimenez 2014). A fixed rank makes the refresh
// sweep through a stratified permutation of the image: what one frame refreshes is spread
// evenly, and the next frame continues where it stopped.
float refresh_rank(uvec2 pix) {
    return fract(52.9829189 * fract(0.06711056 * float(pix.x) + 0.00583715 * float(pix.y)));
}

// Histogram bin of a candidate: lower bins are refreshed first.
uint refresh_bin(uint age, float rank) {
    return (AGE_LEVELS - 1u - min(age, AGE_LEVELS - 1u)) * RANK_LEVELS + min(uint(rank * float(RANK_LEVELS)), RANK_LEVELS - 1u);
}

void count_candidate(uint q, uint age) {
    atomicAdd(counters[C_CANDIDATES], 1u);
    atomicAdd(counters[C_HISTOGRAM + refresh_bin(age, refresh_rank(pixel_of(q)))], 1u);
}

// Frameless budget: re-trace frameless_fraction of all pixels per frame. Pixels that must be
// traced anyway count first; the rest of the budget goes to candidates in refresh order. Finds
// the bin where the budget runs out and the share of that bin to take.
void threshold() {
    uint budget = uint(ceil(params.frameless_fraction * float(pixel_count())));
    uint forced = counters[C_FORCED];
    uint extra = budget > forced ? budget - forced : 0u;
    uint bin = NO_SAMPLE;
    float fraction = 0.0;
    if (extra > 0u) {
        uint acc = 0u;
        bin = HISTOGRAM_BINS;
        for (uint b = 0u; b < HISTOGRAM_BINS; ++b) {
            uint h = counters[C_HISTOGRAM + b];
            if (h > 0u && acc + h >= extra) {
                bin = b;
                fraction = float(extra - acc) / float(h);
                break;
            }
            acc += h;
        }
    }
    counters[C_THRESHOLD_BIN] = bin;
    counters[C_THRESHOLD_FRACTION] = floatBitsToUint(fraction);
}

void select_frameless(uint q) {
    uint st = state[q];
    uint kind = st & PX_KIND_MASK;
    uint limit = counters[C_THRESHOLD_BIN];
    if ((kind != PX_REUSE && kind != PX_VERIFY) || limit == NO_SAMPLE) {
        return;
    }
    float rank = refresh_rank(pixel_of(q));
    uint bin = refresh_bin(shown[q].meta.w, rank);
    // Within the last bin, the rank's finer digits decide.
    float within = fract(rank * float(RANK_LEVELS));
    if (bin < limit || (bin == limit && within < uintBitsToFloat(counters[C_THRESHOLD_FRACTION]))) {
        state[q] = PX_TRACE | PX_FRAMELESS;
    }
}

// Whether pixel q belongs on job list `list` (pc.gather).
bool wanted(uint q, uint list) {
    uint kind = state[q] & PX_KIND_MASK;
    // With adaptive sub-sampling on the rt path, pixels to trace get their primary ray in the
    // visibility pass too, so interpolated pixels know their hit and can be cached.
    return list == GATHER_VERIFY
        ? kind == PX_VERIFY || (kind == PX_TRACE && (params.flags & (RP_ADAPTIVE | RP_GBUFFER)) == RP_ADAPTIVE)
        : kind == PX_TRACE && (list == 1u || is_block_sample(pixel_of(q), list));
}

// Stream compaction of the job list, in tile order: every subgroup writes its jobs
// contiguously in invocation order after one atomic (a subgroup covers one or more rows of the
// 8x8 tile), so neighbouring lanes of a tracing pass trace neighbouring pixels. The last
// subgroup to finish turns the list's length into the tracing pass's indirect dispatch (and
// starts the next list at zero), so no separate pass and barrier is needed for that. No
// workgroup barrier: a CPU device (lavapipe) runs shaders with barrier() as coroutines, which
// cost more than the atomics they would save.
void append_job(bool take, uint q) {
    uint t = take ? 1u : 0u;
    uint within = subgroupExclusiveAdd(t);
    uint total = subgroupAdd(t);
    uint base = 0u;
    if (subgroupElect()) {
        base = total > 0u ? atomicAdd(counters[C_JOBS], total) : 0u;
        // This subgroup's share of the count is added before it counts itself done.
        memoryBarrierBuffer();
        uint subgroups = gl_NumWorkGroups.x * gl_NumWorkGroups.y * gl_NumSubgroups;
        if (atomicAdd(counters[C_TILES_DONE], 1u) + 1u == subgroups) {
            uint n = atomicExchange(counters[C_JOBS], 0u);
            dispatch_args[0] = (n + 63u) / 64u;
            dispatch_args[1] = 1u;
            dispatch_args[2] = 1u;
            dispatch_args[3] = n;
            counters[C_TILES_DONE] = 0u;
        }
    }
    base = subgroupBroadcastFirst(base);
    if (take) {
        jobs[base + within] = q;
    }
}

// Reused pixels take their sample's colour (a miss: the background seen along this pixel's
// own ray) and carry the sample, one frame older, into the next cache. Every other pixel
// starts the next cache empty; the tracing pass fills the ones it traces.
void commit(uint q) {
    uint st = state[q];
    if ((st & PX_KIND_MASK) != PX_REUSE) {
        cache_next[q] = empty_entry();
        return;
    }
    CacheEntry e = cache_prev[resolved_winner(q)];
    vec3 c = e.color.rgb;
    if ((e.meta.x & CACHE_MISS) != 0u) {
        c = background_radiance(camera_ray(vec2(pixel_of(q)) + 0.5).dir);
    }
    color[q] = vec4(c, 1.0);
    e.meta.w += 1u;
    if ((st & PX_FILLED) != 0u && (e.meta.x & CACHE_MISS) != 0u) {
        // A miss's colour is recomputed per pixel: the copy simply becomes this pixel's.
        e.position = vec4(camera_ray(vec2(pixel_of(q)) + 0.5).dir, 0.0);
    } else if ((st & PX_FILLED) != 0u) {
        // A fill carries a copy of a neighbour's colour. Cached as it is, the copy would
        // collide with its original next frame and leave the pixel empty again, so the
        // sample density of a surface seen larger and larger would only fall. Instead it
        // becomes this pixel's sample at this pixel's primary hit: the G-buffer's where
        // there is one, else where this pixel's ray meets the copied sample's plane (the
        // neighbourhood passed the edge test, so it is that smooth surface).
        ivec2 pix = ivec2(pixel_of(q));
        if ((params.flags & RP_GBUFFER) != 0u || (st & PX_VERIFIED) != 0u) {
            e.position = vec4(imageLoad(g_position, pix).xyz, 1.0);
            e.normal = vec4(imageLoad(g_geometric, pix).xyz, 0.0);
        } else {
            Ray r = camera_ray(vec2(pix) + 0.5);
            float denom = dot(r.dir, e.normal.xyz);
            if (abs(denom) > 1e-4) {
                float t = dot(e.position.xyz - r.origin, e.normal.xyz) / denom;
                if (t > 0.0) {
                    e.position = vec4(r.origin + t * r.dir, 1.0);
                }
            }
        }
        e.meta.x = with_hops(e.meta.x, cache_hops(e) + 1u);
    }
    cache_next[q] = e;
}

// Compared as displayed, roughly (Reinhard, gamma 2.2): a linear difference that is
// invisible in a bright region is a visible step in a dark one.
vec3 display(vec3 c) {
    vec3 v = max(c, vec3(0.0));
    return pow(v / (1.0 + v), vec3(1.0 / 2.2));
}

float differ(vec3 x, vec3 y) {
    vec3 d = abs(display(x) - display(y));
    return max(d.x, max(d.y, d.z));
}

// Tent weight that is 1 at `c` and 0 at both ends of [0, 1].
float tent(float u, float c) {
    return u <= c ? (c > 0.0 ? u / c : 1.0) : (c < 1.0 ? (1.0 - u) / (1.0 - c) : 1.0);
}

// Adaptive sub-sampling (the seed's): a block whose four corners and centre differ by at most
// the threshold is filled by interpolation: bilinear between the corners plus the centre's
// deviation from it, fading out towards the block edges (quincunx). Other blocks stay for the
// next level.
void interpolate(uint q) {
    uint st = state[q];
    if ((st & PX_KIND_MASK) != PX_TRACE) {
        return;
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
        return;
    }
    vec2 span = vec2(max(sx.y - sx.x, 1u), max(sy.y - sy.x, 1u));
    vec2 uv = (vec2(pix) - vec2(sx.x, sy.x)) / span;
    vec2 uvc = (vec2(centre) - vec2(sx.x, sy.x)) / span;
    vec3 bil_c = mix(mix(c00, c10, uvc.x), mix(c01, c11, uvc.x), uvc.y);
    vec3 bil = mix(mix(c00, c10, uv.x), mix(c01, c11, uv.x), uv.y);
    vec3 c = bil + (cc - bil_c) * tent(uv.x, uvc.x) * tent(uv.y, uvc.y);
    c = max(c, vec3(0.0));
    color[q] = vec4(c, 1.0);
    state[q] = (st & ~PX_KIND_MASK) | PX_INTERP;
    if ((params.flags & RP_GBUFFER) != 0u || (st & PX_VERIFIED) != 0u) {
        // Cached at the pixel's primary hit, flagged so that fills do not copy it.
        ivec2 ip = ivec2(pix);
        uvec4 ids = imageLoad(g_ids, ip);
        CacheEntry e;
        e.color = vec4(c, 1.0);
        if (ids.x == 0xFFFFFFFFu) {
            e.position = vec4(camera_ray(vec2(pix) + 0.5).dir, 0.0);
            e.normal = vec4(0.0);
            e.meta = uvec4(CACHE_VALID | CACHE_MISS, 0u, NO_SAMPLE, 0u);
        } else {
            vec4 n = imageLoad(g_normal, ip);
            vec4 ng = imageLoad(g_geometric, ip);
            vec4 base = imageLoad(g_base, ip);
            uint material = ids.z & 0x7FFFFFFFu;
            bool vd = surface_view_dependent(ng.w, n.w, uintBitsToFloat(ids.w), scene_material(material).alpha_mode, base.a);
            e.position = vec4(imageLoad(g_position, ip).xyz, 1.0);
            e.normal = vec4(ng.xyz, 0.0);
            e.meta = uvec4(with_hops(CACHE_VALID | (vd ? CACHE_VIEW_DEPENDENT : 0u), 1u), material, ids.x, 0u);
        }
        cache_next[q] = e;
    }
}

// Statistics of the frame's final pixel states: summed per subgroup, one atomic per subgroup
// and counter (no workgroup barrier, see append_job).
void stats(uint q, bool inside) {
    uint st = inside ? state[q] : 0u;
    uint kind = inside ? st & PX_KIND_MASK : 0u;
    COUNTER_ADD(counters[C_REUSED], kind == PX_REUSE ? 1u : 0u);
    COUNTER_ADD(counters[C_TRACED], kind == PX_TRACED ? 1u : 0u);
    COUNTER_ADD(counters[C_INTERP], kind == PX_INTERP ? 1u : 0u);
    COUNTER_ADD(counters[C_HOLES], (st & PX_HOLE) != 0u ? 1u : 0u);
    COUNTER_ADD(counters[C_REJECTED], (st & PX_REJECTED) != 0u ? 1u : 0u);
    COUNTER_ADD(counters[C_VIEW_DEPENDENT], (st & PX_VIEW_DEPENDENT) != 0u ? 1u : 0u);
    COUNTER_ADD(counters[C_EXPIRED], (st & PX_EXPIRED) != 0u ? 1u : 0u);
    COUNTER_ADD(counters[C_FRAMELESS], (st & PX_FRAMELESS) != 0u ? 1u : 0u);
    COUNTER_ADD(counters[C_FILLED], (st & PX_FILLED) != 0u && kind == PX_REUSE ? 1u : 0u);
}

void main() {
    if (pc.stage == STAGE_THRESHOLD) {
        if (gl_GlobalInvocationID.x == 0u && gl_GlobalInvocationID.y == 0u) {
            threshold();
        }
        return;
    }
    uvec2 pix = gl_GlobalInvocationID.xy;
    bool inside = pix.x < frame.width && pix.y < frame.height;
    uint q = pix.y * frame.width + pix.x;
    if (inside) {
        switch (pc.stage) {
        case STAGE_SCATTER:
        case STAGE_RESOLVE: {
            // Thread q reprojects the sample cached at pixel q of the previous frame. Nearest
            // depth wins; equal depths go to the lowest source index, so the result is
            // deterministic.
            CacheEntry e = cache_prev[q];
            uint target, key;
            vec2 film;
            if ((e.meta.x & CACHE_VALID) != 0u && project_sample(e, target, key, film)) {
                if (pc.stage == STAGE_SCATTER) {
                    atomicMin(DEPTH_KEY(target), key);
                } else if (DEPTH_KEY(target) == key) {
                    atomicMin(WINNER(target), q);
                }
            }
            break;
        }
        case STAGE_FILL:
            fill(q);
            record_shown(q);
            break;
        case STAGE_CLASSIFY: classify(q); break;
        case STAGE_SELECT: select_frameless(q); break;
        case STAGE_COMMIT: commit(q); break;
        case STAGE_INTERPOLATE: interpolate(q); break;
        default: break;
        }
    }
    if (pc.stage == STAGE_STATS) {
        stats(q, inside);
    }
    if (pc.gather != GATHER_NONE) {
        append_job(inside && wanted(q, pc.gather), q);
    }
}
