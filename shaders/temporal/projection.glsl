// Temporal reuse: projecting cached samples into this frame's camera (depth keys and where in
// its pixel a sample falls), and the view geometry the tests use.
// Included by temporal.glsl (in its order: each part uses the ones before it).
// An entry without CACHE_VALID is empty: no reader looks past its meta.
void clear_entry(uint q) { CACHE_NEXT(q).meta = 0u; }

vec3 camera_forward() { return normalize(-frame.camera_to_world[2].xyz); }

// Where the ray through pixel `pix`'s centre meets the plane through `point` with normal `n`,
// in front of the camera: false where it runs (nearly) parallel to the plane or meets it
// behind. For samples cached on a neighbour's plane (fills, interpolated blocks).
bool pixel_ray_meets_plane(uvec2 pix, vec3 point, vec3 n, out vec3 hit) {
    Ray r = camera_ray(vec2(pix) + 0.5);
    float denom = dot(r.dir, n);
    float t = dot(point - r.origin, n) / (abs(denom) > 1e-4 ? denom : 1.0);
    hit = r.origin + t * r.dir;
    return abs(denom) > 1e-4 && t > 0.0;
}

// Distance along the view axis (the "view z" of the rejection test).
float view_depth(vec3 p) { return dot(p - frame.camera_pos, camera_forward()); }

// Projects a cached sample into the current camera. Returns false when it falls outside the
// image or behind the camera; otherwise the pixel index and a depth key where the nearest
// sample has the smallest key (positive float bits order like the floats; misses, points at
// infinity, lose to every hit). The key's KEY_LOW_MASK bits, the depth's lowest mantissa bits
// (depths within 2^-16 of each other count as equal), hold where in the pixel the sample falls
// and whether a fill may copy it: what the fill needs of a neighbour's sample, without a
// gather. Misses are not reprojected by orthographic cameras, whose rays all share one
// direction.
// A cached sample in clip space (a miss, a direction: a point at infinity).
vec4 clip_of(vec3 position, bool miss) { return frame.view_proj * vec4(position, miss ? 0.0 : 1.0); }
// Where on the film, in pixels, a point in clip space in front of the camera falls.
vec2 film_of(vec4 clip) { return (clip.xy / clip.w * 0.5 + 0.5) * vec2(frame.width, frame.height); }

bool project_sample(CacheEntry e, out uint pixel, out uint key) {
    pixel = NO_SAMPLE;
    key = NO_SAMPLE;
    bool miss = cache_miss(e);
    if (miss && frame.ortho != 0u) {
        return false;
    }
    vec4 clip = clip_of(e.position, miss);
    float z = miss ? 1.0 : view_depth(e.position);
    if (!(clip.w > 0.0) || !(z > 0.0)) {
        return false;
    }
    vec2 film = film_of(clip);
    if (!(film.x >= 0.0 && film.y >= 0.0 && film.x < float(frame.width) && film.y < float(frame.height))) {
        return false;
    }
    // The film position in places (eighths of a pixel), whose high bits are the pixel and low
    // bits the place: one conversion per axis, and a signed one (a CPU device converts floats
    // to unsigned integers lane by lane). Clamped: film * 8 may round up to the image's edge.
    const uint places = 1u << KEY_PLACE_BITS;
    uvec2 at = min(uvec2(ivec2(film * float(places))), uvec2(frame.width, frame.height) * places - 1u);
    uvec2 p = at >> KEY_PLACE_BITS;
    pixel = p.y * frame.width + p.x;
    key = ((miss ? 0x7F800000u : floatBitsToUint(z)) & ~KEY_LOW_MASK) | (cache_hops(e) >= params.max_hops ? KEY_NOT_COPYABLE : 0u)
        | ((at.x & (places - 1u)) << KEY_PLACE_BITS) | (at.y & (places - 1u));
    return true;
}

// Where in the film, in pixels, the sample with depth key `key` that won pixel `pix` falls (to
// an eighth of a pixel: the centre of its place).
vec2 key_film(uvec2 pix, uint key) {
    const float places = float(1u << KEY_PLACE_BITS);
    uvec2 place = uvec2((key >> KEY_PLACE_BITS) & ((1u << KEY_PLACE_BITS) - 1u), key & ((1u << KEY_PLACE_BITS) - 1u));
    return vec2(pix) + (vec2(place) + 0.5) / places;
}
