#version 460
// Temporal reuse, frameless threshold: from the shown stage's histogram of the candidates'
// refresh bins, places this frame's refresh window where the sweep stands, so that classify
// selects the pixels to refresh. One invocation does the work (dispatched as one workgroup).
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

// Frameless budget: re-trace frameless_fraction of all pixels per frame. Pixels that must be
// traced anyway count first; the rest of the budget goes to candidates in the sweep's window,
// whole bins from where the sweep stands until the window holds the rest (so at least the
// budget is traced, and at most one bin more).
void threshold() {
    uint budget = uint(ceil(params.frameless_fraction * float(pixel_count())));
    uint candidates = 0u;
    for (uint b = 0u; b < REFRESH_BINS; ++b) {
        candidates += counters[C_HISTOGRAM + b];
    }
    uint filled = 0u;
    for (uint s = 0u; s < COUNTER_STRIPES; ++s) {
        filled += counters[(s + 1u) * COUNTER_STRIPE_WORDS + C_SHOWN_FILLED];
    }
    // Every pixel that showed a sample and is no candidate must be traced, and so must every
    // empty pixel no neighbour filled (a hole): they count first. Filled pixels keep a
    // neighbour's copy, outside the budget.
    uint forced = pixel_count() - candidates - filled;
    uint extra = budget > forced ? budget - forced : 0u;
    uint start = counters[C_SWEEP];
    uint bins = 0u;
    for (uint taken = 0u; taken < extra && bins < REFRESH_BINS; ++bins) {
        taken += counters[C_HISTOGRAM + ((start + bins) & (REFRESH_BINS - 1u))];
    }
    counters[C_WINDOW_START] = start;
    counters[C_WINDOW_BINS] = bins;
    counters[C_SWEEP] = (start + bins) & (REFRESH_BINS - 1u);
}

void main() {
    if (gl_GlobalInvocationID.x == 0u && gl_GlobalInvocationID.y == 0u) {
        threshold();
    }
}
