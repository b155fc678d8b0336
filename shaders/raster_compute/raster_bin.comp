// variants: atomic64 atomic32
#version 460
// Compute rasterizer, binning (see raster.glsl; Laine & Karras 2011's bin stage): the
// triangles raster_triangles.comp queued go into per-tile lists, in three stages picked by a
// specialization constant (src/render/passes/raster_compute.rs builds one pipeline per stage):
// COUNT (per queued triangle: +1 on every tile its bounding box touches), SCAN (one workgroup:
// exclusive prefix sum of the counts into each tile's first entry), FILL (per queued triangle:
// its index into each tile's list). A (triangle, tile) pair beyond the bins' capacity is
// rasterized by the FILL invocation itself, with per-pixel atomics, so nothing is dropped.
#extension GL_GOOGLE_include_directive : require
#include "raster.glsl"

// RASTER_BIN_COUNT, _SCAN or _FILL (src/interface/passes.rs).
layout(constant_id = 0) const uint STAGE = 0u;

layout(local_size_x = 256) in;

shared uint partial[256];

void scan() {
    uint tiles = tile_count_total();
    uint lane = gl_LocalInvocationIndex;
    uint chunk = (tiles + 255u) / 256u;
    uint first = min(lane * chunk, tiles);
    uint last = min(first + chunk, tiles);
    uint sum = 0u;
    for (uint t = first; t < last; ++t) {
        sum += bins[t];
    }
    partial[lane] = sum;
    barrier();
    // Hillis-Steele inclusive scan of the 256 chunk sums.
    for (uint step = 1u; step < 256u; step *= 2u) {
        uint add = lane >= step ? partial[lane - step] : 0u;
        barrier();
        partial[lane] += add;
        barrier();
    }
    uint offset = partial[lane] - sum;
    for (uint t = first; t < last; ++t) {
        bins[tiles + t] = offset;
        bins[2u * tiles + t] = offset;
        offset += bins[t];
    }
}

void main() {
    if (STAGE == RASTER_BIN_SCAN) {
        scan();
        return;
    }
    uvec2 grid = tile_grid();
    uint tiles = tile_count_total();
    uint capacity = bin_capacity();
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    for (uint i = gl_GlobalInvocationID.x; i < big_count; i += stride) {
        uint gid = big[i];
        Poly poly;
        ivec4 box;
        if (!big_setup(gid, poly, box)) {
            continue;
        }
        for (int ty = box.y; ty <= box.w; ++ty) {
            for (int tx = box.x; tx <= box.z; ++tx) {
                uint tile = uint(ty) * grid.x + uint(tx);
                if (STAGE == RASTER_BIN_COUNT) {
                    atomicAdd(bins[tile], 1u);
                    continue;
                }
                uint slot = atomicAdd(bins[2u * tiles + tile], 1u);
                if (slot < capacity) {
                    bins[3u * tiles + slot] = i;
                    continue;
                }
                // Over capacity: this invocation covers the tile itself.
                for (uint k = 1u; k + 1u < poly.count; ++k) {
                    Tri t;
                    if (!make_tri(poly, k, t)) {
                        continue;
                    }
                    ivec2 lo = max(ivec2(tx, ty) * TILE_SIZE, t.bbox.xy);
                    ivec2 hi = min(ivec2(tx, ty) * TILE_SIZE + TILE_SIZE - 1, t.bbox.zw);
                    for (int y = lo.y; y <= hi.y; ++y) {
                        for (int x = lo.x; x <= hi.x; ++x) {
                            raster_pixel(poly, t, gid, ivec2(x, y));
                        }
                    }
                }
            }
        }
    }
}
