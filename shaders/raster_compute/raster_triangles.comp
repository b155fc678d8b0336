// variants: atomic64 atomic32
#version 460
// Compute rasterizer, triangle stage (see raster.glsl): one invocation per triangle of the
// scene (grid-stride). Transforms and culls it; rasterizes it on the spot when it needs no
// clipping and its bounding box is small, else queues it for raster_big.comp.
#extension GL_GOOGLE_include_directive : require
#include "raster.glsl"

layout(local_size_x = 64) in;

void main() {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    for (uint gid = gl_GlobalInvocationID.x; gid < pc.triangle_count; gid += stride) {
        Poly poly;
        vec4 clip[3];
        bool needs_clip;
        if (!triangle_clip(gid, poly, clip, needs_clip)) {
            continue;
        }
        if (!needs_clip) {
            poly_from_triangle(poly, clip);
            Tri t;
            if (!make_tri(poly, 1u, t)) {
                continue;
            }
            ivec2 size = t.bbox.zw - t.bbox.xy + 1;
            if (size.x * size.y <= SMALL_TRIANGLE_PIXELS) {
                for (int y = t.bbox.y; y <= t.bbox.w; ++y) {
                    for (int x = t.bbox.x; x <= t.bbox.z; ++x) {
                        raster_pixel(poly, t, gid, ivec2(x, y));
                    }
                }
                continue;
            }
        }
        // The id pass of the atomic32 variant reuses the depth pass's queue.
        if (pc.pass_kind == 0u) {
            big[atomicAdd(big_count, 1u)] = gid;
        }
    }
}
