// Temporal reprojection (src/render/reproject.rs): the per-pixel sample cache, pixel states,
// parameters and the tests shared by reproject.comp, reproject_primary.comp and
// reproject_trace.comp. Include after scene.glsl and frame.glsl.
//
// Bindings (one numbering for the pipelines): 4 params, 5 previous cache, 6 next cache,
// 7 scatter winners and depth keys (8 unused), 9 pixel states, 10 colour, 11 job list,
// 12 counters, 13-19 G-buffer images (gbuffer.frag's layout), 20 indirect dispatch arguments,
// 21 the sample each pixel shows (without its colour).
#ifndef RQR_REPROJECT_GLSL
#define RQR_REPROJECT_GLSL

// A cached sample: the colour of one primary hit and where it was.
#define CACHE_VALID 1u
#define CACHE_MISS 2u            // position holds the unit ray direction (a point at infinity)
#define CACHE_VIEW_DEPENDENT 4u  // specular/transmissive: never reused
// Bits 8-15 of the flags: how many fills away from where it was computed the colour is (an
// interpolated colour counts as one); a fill copies only samples below params.max_hops.
#define CACHE_HOPS_SHIFT 8u
struct CacheEntry {
    vec4 color;     // rgb: linear radiance; a: 1
    vec4 position;  // xyz: world position of the primary hit (a miss: unit direction)
    vec4 normal;    // xyz: geometric normal of the glTF front face
    uvec4 meta;     // x: CACHE_* flags, y: material, z: instance, w: age in frames
};
uint cache_hops(CacheEntry e) { return (e.meta.x >> CACHE_HOPS_SHIFT) & 255u; }
uint with_hops(uint flags, uint hops) { return (flags & ~(255u << CACHE_HOPS_SHIFT)) | (min(hops, 255u) << CACHE_HOPS_SHIFT); }

// Pixel state: a kind in the low bits plus the reasons that led to it (for statistics).
#define PX_KIND_MASK 15u
#define PX_REUSE 1u     // shows a reprojected sample
#define PX_TRACE 2u     // needs new rays (or interpolation), not done yet
#define PX_VERIFY 3u    // has a candidate sample; a primary ray decides (rt path)
#define PX_TRACED 4u    // traced this frame
#define PX_INTERP 5u    // interpolated this frame (adaptive sub-sampling)
#define PX_HOLE (1u << 4)            // no sample landed here (disocclusion, screen edge, first frame)
#define PX_REJECTED (1u << 5)        // the sample disagrees with this frame's primary visibility
#define PX_VIEW_DEPENDENT (1u << 6)  // specular/transmissive sample or surface
#define PX_EXPIRED (1u << 7)         // older than --max-age
#define PX_FRAMELESS (1u << 8)       // picked by the frameless refresh
#define PX_VERIFIED (1u << 9)        // G-buffer images hold this pixel's primary hit (rt path)
#define PX_FILLED (1u << 10)         // the sample is a neighbour's, filling an empty pixel

#define NO_SAMPLE 0xFFFFFFFFu
// A depth key with this bit marks an empty pixel filled from a neighbour (plus the source
// index); real keys are positive float bits.
#define FILLED_KEY 0x80000000u

// Counter slots (binding 12): rays by kind and samples as in raytrace.comp, then statistics.
#define C_SAMPLES 4u
#define C_JOBS 5u
#define C_REUSED 6u
#define C_TRACED 7u
#define C_INTERP 8u
#define C_HOLES 9u
#define C_REJECTED 10u
#define C_VIEW_DEPENDENT 11u
#define C_EXPIRED 12u
#define C_FRAMELESS 13u
#define C_VERIFY_RAYS 14u
#define C_CANDIDATES 15u
#define C_FORCED 16u
#define C_THRESHOLD_BIN 17u
#define C_THRESHOLD_FRACTION 18u
#define C_FILLED 19u
#define C_TILES_DONE 20u  // workgroups that finished appending to the current job list
#define C_HISTOGRAM 32u
#define AGE_LEVELS 64u
#define RANK_LEVELS 64u
#define HISTOGRAM_BINS (AGE_LEVELS * RANK_LEVELS)

// Params flags.
#define RP_REUSE 1u        // reproject the previous frame's cache
#define RP_GBUFFER 2u      // every pixel's primary hit is in the G-buffer (hybrid path)
#define RP_VERIFY_ALL 4u   // rt path: verify every candidate with a primary ray
#define RP_FRAMELESS 8u    // frameless refresh of the oldest samples
#define RP_ADAPTIVE 16u    // adaptive sub-sampling of the pixels that need new colour

layout(set = 0, binding = 4, scalar) uniform Params {
    uint flags;
    uint max_age;              // a sample older than this is re-traced
    float frameless_fraction;  // share of pixels re-traced per frame (0..1)
    float subsample_threshold; // adaptive sub-sampling: largest channel difference to interpolate
    uint pad0;
    float plane_threshold;     // plane distance / view depth
    float normal_threshold;    // smallest dot of the two geometric normals
    float edge_threshold;      // rt path: plane distance / view depth between neighbours = an edge
    float specular_metallic;   // metallic at or above: view-dependent
    float specular_roughness;  // roughness below: view-dependent (Whitted mirror term)
    float fill_radius;         // an empty pixel takes a neighbour's sample this close (pixels)
    uint max_hops;             // fills copy samples fewer hops than this from their origin
} params;

layout(set = 0, binding = 5, scalar) readonly buffer CachePrev { CacheEntry cache_prev[]; };
layout(set = 0, binding = 6, scalar) buffer CacheNext { CacheEntry cache_next[]; };
// Per pixel, interleaved: word 2q is the index of the sample that won pixel q, word 2q + 1 its
// depth key. Where the device has 64-bit atomics, one atomicMin of key << 32 | index on the
// pair (little-endian: index in the low word) picks the nearest sample and breaks depth ties
// by the lowest index in one pass (reproject_scatter64.comp); otherwise two 32-bit passes do.
#ifndef RQR_KEY_WINNER_64
layout(set = 0, binding = 7, std430) buffer KeyWinner { uint key_winner[]; };
#define WINNER(q) key_winner[2u * (q)]
#define DEPTH_KEY(q) key_winner[2u * (q) + 1u]
#endif
layout(set = 0, binding = 9, std430) buffer States { uint state[]; };
layout(set = 0, binding = 10, scalar) buffer Colors { vec4 color[]; };
layout(set = 0, binding = 11, std430) buffer Jobs { uint jobs[]; };
layout(set = 0, binding = 12, std430) buffer Counters { uint counters[]; };
layout(set = 0, binding = 13, rgba32f) uniform image2D g_position;   // world position, t
layout(set = 0, binding = 14, rgba32f) uniform image2D g_normal;     // shading normal, roughness
layout(set = 0, binding = 15, rgba32f) uniform image2D g_geometric;  // front-face normal, metallic
layout(set = 0, binding = 16, rgba16f) uniform image2D g_base;       // base colour, alpha
layout(set = 0, binding = 17, rgba16f) uniform image2D g_emissive;   // emissive, occlusion
layout(set = 0, binding = 18, rgba32ui) uniform uimage2D g_ids;      // instance, primitive, material | front << 31, transmission bits
layout(set = 0, binding = 19, rgba32f) uniform image2D g_bary;       // barycentrics, motion
// The tracing passes' dispatch (x, y, z workgroups) and their job count, written by
// reproject.comp's ARGS stage from the job list that the gather before it compacted.
layout(set = 0, binding = 20, std430) buffer DispatchArgs { uint dispatch_args[4]; };

// Per pixel, the cached sample it shows after the scatter and the fill (colour left out):
// position, normal and meta of CacheEntry; meta.x = 0 where no sample landed. Written in
// pixel order by the fill stage, so the stages that look at a pixel's neighbours read
// neighbouring memory instead of gathering whole cache entries from wherever they came from.
struct Shown {
    vec4 position;
    vec4 normal;
    uvec4 meta;
};
layout(set = 0, binding = 21, scalar) buffer ShownSamples { Shown shown[]; };

CacheEntry shown_entry(uint q) {
    Shown s = shown[q];
    return CacheEntry(vec4(0.0), s.position, s.normal, s.meta);
}

// Jobs of the current tracing pass (one per invocation, 64 per workgroup).
uint job_count() { return dispatch_args[3]; }

uint pixel_count() { return frame.width * frame.height; }

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
uvec2 pixel_of(uint index) { return uvec2(index % frame.width, index / frame.width); }

vec3 camera_forward() { return normalize(-frame.camera_to_world[2].xyz); }

// Distance along the view axis (the "view z" of the rejection test).
float view_depth(vec3 p) { return dot(p - frame.camera_pos, camera_forward()); }

// Projects a cached sample into the current camera. Returns false when it falls outside the
// image or behind the camera; otherwise the pixel index and a depth key where the nearest
// sample has the smallest key (positive float bits order like the floats; misses, points at
// infinity, lose to every hit). Misses are not reprojected by orthographic cameras, whose
// rays all share one direction.
bool project_sample(CacheEntry e, out uint pixel, out uint key, out vec2 film) {
    pixel = NO_SAMPLE;
    key = NO_SAMPLE;
    film = vec2(-1.0);
    bool miss = (e.meta.x & CACHE_MISS) != 0u;
    if (miss && frame.ortho != 0u) {
        return false;
    }
    vec4 clip = frame.view_proj * vec4(e.position.xyz, miss ? 0.0 : 1.0);
    float z = miss ? 1.0 : view_depth(e.position.xyz);
    if (!(clip.w > 0.0) || !(z > 0.0)) {
        return false;
    }
    film = (clip.xy / clip.w * 0.5 + 0.5) * vec2(frame.width, frame.height);
    if (!(film.x >= 0.0 && film.y >= 0.0 && film.x < float(frame.width) && film.y < float(frame.height))) {
        return false;
    }
    uvec2 p = min(uvec2(film), uvec2(frame.width - 1u, frame.height - 1u));
    pixel = p.y * frame.width + p.x;
    key = miss ? 0x7F800000u : floatBitsToUint(z);
    return true;
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
    if ((e.meta.x & CACHE_MISS) != 0u) {
        return false;
    }
    float z = max(view_depth(p), 1e-6);
    float plane = abs(dot(e.position.xyz - p, ng)) / z;
    return plane <= params.plane_threshold && dot(e.normal.xyz, ng) >= params.normal_threshold && e.meta.y == material;
}

// Decides a pixel with candidate sample `e` from this frame's primary hit there.
uint judge_primary(CacheEntry e, bool hit, vec3 p, vec3 ng, uint material, float metallic, float roughness,
                   float transmission, float alpha) {
    if (!hit) {
        return (e.meta.x & CACHE_MISS) != 0u ? PX_REUSE : (PX_TRACE | PX_REJECTED);
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

#endif
