// Temporal reuse: the parameters, the per-pixel buffers (buffer references at the addresses in
// the parameters), the counters, the G-buffer images and the indirect dispatches, and the
// pixels' colour output.
// Included by temporal.glsl (in its order: each part uses the ones before it).
// Pixel state: a PX_* kind in the low bits plus the reasons that led to it (for statistics).
// A depth key with FILLED_KEY marks an empty pixel filled from a neighbour (plus the source
// index); real keys are positive float bits.

layout(set = 0, binding = BINDING_RP_PARAMS, scalar) uniform Params { GpuParams params; };

// The per-pixel buffers, through buffer references at the addresses in `params` (GpuParams:
// a CPU device (lavapipe) gathers and scatters through a buffer reference with vector
// instructions, where it accesses a descriptor-bound buffer lane by lane). Not readonly:
// with moving geometry the scatter moves each entry with its object (anchor.glsl).
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
// by the lowest index in one pass (temporal_scatter64.comp); otherwise two 32-bit passes do.
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
// The G-buffer images (gbuffer.frag's layout): the raster pass's (hybrid) or 1x1 placeholders
// (rt: the verify pass keeps its primary hits in registers).
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
