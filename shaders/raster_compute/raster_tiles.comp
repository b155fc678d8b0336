// variants: atomic64 atomic32
#version 460
// Compute rasterizer, per-tile stage (see raster.glsl; Laine & Karras 2011's fine raster,
// with each pixel's coverage and depth in its invocation's registers instead of shared memory):
// one 16x16 workgroup per screen tile, one invocation per pixel, walks the tile's list of
// binned triangles in order and keeps the nearest covering one (lowest id on equal depth, as
// the atomic path decides); then one depth test per pixel merges it with the small triangles'
// atomics. No barrier: every invocation sets up the same triangle from the same data.
#extension GL_GOOGLE_include_directive : require
#include "raster.glsl"

layout(local_size_x = RASTER_TILE_SIZE, local_size_y = RASTER_TILE_SIZE) in;

void main() {
    uvec2 grid = tile_grid();
    uint tiles = tile_count_total();
    uint tile = gl_WorkGroupID.y * grid.x + gl_WorkGroupID.x;
    ivec2 pix = ivec2(gl_WorkGroupID.xy * uint(TILE_SIZE) + gl_LocalInvocationID.xy);
    bool inside = pix.x < int(frame.width) && pix.y < int(frame.height);
    uint first = bins[tiles + tile];
    uint end = min(first + bins[tile], bin_capacity());
    uint best_bits = 0xFFFFFFFFu;
    uint best_gid = 0xFFFFFFFFu;
    for (uint j = first; j < end; ++j) {
        uint gid = big[bins[3u * tiles + j]];
        Poly poly;
        ivec4 box;
        if (!big_setup(gid, poly, box) || !inside) {
            continue;
        }
        for (uint k = 1u; k + 1u < poly.count; ++k) {
            Tri t;
            if (!make_tri(poly, k, t) || any(lessThan(pix, t.bbox.xy)) || any(greaterThan(pix, t.bbox.zw))) {
                continue;
            }
            float depth;
            vec3 persp;
            if (!raster_cover(t, pix, depth, persp)) {
                continue;
            }
            uint bits = floatBitsToUint(depth);
            if (bits > best_bits || (bits == best_bits && gid >= best_gid)) {
                continue;
            }
            if ((poly.flags & DRAW_ALPHA_TEST) != 0u && !alpha_accepts(poly.instance, poly.prim, persp.yz)) {
                continue;
            }
            best_bits = bits;
            best_gid = gid;
        }
    }
    uint index = uint(pix.y) * frame.width + uint(pix.x);
    if (best_gid != 0xFFFFFFFFu && depth_may_win(index, best_bits, best_gid)) {
        depth_store(index, best_bits, best_gid);
    }
}
