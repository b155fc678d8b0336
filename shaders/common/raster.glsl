// Compute rasterizer of the visibility buffer (`--raster compute`; src/render/passes/raster_compute.rs).
// Writes what gbuffer_visibility.frag writes (instance, primitive per pixel) with the rules of the
// graphics pipeline it replaces: vertices transformed and jittered like gbuffer.vert, clipped
// against the near plane (and a guard band), snapped to 1/256 pixel (subPixelPrecisionBits 8),
// exact integer edge functions with the top-left fill rule at pixel centres, back-face culling
// per draw (clockwise front faces for mirrored instances), depth z/w interpolated linearly in
// screen space, alpha-MASK tested against the base-colour texture (alpha_accepts, with
// KHR_texture_transform) at perspective-correct barycentrics. BLEND draws count as opaque, as in
// the graphics pass.
//
// Depth test: per pixel min of (depth bits << 32 | global triangle id) by 64-bit atomicMin
// (variant atomic64), or, without shaderBufferInt64Atomics (variant atomic32), a 32-bit
// atomicMin of the depth bits in one pass and, where a triangle's depth equals the minimum, an
// atomicMin of its id in a second pass. Either way ties go to the lowest id, deterministically.
//
// Triangles that are not rasterized on the spot (bounding box over SMALL_TRIANGLE_PIXELS, or
// clipped) are binned into 16x16-pixel screen tiles, as in Laine & Karras 2011 ("High-
// Performance Software Rasterization on GPUs"): raster_bin.comp counts each queued triangle's
// tiles, scans the counts into per-tile offsets and fills per-tile triangle lists;
// raster_tiles.comp then runs one workgroup per tile, each invocation one pixel, walks the
// tile's list with coverage and depth kept in registers, and writes one depth test per pixel.
//
// Bindings (src/interface/passes.rs): scene, textures, frame, BINDING_RASTER_DEPTH_IDS (depth|id
// per pixel), _DRAWS (draw table), _BIG (big-triangle list), _VISIBILITY (resolve only), _BINS
// (tile bins).
#ifndef RQR_RASTER_GLSL
#define RQR_RASTER_GLSL

#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#ifdef RAY_BACKEND_ATOMIC64
#extension GL_EXT_shader_atomic_int64 : require
#endif
#include "scene.glsl"
#include "frame.glsl"
#include "interface_passes.glsl"

#ifdef RAY_BACKEND_ATOMIC64
layout(set = 0, binding = BINDING_RASTER_DEPTH_IDS, std430) buffer DepthIds { uint64_t depth_id[]; };
#else
// [0, pixels): depth bits; [pixels, 2 pixels): global triangle id.
layout(set = 0, binding = BINDING_RASTER_DEPTH_IDS, std430) buffer DepthIds { uint depth_id[]; };
#endif

// RasterDraw (one entry per drawn instance, in instance order) and its DRAW_* flags are
// declared in src/interface/passes.rs.
layout(set = 0, binding = BINDING_RASTER_DRAWS, scalar) readonly buffer Draws { RasterDraw draws[]; };
// Triangles too big (or clipped) for one invocation: binned into tiles.
layout(set = 0, binding = BINDING_RASTER_BIG, std430) buffer Big { uint big_count; uint big[]; };
// Tile bins, for T tiles: [0, T) triangles per tile, [T, 2T) each tile's first entry,
// [2T, 3T) fill cursors, [3T, ..) the entries (indices into big[]).
layout(set = 0, binding = BINDING_RASTER_BINS, std430) buffer Bins { uint bins[]; };
#define TILE_SIZE int(RASTER_TILE_SIZE)
uvec2 tile_grid() { return (uvec2(frame.width, frame.height) + uvec2(RASTER_TILE_SIZE - 1u)) / uvec2(RASTER_TILE_SIZE); }
uint tile_count_total() { uvec2 g = tile_grid(); return g.x * g.y; }
uint bin_capacity() { return uint(bins.length()) - 3u * tile_count_total(); }

layout(push_constant) uniform Push { RasterPush pc; };

#define SUBPIXEL 256
#define SUBPIXEL_HALF 128
// Guard band in NDC units: beyond it triangles are clipped so fixed-point coordinates stay
// below 2^24 and edge-function products fit in 64 bits.
#define GUARD_BAND 32.0
#define MAX_POLY 8
// Bounding boxes up to this many pixels are rasterized by the invocation that set them up.
#define SMALL_TRIANGLE_PIXELS 64

// The draw holding global triangle `gid`: the last entry whose first triangle is <= gid.
uint draw_of(uint gid) {
    uint lo = 0u;
    uint hi = pc.draw_count - 1u;
    while (lo < hi) {
        uint mid = (lo + hi + 1u) / 2u;
        if (draws[mid].first_triangle <= gid) {
            lo = mid;
        } else {
            hi = mid - 1u;
        }
    }
    return lo;
}

// A triangle after clipping: a convex polygon in snapped framebuffer coordinates.
struct Poly {
    uint count;
    uint instance;
    uint prim;
    uint flags;
    ivec2 p[MAX_POLY];
    float z[MAX_POLY];
    float inv_w[MAX_POLY];
    vec3 bary[MAX_POLY];
};

// Signed distance of clip-space point `c` to clipping plane `plane` (inside >= 0): 0 near
// (z >= 0), 1-4 guard band.
float plane_distance(vec4 c, uint plane) {
    switch (plane) {
    case 0u: return c.z;
    case 1u: return GUARD_BAND * c.w - c.x;
    case 2u: return GUARD_BAND * c.w + c.x;
    case 3u: return GUARD_BAND * c.w - c.y;
    default: return GUARD_BAND * c.w + c.y;
    }
}

// Transforms the corners of triangle `gid` like gbuffer.vert. Returns false when the triangle
// is outside one of the view-volume planes entirely; `needs_clip` when a corner is behind the
// near plane or outside the guard band.
bool triangle_clip(uint gid, out Poly poly, out vec4 clip[3], out bool needs_clip) {
    uint d = draw_of(gid);
    RasterDraw dr = draws[d];
    poly.instance = dr.instance;
    poly.prim = gid - dr.first_triangle;
    poly.flags = dr.flags;
    poly.count = 0u;
    GpuInstance inst = scene_instance(dr.instance);
    uvec3 tri = scene_triangle(scene_geometry(inst.geometry), poly.prim);
    vec2 jitter_ndc = vec2(2.0 * frame.jitter.x / float(frame.width), 2.0 * frame.jitter.y / float(frame.height));
    for (uint k = 0u; k < 3u; ++k) {
        uint v = k == 0u ? tri.x : (k == 1u ? tri.y : tri.z);
        vec4 world = inst.object_to_world * vec4(scene_position(v), 1.0);
        vec4 c = frame.view_proj * world;
        c.xy -= jitter_ndc * c.w;
        clip[k] = c;
    }
    // Trivial rejection against the view volume.
    if ((clip[0].x > clip[0].w && clip[1].x > clip[1].w && clip[2].x > clip[2].w)
        || (clip[0].x < -clip[0].w && clip[1].x < -clip[1].w && clip[2].x < -clip[2].w)
        || (clip[0].y > clip[0].w && clip[1].y > clip[1].w && clip[2].y > clip[2].w)
        || (clip[0].y < -clip[0].w && clip[1].y < -clip[1].w && clip[2].y < -clip[2].w)
        || (clip[0].z < 0.0 && clip[1].z < 0.0 && clip[2].z < 0.0)
        || (clip[0].z > clip[0].w && clip[1].z > clip[1].w && clip[2].z > clip[2].w)) {
        return false;
    }
    needs_clip = false;
    for (uint k = 0u; k < 3u; ++k) {
        for (uint plane = 0u; plane < 5u; ++plane) {
            needs_clip = needs_clip || plane_distance(clip[k], plane) < 0.0;
        }
    }
    return true;
}

// Framebuffer position of a clip-space point, snapped to 1/SUBPIXEL pixel.
ivec2 snap(vec4 c) {
    vec2 ndc = c.xy / c.w;
    vec2 fb = (ndc * 0.5 + 0.5) * vec2(float(frame.width), float(frame.height));
    return ivec2(round(fb * float(SUBPIXEL)));
}

void poly_push(inout Poly poly, vec4 c, vec3 bary) {
    uint i = poly.count;
    poly.p[i] = snap(c);
    poly.z[i] = c.z / c.w;
    poly.inv_w[i] = 1.0 / c.w;
    poly.bary[i] = bary;
    poly.count = i + 1u;
}

// Fills `poly` from the three corners without clipping.
void poly_from_triangle(inout Poly poly, vec4 clip[3]) {
    poly.count = 0u;
    poly_push(poly, clip[0], vec3(1.0, 0.0, 0.0));
    poly_push(poly, clip[1], vec3(0.0, 1.0, 0.0));
    poly_push(poly, clip[2], vec3(0.0, 0.0, 1.0));
}

// Sutherland-Hodgman clipping against the near plane and the guard band; the barycentrics
// of the original triangle travel with every new corner.
void poly_clip(inout Poly poly, vec4 clip[3]) {
    vec4 c[MAX_POLY];
    vec3 b[MAX_POLY];
    vec4 oc[MAX_POLY];
    vec3 ob[MAX_POLY];
    uint n = 3u;
    c[0] = clip[0];
    c[1] = clip[1];
    c[2] = clip[2];
    b[0] = vec3(1.0, 0.0, 0.0);
    b[1] = vec3(0.0, 1.0, 0.0);
    b[2] = vec3(0.0, 0.0, 1.0);
    for (uint plane = 0u; plane < 5u; ++plane) {
        uint m = 0u;
        for (uint i = 0u; i < n; ++i) {
            uint j = i + 1u == n ? 0u : i + 1u;
            float di = plane_distance(c[i], plane);
            float dj = plane_distance(c[j], plane);
            if (di >= 0.0 && m < MAX_POLY) {
                oc[m] = c[i];
                ob[m] = b[i];
                m++;
            }
            if ((di >= 0.0) != (dj >= 0.0) && m < MAX_POLY) {
                float t = di / (di - dj);
                oc[m] = mix(c[i], c[j], t);
                ob[m] = mix(b[i], b[j], t);
                m++;
            }
        }
        n = m;
        for (uint i = 0u; i < n; ++i) {
            c[i] = oc[i];
            b[i] = ob[i];
        }
    }
    poly.count = 0u;
    for (uint i = 0u; i < n; ++i) {
        // The near-plane intersection has z exactly 0 up to rounding; keep it inside.
        vec4 v = c[i];
        v.z = max(v.z, 0.0);
        poly_push(poly, v, b[i]);
    }
}

// One triangle ready for coverage tests: counter-clockwise in the edge-function sense
// (area > 0), with its pixel bounding box (inclusive, clamped to the image).
struct Tri {
    ivec2 v0, v1, v2;
    int64_t area;
    ivec3 bias;
    ivec4 bbox;
    vec3 z;
    vec3 inv_w;
    vec3 b0, b1, b2;
};

// Top-left fill rule for edge a -> b of a triangle with positive area in framebuffer
// coordinates (y down): left edges go up, top edges are horizontal and go right. Samples
// exactly on other edges are not covered.
int edge_bias(ivec2 a, ivec2 b) {
    ivec2 e = b - a;
    return (e.y < 0 || (e.y == 0 && e.x > 0)) ? 0 : -1;
}

int64_t edge(ivec2 a, ivec2 b, ivec2 p) {
    return int64_t(b.x - a.x) * int64_t(p.y - a.y) - int64_t(b.y - a.y) * int64_t(p.x - a.x);
}

// Fan triangle (0, k, k+1) of `poly`; false when degenerate, back-facing and culled, or
// covering no pixel centre's bounding box.
bool make_tri(Poly poly, uint k, out Tri t) {
    uint i1 = k;
    uint i2 = k + 1u;
    int64_t area = edge(poly.p[0], poly.p[i1], poly.p[i2]);
    if (area == 0l) {
        return false;
    }
    // Vulkan facing: a = -area / 2 > 0 is counter-clockwise (framebuffer y points down).
    bool front = (poly.flags & DRAW_MIRRORED) != 0u ? area > 0l : area < 0l;
    if ((poly.flags & DRAW_CULL_BACK) != 0u && !front) {
        return false;
    }
    if (area < 0l) {
        uint s = i1;
        i1 = i2;
        i2 = s;
        area = -area;
    }
    t.v0 = poly.p[0];
    t.v1 = poly.p[i1];
    t.v2 = poly.p[i2];
    t.area = area;
    t.bias = ivec3(edge_bias(t.v1, t.v2), edge_bias(t.v2, t.v0), edge_bias(t.v0, t.v1));
    t.z = vec3(poly.z[0], poly.z[i1], poly.z[i2]);
    t.inv_w = vec3(poly.inv_w[0], poly.inv_w[i1], poly.inv_w[i2]);
    t.b0 = poly.bary[0];
    t.b1 = poly.bary[i1];
    t.b2 = poly.bary[i2];
    ivec2 lo = min(t.v0, min(t.v1, t.v2));
    ivec2 hi = max(t.v0, max(t.v1, t.v2));
    // Pixel x's centre is x * SUBPIXEL + SUBPIXEL_HALF.
    ivec2 first = (lo - SUBPIXEL_HALF + (SUBPIXEL - 1)) >> 8;
    ivec2 last = (hi - SUBPIXEL_HALF) >> 8;
    first = max(first, ivec2(0));
    last = min(last, ivec2(int(frame.width) - 1, int(frame.height) - 1));
    t.bbox = ivec4(first, last);
    return first.x <= last.x && first.y <= last.y;
}

// Whether depth `bits` of triangle `gid` can still win pixel `index` (an early out before the
// alpha test's texture fetch).
bool depth_may_win(uint index, uint bits, uint gid) {
#ifdef RAY_BACKEND_ATOMIC64
    // A plain 64-bit load racing with another invocation's atomicMin may tear, but either
    // half-word it returns for the depth is one that was stored, hence >= the current minimum's,
    // so skipping a strictly farther depth is always safe.
    return bits <= uint(depth_id[index] >> 32);
#else
    if (pc.pass_kind == 0u) {
        return bits < depth_id[index];
    }
    return bits == depth_id[index] && gid < depth_id[frame.width * frame.height + index];
#endif
}

// The depth test's atomic: nearest depth wins, the lowest id on equal depths.
void depth_store(uint index, uint bits, uint gid) {
#ifdef RAY_BACKEND_ATOMIC64
    atomicMin(depth_id[index], (uint64_t(bits) << 32) | uint64_t(gid));
#else
    if (pc.pass_kind == 0u) {
        atomicMin(depth_id[index], bits);
    } else {
        atomicMin(depth_id[frame.width * frame.height + index], gid);
    }
#endif
}

// Depth test and write of triangle `gid` at pixel `pix` with depth `depth`.
void depth_write(Poly poly, uint gid, ivec2 pix, float depth, vec3 persp) {
    uint index = uint(pix.y) * frame.width + uint(pix.x);
    uint bits = floatBitsToUint(depth);
    if (!depth_may_win(index, bits, gid)) {
        return;
    }
    if ((poly.flags & DRAW_ALPHA_TEST) != 0u && !alpha_accepts(poly.instance, poly.prim, persp.yz)) {
        return;
    }
    depth_store(index, bits, gid);
}

// Coverage and depth of fan triangle `t` at pixel `pix`: false when the pixel centre is not
// covered or the depth is beyond the far plane; else its depth and perspective-correct
// barycentrics of the original triangle.
bool raster_cover(Tri t, ivec2 pix, out float depth, out vec3 persp) {
    depth = 0.0;
    persp = vec3(0.0);
    ivec2 p = pix * SUBPIXEL + SUBPIXEL_HALF;
    int64_t e0 = edge(t.v1, t.v2, p);
    int64_t e1 = edge(t.v2, t.v0, p);
    int64_t e2 = edge(t.v0, t.v1, p);
    if (e0 + int64_t(t.bias.x) < 0l || e1 + int64_t(t.bias.y) < 0l || e2 + int64_t(t.bias.z) < 0l) {
        return false;
    }
    precise vec3 l = vec3(float(e0), float(e1), float(e2)) / float(t.area);
    precise float d = max(dot(l, t.z), 0.0);
    if (d > 1.0) {
        return false;
    }
    depth = d;
    vec3 pw = l * t.inv_w;
    persp = (pw.x * t.b0 + pw.y * t.b1 + pw.z * t.b2) / (pw.x + pw.y + pw.z);
    return true;
}

// Coverage, depth and write of one pixel.
void raster_pixel(Poly poly, Tri t, uint gid, ivec2 pix) {
    float depth;
    vec3 persp;
    if (raster_cover(t, pix, depth, persp)) {
        depth_write(poly, gid, pix, depth, persp);
    }
}

// A queued triangle clipped and ready: its polygon, and the tiles its fan triangles' pixel
// bounding boxes touch (inclusive tile coordinates). False when no pixel centre can be covered.
bool big_setup(uint gid, out Poly poly, out ivec4 tiles) {
    vec4 clip[3];
    bool needs_clip;
    tiles = ivec4(0, 0, -1, -1);
    if (!triangle_clip(gid, poly, clip, needs_clip)) {
        return false;
    }
    if (needs_clip) {
        poly_clip(poly, clip);
    } else {
        poly_from_triangle(poly, clip);
    }
    ivec4 box = ivec4(0x7FFFFFFF, 0x7FFFFFFF, -1, -1);
    for (uint k = 1u; k + 1u < poly.count; ++k) {
        Tri t;
        if (make_tri(poly, k, t)) {
            box = ivec4(min(box.xy, t.bbox.xy), max(box.zw, t.bbox.zw));
        }
    }
    if (box.z < 0) {
        return false;
    }
    tiles = ivec4(box.xy / TILE_SIZE, box.zw / TILE_SIZE);
    return true;
}

#endif
