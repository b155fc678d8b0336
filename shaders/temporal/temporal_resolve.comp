#version 460
// Temporal reuse, resolve (second of the two 32-bit scatter passes): every cached sample projects
// again, and among the samples whose depth key won their pixel the lowest source index wins
// (atomicMin), so equal depths resolve deterministically. One thread per cached sample.
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
        CacheEntry e = CACHE_PREV(q);
        uint target, key;
        if ((e.meta & CACHE_VALID) != 0u && project_sample(e, target, key)) {
            if (DEPTH_KEY(target) == key) {
                atomicMin(WINNER(target), q);
            }
        }
    }
}
