#version 460
// Temporal reuse, scatter (first of two 32-bit passes; temporal_scatter64.comp does both in one
// where the device has 64-bit buffer atomics): every sample of the previous frame's cache, moved
// with its object first on moving geometry, is projected into this camera, and the nearest
// depth key per pixel wins (atomicMin). One thread per cached sample, 8x8-pixel workgroups.
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

void main() {
    uvec2 pix = gl_GlobalInvocationID.xy;
    bool inside = pix.x < frame.width && pix.y < frame.height;
    uint q = pix.y * frame.width + pix.x;
    if (inside) {
        // Thread q reprojects the sample cached at pixel q of the previous frame. Nearest
        // depth wins; equal depths go to the lowest source index (temporal_resolve.comp), so
        // the result is deterministic. The scatter moves samples on moving geometry with their
        // objects first.
        CacheEntry e = moved_entry(q);
        uint target, key;
        if ((e.meta & CACHE_VALID) != 0u && project_sample(e, target, key)) {
            atomicMin(DEPTH_KEY(target), key);
        }
    }
}
