// Temporal reuse: the sample a pixel shows, pixel indices, and adaptive sub-sampling's blocks.
// Included by temporal.glsl (in its order: each part uses the ones before it).
// The sample shown at pixel q: the one the scatter chose, or, for a pixel no sample landed on,
// the neighbour's sample the fill chose (kept in the depth key, whose own use ended with the
// scatter). NO_SAMPLE when neither.
#ifndef RQR_KEY_WINNER_64
uint resolved_winner(uint q) {
    uint w = WINNER(q);
    if (w != NO_SAMPLE) {
        return w;
    }
    uint k = DEPTH_KEY(q);
    return (k != NO_SAMPLE && k >= FILLED_KEY) ? (k & ~FILLED_KEY) : NO_SAMPLE;
}

#endif
// Pixel of an index in pixel order. The row is a float quotient corrected by one (exact for
// any image size): a CPU device has no vector integer division and divides lane by lane.
uvec2 pixel_of(uint index) {
    uint y = uint((float(index) + 0.5) / float(frame.width));
    y = y * frame.width > index ? y - 1u : ((y + 1u) * frame.width <= index ? y + 1u : y);
    return uvec2(index - y * frame.width, y);
}

// Adaptive sub-sampling blocks of L x L pixels share their corners with their neighbours:
// block b spans pixels [b L, min(b L + L, n - 1)], and pixel x belongs to block
// min(x / L, blocks - 1) (so the last row/column closes the last block). L is a power of two
// (4, 2, 1), so these divide by shifting: a CPU device has no vector integer division.
uint block_count(uint n, uint l) { return max(1u, (n - 2u + l) >> uint(findLSB(l))); }

uvec2 block_span(uint x, uint n, uint l) {
    uint x0 = min(x >> uint(findLSB(l)), block_count(n, l) - 1u) * l;
    return uvec2(x0, min(x0 + l, n - 1u));
}

bool is_block_sample(uvec2 pix, uint l) {
    uvec2 sx = block_span(pix.x, frame.width, l);
    uvec2 sy = block_span(pix.y, frame.height, l);
    bool corner = (pix.x == sx.x || pix.x == sx.y) && (pix.y == sy.x || pix.y == sy.y);
    bool centre = pix.x == (sx.x + sx.y) / 2u && pix.y == (sy.x + sy.y) / 2u;
    return corner || centre;
}

// Whether a pixel in state `st` is traced at adaptive level `level` (1: every pixel to trace).
bool traced_at(uint st, uvec2 pix, uint level) {
    return (st & PX_KIND_MASK) == PX_TRACE && (level == 1u || is_block_sample(pix, level));
}
