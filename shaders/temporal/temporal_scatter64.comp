#version 460
// Temporal reuse's scatter in one pass, for devices with 64-bit buffer atomics
// (src/render/temporal/ picks it; temporal_scatter.comp + temporal_resolve.comp do the same in
// two 32-bit passes elsewhere): every cached sample is projected into this camera and takes its
// pixel with an atomicMin of depth key << 32 | source index, so the nearest sample wins and
// equal depths go to the lowest index, exactly as the two-pass version decides.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
#define RQR_KEY_WINNER_64
#include "scene.glsl"
#include "frame.glsl"
#include "temporal.glsl"

layout(set = 0, binding = BINDING_RP_KEY_WINNER, std430) buffer KeyWinner64 { uint64_t key_winner64[]; };

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    uvec2 pix = gl_GlobalInvocationID.xy;
    if (pix.x >= frame.width || pix.y >= frame.height) {
        return;
    }
    uint q = pix.y * frame.width + pix.x;
    // Samples on moving geometry move with their objects first (anchor.glsl).
    CacheEntry e = moved_entry(q);
    uint target, key;
    if ((e.meta & CACHE_VALID) != 0u && project_sample(e, target, key)) {
        atomicMin(key_winner64[target], (uint64_t(key) << 32) | uint64_t(q));
    }
}
