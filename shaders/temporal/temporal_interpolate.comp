#version 460
// Temporal reuse, adaptive sub-sampling's interpolation at one level: over the pending pixels'
// job list, fills every block whose traced corners and centre are similar by interpolation,
// and lists the next level's pixels to trace. One thread per job, 64 per workgroup.
#extension GL_GOOGLE_include_directive : require
#include "scene.glsl"
#include "frame.glsl"
#include "counters.glsl"
#include "temporal.glsl"

#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_clustered : require

layout(local_size_x = 8, local_size_y = 8) in;
// ReprojectPush: level, the adaptive level the stage works at (interpolate); gather, the level
// whose pixels to trace the stage lists (GATHER_NONE: it lists none).
layout(push_constant) uniform Push { ReprojectPush pc; };

// The colour of a pixel settled earlier this frame: every pixel that has one (reused, traced,
// interpolated) has it in its next cache entry, so adaptive sub-sampling needs no separate
// colour buffer.
vec3 color_at(uint x, uint y) { return CACHE_NEXT(y * frame.width + x).color; }

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

void main() {
    // Dispatched over the pending pixels' job list (one job per invocation), not the image.
    uint i = linear_invocation(gl_WorkGroupSize.x * gl_WorkGroupSize.y);
    bool inside = i < job_count(LIST_PENDING);
    uint q = inside ? job_at(LIST_PENDING, i) : 0u;
    uvec2 pix = pixel_of(q);
    bool interpolated = false;
    if (inside) {
        interpolated = interpolate(q);
    }
    COUNTER_ADD(counters[stat_slot(C_INTERP)], interpolated ? 1u : 0u);
    // The next level's pixels to trace; the interpolation counts itself above, so
    // nothing settles here.
    if (pc.gather != GATHER_NONE) {
        bool leader = subgroupElect();
        settle_and_list(0u, uvec3(LIST_VERIFY), bvec3(inside && traced_at(STATE(q), pix, pc.gather), false, false), 2u, q, leader);
        lists_done(1u << LIST_VERIFY, leader);
    }
}
