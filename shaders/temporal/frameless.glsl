// Temporal reuse, frameless rendering: the refresh order, and which pixels the sweep may keep or
// refreshes this frame (the threshold stage places its window).
// Included by the stages that use it (temporal_*.comp), after temporal.glsl.
#ifndef RQR_TEMPORAL_FRAMELESS_GLSL
#define RQR_TEMPORAL_FRAMELESS_GLSL

// Frameless refresh order: a fixed interleaved-gradient-noise rank (Jimenez 2014) of the
// pixel's row segment (REFRESH_SEGMENT pixels), quantized to REFRESH_BINS bins: a stratified
// permutation of the image. Each frame refreshes the candidates in a window of bins that
// starts where the previous frame's ended (a sweep, as in Bishop et al.'s frameless
// rendering, but stratified instead of random): what one frame refreshes is spread evenly, and
// every candidate is refreshed once per pass of the sweep. Segments, not pixels: the shown
// stage counts a segment's candidates with one atomic (a per-pixel atomic cost 0.7 ms of a
// 13 ms frame on lavapipe), and the tracing pass traces neighbouring pixels together. (Oldest
// first by an age x rank histogram chose the same pixels on a still camera.)
uint refresh_bin(uvec2 pix) {
    vec2 segment = vec2(pix.x / REFRESH_SEGMENT, pix.y);
    float rank = fract(52.9829189 * fract(0.06711056 * segment.x + 0.00583715 * segment.y));
    return min(uint(int(rank * float(REFRESH_BINS))), REFRESH_BINS - 1u);
}

// Frameless rendering: whether a pixel showing sample `e` may keep it this frame (the
// refresh sweep decides), as opposed to pixels that must be traced anyway. The samples that
// classify then rejects (G-buffer, visibility) are traced on top of the budget.
bool frameless_candidate(CacheEntry e) {
    uint age = cache_age(e.meta);
    return (params.flags & RP_FRAMELESS) != 0u && (e.meta & CACHE_VIEW_DEPENDENT) == 0u && age < params.max_age
        && ((e.meta & CACHE_MOVED) == 0u || age < MOVED_MAX_AGE);
}

// Whether the frameless budget refreshes a candidate pixel: its bin lies in this frame's
// window (which wraps around).
bool frameless_selects(uvec2 pix) {
    return ((refresh_bin(pix) - counters[C_WINDOW_START]) & (REFRESH_BINS - 1u)) < counters[C_WINDOW_BINS];
}

#endif
