// Temporal reprojection (src/render/passes/reproject/): the per-pixel sample cache, pixel states,
// parameters and the tests shared by reproject.comp, reproject_primary.comp and
// reproject_trace.comp. Include after scene.glsl and frame.glsl.
//
// Every binding, flag, stage, counter slot and shared struct (CacheEntry, Shown, GpuParams,
// the push constants) is declared once, in src/interface/reproject.rs, from which build.rs
// generates interface_reproject.glsl.
#ifndef RQR_REPROJECT_GLSL
#define RQR_REPROJECT_GLSL
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
// [[unroll]] on the short loops over neighbours and counters: a CPU device (lavapipe) keeps a
// local array indexed by a loop variable on the stack and gathers from it lane by lane.
#extension GL_EXT_control_flow_attributes : require
#include "counters.glsl"
#include "interface_passes.glsl"
#include "tonemap.glsl"
#include "interface_reproject.glsl"
#include "environment.glsl"

// CacheEntry: a cached sample, the colour of one primary hit and where it was. meta holds
// CACHE_* flags in bits 0-3; bits 4-5 count how many fills away from where it was computed the
// colour is (an interpolated colour counts as one; a fill copies only samples below
// params.max_hops); bits 6-15 its age in frames (saturating at MAX_CACHE_AGE); bits 16-31 its
// material.
uint cache_hops(CacheEntry e) { return (e.meta >> CACHE_HOPS_SHIFT) & 3u; }
uint with_hops(uint meta, uint hops) { return (meta & ~(3u << CACHE_HOPS_SHIFT)) | (min(hops, 3u) << CACHE_HOPS_SHIFT); }
uint cache_age(uint meta) { return (meta >> CACHE_AGE_SHIFT) & MAX_CACHE_AGE; }
// One frame older (saturating).
uint aged(uint meta) { return cache_age(meta) < MAX_CACHE_AGE ? meta + (1u << CACHE_AGE_SHIFT) : meta; }
uint cache_material(CacheEntry e) { return e.meta >> CACHE_MATERIAL_SHIFT; }
// The meta word of a new sample of `material`, `hops` fills away from computed colour (an
// interpolated colour counts as one), age 0.
uint new_cache_meta(uint flags, uint hops, uint material) { return with_hops(flags, hops) | (material << CACHE_MATERIAL_SHIFT); }
bool cache_miss(CacheEntry e) { return (e.meta & CACHE_MISS) != 0u; }

// Unit normals in one word: octahedral coordinates (Cigolle et al. 2014), 14 bits each in
// bits 18-31 and 4-17 (bits 0-3 are left for Shown's flags). About 2e-4 rad of error, far
// below the normal and plane thresholds that read it.
vec2 oct_wrap(vec2 v) { return (1.0 - abs(v.yx)) * vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0); }
uint pack_normal(vec3 n) {
    n /= max(abs(n.x) + abs(n.y) + abs(n.z), 1e-20);
    vec2 o = n.z >= 0.0 ? n.xy : oct_wrap(n.xy);
    uvec2 u = uvec2(round(clamp(o * 0.5 + 0.5, 0.0, 1.0) * 16383.0));
    return (u.x << 18) | (u.y << 4);
}
// (The z < 0 half is unfolded without branches, Stubbe's form of oct_wrap, and normalized by
// one reciprocal square root: the edge test unpacks five normals per pixel.)
vec3 unpack_normal(uint p) {
    vec2 o = vec2(uvec2(p >> 18, (p >> 4) & 0x3FFFu)) * (2.0 / 16383.0) - 1.0;
    vec3 n = vec3(o, 1.0 - abs(o.x) - abs(o.y));
    float t = max(-n.z, 0.0);
    n.xy += vec2(n.x >= 0.0 ? -t : t, n.y >= 0.0 ? -t : t);
    return n * inversesqrt(dot(n, n));
}

// Pixel state: a PX_* kind in the low bits plus the reasons that led to it (for statistics).
// A depth key with FILLED_KEY marks an empty pixel filled from a neighbour (plus the source
// index); real keys are positive float bits.

layout(set = 0, binding = BINDING_RP_PARAMS, scalar) uniform Params { GpuParams params; };

// The per-pixel buffers, through buffer references at the addresses in `params` (GpuParams:
// a CPU device (lavapipe) gathers and scatters through a buffer reference with vector
// instructions, where it accesses a descriptor-bound buffer lane by lane). Not readonly:
// with moving geometry the scatter moves each entry with its object (reproject_anchor.glsl).
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer CacheEntries { CacheEntry v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer Words { uint v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer Colors { vec4 v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer ShownRecords { Shown v[]; };
// The cache this frame reads (the previous frame's samples) and the one it writes.
#define CACHE_PREV(i) CacheEntries(params.cache_prev).v[i]
#define CACHE_NEXT(i) CacheEntries(params.cache_next).v[i]
// Per pixel, interleaved: word 2q is the index of the sample that won pixel q, word 2q + 1 its
// depth key. Where the device has 64-bit atomics, one atomicMin of key << 32 | index on the
// pair (little-endian: index in the low word) picks the nearest sample and breaks depth ties
// by the lowest index in one pass (reproject_scatter64.comp); otherwise two 32-bit passes do.
#ifndef RQR_KEY_WINNER_64
#define WINNER(q) Words(params.key_winner).v[2u * (q)]
#define DEPTH_KEY(q) Words(params.key_winner).v[2u * (q) + 1u]
#endif
// Per pixel: the PX_* state, the linear colour (EXR output only), the display value (RGBA8).
#define STATE(q) Words(params.states).v[q]
#define LINEAR_COLOR(q) Colors(params.colors).v[q]
#define DISPLAY(q) Words(params.display).v[q]
// The job lists share one buffer: list k holds jobs [k n, k n + n), n = pixels.
#define JOBS(i) Words(params.jobs).v[i]
layout(set = 0, binding = BINDING_RP_COUNTERS, std430) buffer Counters { uint counters[]; };
// The G-buffer images (gbuffer.frag's layout): the raster pass's (hybrid) or the visibility
// pass's (rt).
layout(set = 0, binding = BINDING_RP_GBUFFER + GBUFFER_POSITION, rgba32f) uniform image2D g_position;   // world position, t
layout(set = 0, binding = BINDING_RP_GBUFFER + GBUFFER_NORMAL, rgba32f) uniform image2D g_normal;       // shading normal, roughness
layout(set = 0, binding = BINDING_RP_GBUFFER + GBUFFER_GEOMETRIC, rgba32f) uniform image2D g_geometric; // front-face normal, metallic
layout(set = 0, binding = BINDING_RP_GBUFFER + GBUFFER_BASE, rgba16f) uniform image2D g_base;           // base colour, alpha
layout(set = 0, binding = BINDING_RP_GBUFFER + GBUFFER_EMISSIVE, rgba16f) uniform image2D g_emissive;   // emissive, occlusion
layout(set = 0, binding = BINDING_RP_GBUFFER + GBUFFER_IDS, rgba32ui) uniform uimage2D g_ids;          // instance, primitive, material | front << 31, transmission bits
layout(set = 0, binding = BINDING_RP_GBUFFER + GBUFFER_BARY, rgba32f) uniform image2D g_bary;           // barycentrics, motion
// Per job list k: the indirect dispatch of the pass that works through it (x, y, z
// workgroups) and its job count, at dispatch_args[4 k, 4 k + 4); written by the last subgroup
// of the pass that appended to the list (lists_done()).
layout(set = 0, binding = BINDING_RP_DISPATCH_ARGS, std430) buffer DispatchArgs { uint dispatch_args[4 * JOB_LISTS]; };

// Per pixel, what the edge test needs of the cached sample it shows after the scatter (Shown:
// its tangent plane's offset and packed normal with SHOWN_* flags; 0 where no sample landed).
// Written in pixel order by the shown stage, so the stage that looks at a pixel's neighbours
// reads neighbouring memory instead of gathering whole cache entries from wherever they came
// from.
#define SHOWN(q) ShownRecords(params.shown).v[q]

uint pixel_count() { return frame.width * frame.height; }

// Shows colour `c` at pixel q: its display value, and its linear colour where a reader
// wants it.
void show_color(uint q, vec3 c, uint display) {
    if ((params.flags & RP_LINEAR_COLOR) != 0u) {
        LINEAR_COLOR(q) = vec4(c, 1.0);
    }
    DISPLAY(q) = display;
}

// Shows new colour `c` at pixel q, tonemapped here (a separate pass would read every colour
// back). Returns the display value, for the pixel's cache entry.
uint store_color(uint q, vec3 c) {
    uint display = tonemap_rgba8(c, params.tonemap_op, params.tonemap_scale);
    show_color(q, c, display);
    return display;
}

// Job lists. The stage that settles the pixels lists those the visibility pass looks at (list
// 0, rt path) and the first pixels to trace (list 1); the visibility pass adds the candidates
// it rejects to list 1; each adaptive interpolation lists the next level's pixels in list 0,
// whose visibility jobs are done by then. Tracing passes run one job per invocation, 64 per
// workgroup.
uint job_count(uint list) { return dispatch_args[4u * list + 3u]; }
uint job_at(uint list, uint i) { return JOBS(list * pixel_count() + i); }

// The counter slot that holds list `list`'s length while stages append to it.
uint list_counter(uint list) {
    return list == LIST_VERIFY ? C_JOBS : (list == LIST_TRACE ? C_TRACE_JOBS : C_PENDING_JOBS);
}

// The counter slot of statistic `slot` (ray kinds, C_SAMPLES, the pixel counts) for this
// workgroup: its stripe's copy (COUNTER_STRIPES in src/interface/reproject.rs; counters.glsl).
uint stripe_shift() { return stripe_shift_for(COUNTER_STRIPES); }
uint stripe() { return stripe_of(COUNTER_STRIPES); }
uint stat_slot(uint slot) { return (stripe() + 1u) * COUNTER_STRIPE_WORDS + slot; }

// After every append of the dispatch (`leader`: one elected lane of each subgroup): the last
// subgroup to finish turns the lengths of the lists in the bit set `lists` into their indirect
// dispatches, so no separate pass and barrier is needed. Subgroups count themselves done per stripe, and the last of each stripe once more
// in a shared counter (one shared atomic per stripe, not per subgroup). List 0 restarts at zero
// for the next stage that lists into it; the others keep their lengths for the later passes
// that append to them.
void lists_done(uint lists, bool leader) {
    if (leader) {
        // This subgroup's appends are counted before it counts itself done.
        memoryBarrierBuffer();
        uint groups = workgroup_count();
        uint shift = stripe_shift();
        uint members = min(1u << shift, groups - (stripe() << shift));
        uint slot = stat_slot(C_STRIPE_DONE);
        if (atomicAdd(counters[slot], 1u) + 1u == members * gl_NumSubgroups) {
            counters[slot] = 0u;
            memoryBarrierBuffer();
            uint stripes = (groups + (1u << shift) - 1u) >> shift;
            if (atomicAdd(counters[C_TILES_DONE], 1u) + 1u == stripes) {
                for (uint list = 0u; list < JOB_LISTS; ++list) {
                    if ((lists & (1u << list)) != 0u) {
                        uint n = list == LIST_VERIFY ? atomicExchange(counters[C_JOBS], 0u) : atomicAdd(counters[list_counter(list)], 0u);
                        // Rows of workgroups (GROUPS_PER_ROW; rqr::vk::rows_of_groups).
                        uint groups = (n + 63u) / 64u;
                        uint row = min(groups, GROUPS_PER_ROW);
                        dispatch_args[4u * list] = row;
                        dispatch_args[4u * list + 1u] = row == 0u ? 1u : (groups + row - 1u) / row;
                        dispatch_args[4u * list + 2u] = 1u;
                        dispatch_args[4u * list + 3u] = n;
                    }
                }
                counters[C_TILES_DONE] = 0u;
            }
        }
    }
}

// Counts settled state `settled` (0: nothing to count; a pixel is counted once, by the pass
// that settles it, and the tracing and interpolation passes count the kinds they turn pixels
// into) and appends q to the job lists `list[i]` whose `take[i]` holds (the first `lists` of
// them are used). Stream compaction in tile order: every subgroup writes its jobs contiguously
// in invocation order after one atomic per list (a subgroup covers one or more rows of an 8x8
// tile), so neighbouring lanes of a tracing pass trace neighbouring pixels; ballots, not scans,
// and no workgroup barrier (a CPU device runs shaders with barrier() as coroutines, which cost
// more than the atomics they would save). One lane, `leader` (subgroupElect(), elected once by the caller), does every
// atomic, and one broadcast hands the lists' offsets back: a CPU device (lavapipe) runs each
// subgroup operation (election, ballot, reduction, broadcast) as a loop over the lanes. The
// seven 0/1 counts travel as 8-bit fields of two words, one reduction for all (a subgroup has
// at most 128 lanes). Call from every invocation of the dispatch.
const uint SETTLED_COUNTERS[7] = uint[7](C_REUSED, C_HOLES, C_REJECTED, C_VIEW_DEPENDENT, C_EXPIRED, C_FRAMELESS, C_FILLED);

void settle_and_list(uint settled, uvec3 list, bvec3 take, uint lists, uint q, bool leader) {
    uint kind = settled & PX_KIND_MASK;
    uvec2 packed = uvec2((kind == PX_REUSE ? 1u : 0u) | ((settled & PX_HOLE) != 0u ? 1u << 8 : 0u)
                             | ((settled & PX_REJECTED) != 0u ? 1u << 16 : 0u) | ((settled & PX_VIEW_DEPENDENT) != 0u ? 1u << 24 : 0u),
                         ((settled & PX_EXPIRED) != 0u ? 1u : 0u) | ((settled & PX_FRAMELESS) != 0u ? 1u << 8 : 0u)
                             | ((settled & PX_FILLED) != 0u && kind == PX_REUSE ? 1u << 16 : 0u));
    uvec2 sums = subgroupAdd(packed);
    uvec4 b0 = subgroupBallot(take.x);
    uvec4 b1 = subgroupBallot(take.y);
    uvec4 b2 = lists > 2u ? subgroupBallot(take.z) : uvec4(0u);
    uvec3 total = uvec3(subgroupBallotBitCount(b0), subgroupBallotBitCount(b1), subgroupBallotBitCount(b2));
    uvec3 base = uvec3(0u);
    if (leader) {
        [[unroll]] for (uint k = 0u; k < 7u; ++k) {
            uint n = ((k < 4u ? sums.x : sums.y) >> (8u * (k & 3u))) & 255u;
            if (n != 0u) {
                atomicAdd(counters[stat_slot(SETTLED_COUNTERS[k])], n);
            }
        }
        if (total.x != 0u) base.x = atomicAdd(counters[list_counter(list.x)], total.x);
        if (total.y != 0u) base.y = atomicAdd(counters[list_counter(list.y)], total.y);
        if (total.z != 0u) base.z = atomicAdd(counters[list_counter(list.z)], total.z);
    }
    if ((total.x | total.y | total.z) == 0u) {
        return;
    }
    base = subgroupBroadcastFirst(base);
    uint n = pixel_count();
    if (take.x) JOBS(list.x * n + base.x + subgroupBallotExclusiveBitCount(b0)) = q;
    if (take.y) JOBS(list.y * n + base.y + subgroupBallotExclusiveBitCount(b1)) = q;
    if (take.z) JOBS(list.z * n + base.z + subgroupBallotExclusiveBitCount(b2)) = q;
}

// The sample shown at pixel q: the one the scatter chose, or, for a pixel no sample landed on,
// the neighbour's sample the fill chose (kept in the depth key, whose own use ended with the
// scatter). NO_SAMPLE when neither.
#ifndef RQR_KEY_WINNER_64
uint resolved_winner(uint q) {
    uint w = WINNER(q);
    if (w != NO_SAMPLE) {
        return w;
    }
    uint k = DEPTH_KEY(q);
    return (k != NO_SAMPLE && k >= FILLED_KEY) ? (k & ~FILLED_KEY) : NO_SAMPLE;
}

#endif
// Pixel of an index in pixel order. The row is a float quotient corrected by one (exact for
// any image size): a CPU device has no vector integer division and divides lane by lane.
uvec2 pixel_of(uint index) {
    uint y = uint((float(index) + 0.5) / float(frame.width));
    y = y * frame.width > index ? y - 1u : ((y + 1u) * frame.width <= index ? y + 1u : y);
    return uvec2(index - y * frame.width, y);
}

// Adaptive sub-sampling blocks of L x L pixels share their corners with their neighbours:
// block b spans pixels [b L, min(b L + L, n - 1)], and pixel x belongs to block
// min(x / L, blocks - 1) (so the last row/column closes the last block). L is a power of two
// (4, 2, 1), so these divide by shifting: a CPU device has no vector integer division.
uint block_count(uint n, uint l) { return max(1u, (n - 2u + l) >> uint(findLSB(l))); }

uvec2 block_span(uint x, uint n, uint l) {
    uint x0 = min(x >> uint(findLSB(l)), block_count(n, l) - 1u) * l;
    return uvec2(x0, min(x0 + l, n - 1u));
}

bool is_block_sample(uvec2 pix, uint l) {
    uvec2 sx = block_span(pix.x, frame.width, l);
    uvec2 sy = block_span(pix.y, frame.height, l);
    bool corner = (pix.x == sx.x || pix.x == sx.y) && (pix.y == sy.x || pix.y == sy.y);
    bool centre = pix.x == (sx.x + sx.y) / 2u && pix.y == (sy.x + sy.y) / 2u;
    return corner || centre;
}

// Whether a pixel in state `st` is traced at adaptive level `level` (1: every pixel to trace).
bool traced_at(uint st, uvec2 pix, uint level) {
    return (st & PX_KIND_MASK) == PX_TRACE && (level == 1u || is_block_sample(pix, level));
}

// An entry without CACHE_VALID is empty: no reader looks past its meta.
void clear_entry(uint q) { CACHE_NEXT(q).meta = 0u; }

vec3 camera_forward() { return normalize(-frame.camera_to_world[2].xyz); }

// Where the ray through pixel `pix`'s centre meets the plane through `point` with normal `n`,
// in front of the camera: false where it runs (nearly) parallel to the plane or meets it
// behind. For samples cached on a neighbour's plane (fills, interpolated blocks).
bool pixel_ray_meets_plane(uvec2 pix, vec3 point, vec3 n, out vec3 hit) {
    Ray r = camera_ray(vec2(pix) + 0.5);
    float denom = dot(r.dir, n);
    float t = dot(point - r.origin, n) / (abs(denom) > 1e-4 ? denom : 1.0);
    hit = r.origin + t * r.dir;
    return abs(denom) > 1e-4 && t > 0.0;
}

// Distance along the view axis (the "view z" of the rejection test).
float view_depth(vec3 p) { return dot(p - frame.camera_pos, camera_forward()); }

// Projects a cached sample into the current camera. Returns false when it falls outside the
// image or behind the camera; otherwise the pixel index and a depth key where the nearest
// sample has the smallest key (positive float bits order like the floats; misses, points at
// infinity, lose to every hit). The key's KEY_LOW_MASK bits, the depth's lowest mantissa bits
// (depths within 2^-16 of each other count as equal), hold where in the pixel the sample falls
// and whether a fill may copy it: what the fill needs of a neighbour's sample, without a
// gather. Misses are not reprojected by orthographic cameras, whose rays all share one
// direction.
// A cached sample in clip space (a miss, a direction: a point at infinity).
vec4 clip_of(vec3 position, bool miss) { return frame.view_proj * vec4(position, miss ? 0.0 : 1.0); }
// Where on the film, in pixels, a point in clip space in front of the camera falls.
vec2 film_of(vec4 clip) { return (clip.xy / clip.w * 0.5 + 0.5) * vec2(frame.width, frame.height); }

bool project_sample(CacheEntry e, out uint pixel, out uint key) {
    pixel = NO_SAMPLE;
    key = NO_SAMPLE;
    bool miss = cache_miss(e);
    if (miss && frame.ortho != 0u) {
        return false;
    }
    vec4 clip = clip_of(e.position, miss);
    float z = miss ? 1.0 : view_depth(e.position);
    if (!(clip.w > 0.0) || !(z > 0.0)) {
        return false;
    }
    vec2 film = film_of(clip);
    if (!(film.x >= 0.0 && film.y >= 0.0 && film.x < float(frame.width) && film.y < float(frame.height))) {
        return false;
    }
    // The film position in places (eighths of a pixel), whose high bits are the pixel and low
    // bits the place: one conversion per axis, and a signed one (a CPU device converts floats
    // to unsigned integers lane by lane). Clamped: film * 8 may round up to the image's edge.
    const uint places = 1u << KEY_PLACE_BITS;
    uvec2 at = min(uvec2(ivec2(film * float(places))), uvec2(frame.width, frame.height) * places - 1u);
    uvec2 p = at >> KEY_PLACE_BITS;
    pixel = p.y * frame.width + p.x;
    key = ((miss ? 0x7F800000u : floatBitsToUint(z)) & ~KEY_LOW_MASK) | (cache_hops(e) >= params.max_hops ? KEY_NOT_COPYABLE : 0u)
        | ((at.x & (places - 1u)) << KEY_PLACE_BITS) | (at.y & (places - 1u));
    return true;
}

// Where in the film, in pixels, the sample with depth key `key` that won pixel `pix` falls (to
// an eighth of a pixel: the centre of its place).
vec2 key_film(uvec2 pix, uint key) {
    const float places = float(1u << KEY_PLACE_BITS);
    uvec2 place = uvec2((key >> KEY_PLACE_BITS) & ((1u << KEY_PLACE_BITS) - 1u), key & ((1u << KEY_PLACE_BITS) - 1u));
    return vec2(pix) + (vec2(place) + 0.5) / places;
}

// Whether a surface looks different from another viewpoint: transmissive, metal, see-through
// blending, or glossy enough for the Whitted mirror term ((1 - roughness)^2 of the reflection).
bool surface_view_dependent(float metallic, float roughness, float transmission, uint alpha_mode, float alpha) {
    return transmission > 0.0 || metallic >= params.specular_metallic || roughness < params.specular_roughness
        || (alpha_mode == ALPHA_BLEND && alpha < 1.0);
}

// The same test on a material's factors (where no texture-modulated values are at hand).
bool material_view_dependent(uint material) {
    GpuMaterial m = scene_material(material);
    return surface_view_dependent(m.metallic, m.roughness, m.transmission, m.alpha_mode, m.base_color.a);
}

// ReBLUR / SVGF-style disocclusion test of a cached sample against this frame's primary hit
// `p` with front-face normal `ng` and `material`: same plane (distance relative to the view
// depth), similar normal, same material.
bool sample_matches(CacheEntry e, vec3 p, vec3 ng, uint material) {
    if (cache_miss(e)) {
        return false;
    }
    float z = max(view_depth(p), 1e-6);
    float plane = abs(dot(e.position - p, ng)) / z;
    return plane <= params.plane_threshold && dot(unpack_normal(e.normal), ng) >= params.normal_threshold && cache_material(e) == material;
}

// Decides a pixel with candidate sample `e` from this frame's primary hit there.
uint judge_primary(CacheEntry e, bool hit, vec3 p, vec3 ng, uint material, float metallic, float roughness,
                   float transmission, float alpha) {
    if (!hit) {
        return cache_miss(e) ? PX_REUSE : (PX_TRACE | PX_REJECTED);
    }
    if (surface_view_dependent(metallic, roughness, transmission, scene_material(material).alpha_mode, alpha)) {
        return PX_TRACE | PX_VIEW_DEPENDENT;
    }
    return sample_matches(e, p, ng, material) ? PX_REUSE : (PX_TRACE | PX_REJECTED);
}

// The same from the primary hit in the G-buffer images at `pix`.
uint judge_against_gbuffer(ivec2 pix, CacheEntry e) {
    uvec4 ids = imageLoad(g_ids, pix);
    if (ids.x == 0xFFFFFFFFu) {
        return judge_primary(e, false, vec3(0.0), vec3(0.0), 0u, 0.0, 1.0, 0.0, 1.0);
    }
    vec4 p = imageLoad(g_position, pix);
    vec4 n = imageLoad(g_normal, pix);
    vec4 ng = imageLoad(g_geometric, pix);
    vec4 base = imageLoad(g_base, pix);
    return judge_primary(e, true, p.xyz, ng.xyz, ids.z & 0x7FFFFFFFu, ng.w, n.w, uintBitsToFloat(ids.w), base.a);
}

// A pixel's own primary hit, where the pass that commits the pixel knows it: the G-buffer's
// (hybrid path), or the ray the rt visibility pass has just traced, kept in registers (that
// pass stored it in G-buffer images for its readers once: a quarter of its time on lavapipe).
struct PixelHit {
    bool known;
    bool found;
    vec3 position;
    vec3 ng_front;
    uint instance;
    uint primitive;
    vec2 bary;
};

// For passes that traced no primary ray for the pixel.
PixelHit unknown_pixel_hit() {
    return PixelHit(false, false, vec3(0.0), vec3(0.0), 0u, 0u, vec2(0.0));
}

#include "reproject_anchor.glsl"

// The G-buffer's primary hit at `pix` (hybrid path), as far as commit_entry() reads it: the
// triangle and barycentrics only for moving geometry (the anchor).
PixelHit gbuffer_pixel_hit(ivec2 pix) {
    PixelHit h = unknown_pixel_hit();
    h.known = true;
    h.found = true;
    h.position = imageLoad(g_position, pix).xyz;
    h.ng_front = imageLoad(g_geometric, pix).xyz;
    if (tracks_motion()) {
        uvec4 ids = imageLoad(g_ids, pix);
        h.found = ids.x != 0xFFFFFFFFu;
        h.instance = ids.x;
        h.primitive = ids.y;
        h.bary = imageLoad(g_bary, pix).xy;
    }
    return h;
}

#ifndef RQR_KEY_WINNER_64
// Reused pixels take their sample's colour (a miss: the background seen along this pixel's
// own ray) and carry the sample, one frame older, into the next cache. Every other pixel
// starts the next cache empty; the tracing pass fills the ones it traces. Run by the pass
// that settles pixel q (state `st`).
// `e` is the sample the pixel shows (CACHE_PREV(resolved_winner(q))), read by the caller,
// which has usually read it already for its own tests; `hit` the pixel's primary hit where
// the caller traced it (a fill is cached there).
void commit_entry(uint q, uint st, CacheEntry e, PixelHit hit) {
    if ((st & PX_KIND_MASK) != PX_REUSE) {
        clear_entry(q);
        return;
    }
    if (cache_miss(e) && ((frame.flags & FLAG_SKY) != 0u || env_enabled())) {
        // The sky or environment seen through this pixel. (A uniform background needs no
        // recomputing.) The entry holds the colour the pixel shows (adaptive sub-sampling
        // reads it).
        e.color = miss_radiance(camera_ray(vec2(pixel_of(q)) + 0.5).dir, true);
        e.display = store_color(q, e.color);
    } else {
        // Shown as computed: no tonemapping per reused pixel.
        show_color(q, e.color, e.display);
    }
    e.meta = aged(e.meta);
    if ((st & PX_FILLED) != 0u && cache_miss(e)) {
        // A miss's colour is recomputed per pixel: the copy simply becomes this pixel's.
        e.position = camera_ray(vec2(pixel_of(q)) + 0.5).dir;
    } else if ((st & PX_FILLED) != 0u) {
        // A fill carries a copy of a neighbour's colour. Cached as it is, the copy would
        // collide with its original next frame and leave the pixel empty again, so the
        // sample density of a surface seen larger and larger would only fall. Instead it
        // becomes this pixel's sample at this pixel's primary hit: the G-buffer's or the
        // visibility pass's where there is one, else where this pixel's ray meets the copied
        // sample's plane (the neighbourhood passed the edge test, so it is that smooth
        // surface).
        if ((params.flags & RP_GBUFFER) != 0u) {
            hit = gbuffer_pixel_hit(ivec2(pixel_of(q)));
        }
        if (hit.known) {
            e.position = hit.position;
            e.normal = pack_normal(hit.ng_front);
        } else {
            vec3 p;
            if (pixel_ray_meets_plane(pixel_of(q), e.position, unpack_normal(e.normal), p)) {
                e.position = p;
            }
        }
        e.meta = with_hops(e.meta, cache_hops(e) + 1u);
    }
    anchor_commit(q, resolved_winner(q), st, e, hit);
    CACHE_NEXT(q) = e;
}

#endif

#endif
