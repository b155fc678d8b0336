// Temporal reuse: the samples a pixel's edge-sharing neighbours show, and the rt path's edge test
// over them (the shown stage's fill reads the same neighbours).
// Included by the stages that use it (temporal_*.comp), after temporal.glsl.
#ifndef RQR_TEMPORAL_NEIGHBOURS_GLSL
#define RQR_TEMPORAL_NEIGHBOURS_GLSL

// The records of the samples a pixel's 4 edge-sharing neighbours show (Shown, written by the
// previous stage; empty outside the image), in pixel order, for the edge test.
struct Neighbours {
    Shown shown[4];
};

const ivec2 EDGE_NEIGHBOURS[4] = ivec2[4](ivec2(0, -1), ivec2(-1, 0), ivec2(1, 0), ivec2(0, 1));

Neighbours load_neighbours(ivec2 pix) {
    Neighbours nb;
    [[unroll]] for (uint k = 0u; k < 4u; ++k) {
        ivec2 n = pix + EDGE_NEIGHBOURS[k];
        bool inside = n.x >= 0 && n.y >= 0 && n.x < int(frame.width) && n.y < int(frame.height);
        nb.shown[k] = Shown(0.0, 0u);
        if (inside) {
            nb.shown[k] = SHOWN(uint(n.y) * frame.width + uint(n.x));
        }
    }
    return nb;
}

// Render Cache-style edge test for the rt path without a full primary-verify pass: a
// sample is trusted when the samples of its edge-sharing neighbours lie on the same smooth
// surface (an edge that is a continuous curve passes between a pixel and one of them). A
// surface that was hidden comes into view next to the silhouette that hid it, a depth edge,
// so the pixels there get a primary ray. (A hidden surface coming out from behind an edge
// faster than a pixel per frame can show the farther surface for a few frames beyond that
// band: the price of the mode; --rt-visibility full and the hybrid path check every pixel.)
//
// The plane distance is measured from the neighbour's tangent plane (Shown keeps two words per
// pixel: the plane's offset and the normal); where the normals pass the normal test, the two
// samples' planes nearly agree, so which one is used hardly matters.
//
// Every neighbour is tested and the results combined, without early exits or divisions: on a
// CPU device (lavapipe) a branch that some lanes leave costs more than the arithmetic it skips.
bool near_edge(CacheEntry e, Neighbours nb) {
    bool miss = cache_miss(e);
    vec3 from_camera = e.position - frame.camera_pos;
    // The plane distance relative to the view depth, compared as a distance.
    float limit = params.edge_threshold * (miss ? 1.0 : max(view_depth(e.position), 1e-6));
    vec3 en = unpack_normal(e.normal);
    bool edge = false;
    [[unroll]] for (uint k = 0u; k < 4u; ++k) {
        uint bits = nb.shown[k].normal;
        // An empty neighbour is traced this frame anyway (or filled from its own neighbours).
        // Counting it as an edge would verify the neighbourhood of every pixel a stretched
        // surface leaves empty: on an orbit, most of the rays this mode saves.
        bool landed = (bits & SHOWN_SAMPLE) != 0u;
        bool other_miss = (bits & SHOWN_MISS) != 0u;
        vec3 on = unpack_normal(bits);
        bool apart = abs(dot(from_camera, on) - nb.shown[k].plane) > limit || dot(on, en) < params.normal_threshold;
        edge = edge || (landed && (other_miss != miss || (!miss && apart)));
    }
    return edge;
}

#endif
