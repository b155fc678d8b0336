#version 460
// Temporal reuse, shown: records the sample each pixel shows after the scatter, in pixel order
// (Shown, for the edge test of the neighbours), fills an empty pixel from an edge-sharing
// neighbour's sample, and with frameless rendering counts the candidates per refresh bin and the
// filled pixels for the budget. One thread per pixel, 8x8-pixel workgroups.
#extension GL_GOOGLE_include_directive : require
#include "scene.glsl"
#include "frame.glsl"
#include "counters.glsl"
#include "temporal.glsl"
#include "neighbours.glsl"
#include "frameless.glsl"

#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_clustered : require

layout(local_size_x = 8, local_size_y = 8) in;

// Reprojected point samples leave empty pixels where a surface is seen a little larger than
// before, and along the seams between regions whose samples have different sub-pixel offsets
// (samples keep the world position their colour belongs to). Left alone, each such pixel is
// traced at its centre, starts a region with yet another offset, and empty pixels multiply
// frame after frame. So an empty pixel takes the sample of an edge-sharing neighbour that
// falls nearest to its centre, within fill_radius pixels (nearest first, then the lowest
// source index): a splat footprint, as in the Render Cache. Only samples that sit where their
// colour was computed are copied (not fills or interpolations), so a colour moves at most one
// fill radius. The pixel still goes through the visibility tests (the G-buffer; on the rt
// path the edge test or a primary ray), so a disocclusion is not filled with whatever lies
// next to it. Returns the chosen sample's index, NO_SAMPLE when none qualifies.
//
// Run by the shown stage, so that classify (and the frameless threshold before it: the holes
// left count toward the budget) knows every pixel's sample. The neighbours' samples are read
// from their depth keys (where each falls, whether it may be copied): a fill gathers and
// projects nothing.
uint fill(ivec2 pix) {
    vec2 centre = vec2(pix) + 0.5;
    uint best = NO_SAMPLE;
    // Squared distances: no square roots.
    float best_d2 = params.fill_radius * params.fill_radius;
    [[unroll]] for (uint k = 0u; k < 4u; ++k) {
        ivec2 n = pix + EDGE_NEIGHBOURS[k];
        bool inside = n.x >= 0 && n.y >= 0 && n.x < int(frame.width) && n.y < int(frame.height);
        uint q = uint(n.y) * frame.width + uint(n.x);
        uint w = NO_SAMPLE;
        if (inside) {
            w = WINNER(q);
        }
        if (w != NO_SAMPLE) {
            // (Read only where a sample won: an empty neighbour's key is being rewritten.)
            uint key = DEPTH_KEY(q);
            vec2 d = key_film(uvec2(n), key) - centre;
            float d2 = dot(d, d);
            if ((key & KEY_NOT_COPYABLE) == 0u && (d2 < best_d2 || (d2 == best_d2 && w < best))) {
                best_d2 = d2;
                best = w;
            }
        }
    }
    return best;
}

// Records the sample pixel q shows (the scatter's winner) in pixel order, for the stage that
// looks at neighbours, and fills an empty pixel from its neighbours' samples. With frameless
// rendering it also counts the candidates and the filled pixels, so that the budget's refresh
// window is known before classify, which then selects the pixels to refresh itself (one pass
// over the image, not two).
void record_shown(uint q, uvec2 pix) {
    uint w = WINNER(q);
    bool candidate = false;
    bool filled = false;
    if (w == NO_SAMPLE) {
        // The edge test sees a filled pixel as empty too (its sample is a neighbour's).
        SHOWN(q).normal = 0u;
        uint f = fill(ivec2(pix));
        if (f != NO_SAMPLE) {
            // Later stages read the choice through resolved_winner(): the depth key is free
            // on a pixel no sample landed on (and fills read the keys of winners only).
            DEPTH_KEY(q) = FILLED_KEY | f;
            filled = true;
        }
    } else {
        CacheEntry e = CACHE_PREV(w);
        uint bits = SHOWN_SAMPLE | (cache_miss(e) ? SHOWN_MISS : 0u);
        float plane = cache_miss(e) ? 0.0 : dot(e.position - frame.camera_pos, unpack_normal(e.normal));
        SHOWN(q) = Shown(plane, e.normal | bits);
        candidate = frameless_candidate(e);
    }
    if ((params.flags & RP_FRAMELESS) != 0u) {
        // The candidates of this row segment (which shares a refresh bin) go into the
        // histogram, and the filled pixels (kept out of both the candidates and the pixels
        // that must be traced) into this workgroup's stripe: one reduction (8-bit fields; a
        // segment has 8 pixels) and one or two atomics per segment. Invocations of a subgroup
        // cover the workgroup's rows in order (lavapipe: a subgroup is one row; NVIDIA: four),
        // so a cluster of REFRESH_SEGMENT invocations is one segment.
        uint sums = subgroupClusteredAdd((candidate ? 1u : 0u) | (filled ? 256u : 0u), REFRESH_SEGMENT);
        if ((gl_SubgroupInvocationID & (REFRESH_SEGMENT - 1u)) == 0u) {
            if ((sums & 255u) != 0u) {
                atomicAdd(counters[C_HISTOGRAM + refresh_bin(pix)], sums & 255u);
            }
            if ((sums >> 8) != 0u) {
                atomicAdd(counters[stat_slot(C_SHOWN_FILLED)], sums >> 8);
            }
        }
    }
}

void main() {
    uvec2 pix = gl_GlobalInvocationID.xy;
    bool inside = pix.x < frame.width && pix.y < frame.height;
    uint q = pix.y * frame.width + pix.x;
    if (inside) {
        record_shown(q, pix);
    }
}
