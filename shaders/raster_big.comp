// variants: atomic64 atomic32
#version 460
// Compute rasterizer, big-triangle stage (see raster.glsl): work item w is queued triangle
// w / BIG_SPLIT and every BIG_SPLIT-th 16x16-pixel tile of its bounding box starting at
// w % BIG_SPLIT, so one screen-filling triangle spreads over BIG_SPLIT workgroups instead of
// keeping one busy. Each workgroup takes work items in turn; one invocation clips and sets up
// the triangle in shared memory, then the 16x16 invocations cover its tiles.
#extension GL_GOOGLE_include_directive : require
#include "raster.glsl"

layout(local_size_x = 16, local_size_y = 16) in;
#define BIG_SPLIT 16u

shared Poly shared_poly;
shared bool shared_visible;

void main() {
    uint items = big_count * BIG_SPLIT;
    bool leader = gl_LocalInvocationIndex == 0u;
    for (uint w = gl_WorkGroupID.x; w < items; w += gl_NumWorkGroups.x) {
        uint gid = big[w / BIG_SPLIT];
        uint part = w % BIG_SPLIT;
        if (leader) {
            Poly poly;
            vec4 clip[3];
            bool needs_clip;
            shared_visible = triangle_clip(gid, poly, clip, needs_clip);
            if (shared_visible) {
                if (needs_clip) {
                    poly_clip(poly, clip);
                } else {
                    poly_from_triangle(poly, clip);
                }
            }
            shared_poly = poly;
        }
        barrier();
        if (shared_visible) {
            Poly poly = shared_poly;
            for (uint k = 1u; k + 1u < poly.count; ++k) {
                Tri t;
                if (!make_tri(poly, k, t)) {
                    continue;
                }
                uint tile = 0u;
                for (int ty = t.bbox.y; ty <= t.bbox.w; ty += 16) {
                    for (int tx = t.bbox.x; tx <= t.bbox.z; tx += 16, ++tile) {
                        if (tile % BIG_SPLIT != part) {
                            continue;
                        }
                        ivec2 pix = ivec2(tx, ty) + ivec2(gl_LocalInvocationID.xy);
                        if (pix.x <= t.bbox.z && pix.y <= t.bbox.w) {
                            raster_pixel(poly, t, gid, pix);
                        }
                    }
                }
            }
        }
        barrier();
    }
}
