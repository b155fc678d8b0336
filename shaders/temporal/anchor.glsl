// Temporal reprojection with moving geometry: every cached sample of a scene with
// animated transforms, skins or morph targets remembers the object-space point it was computed
// at, its Anchor (instance, triangle, barycentrics), in a side buffer double-buffered like the
// cache. The scatter moves each anchored sample to where that point is in this frame (this
// frame's instance transform and skinned/morphed vertices), so a sample on a moving object
// lands where the object went; the usual rejection tests (plane, normal, material) still run.
// Static scenes bind placeholders and never touch the anchors (RP_MOVING is off).
//
// Included by temporal.glsl after the bindings; every function is a no-op without RP_MOVING.
#ifndef RQR_TEMPORAL_ANCHOR_GLSL
#define RQR_TEMPORAL_ANCHOR_GLSL

// The anchors this frame reads and writes (buffer references, like the cache's).
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer Anchors { Anchor v[]; };
#define ANCHOR_PREV(q) Anchors(params.anchors_prev).v[q]
#define ANCHOR_NEXT(q) Anchors(params.anchors_next).v[q]

bool tracks_motion() { return (params.flags & RP_MOVING) != 0u; }

// Anchors the sample cached at slot q of the next cache.
void anchor_store(uint q, uint instance, uint primitive, vec2 bary) {
    if (tracks_motion()) {
        ANCHOR_NEXT(q) = Anchor(instance, primitive, bary);
    }
}

// The sample cached at slot q of the next cache has no anchor (a miss).
void anchor_clear(uint q) {
    if (tracks_motion()) {
        ANCHOR_NEXT(q).instance = NO_ANCHOR;
    }
}

// Anchors slot q of the next cache at the primary hit in the G-buffer images at `pix`.
void anchor_from_gbuffer(uint q, ivec2 pix) {
    if (!tracks_motion()) {
        return;
    }
    uvec4 ids = imageLoad(g_ids, pix);
    if (ids.x == 0xFFFFFFFFu) {
        anchor_clear(q);
    } else {
        anchor_store(q, ids.x, ids.y, imageLoad(g_bary, pix).xy);
    }
}

// The anchored triangle's corners in object space.
void anchor_triangle(uint instance, uint primitive, out GpuInstance inst, out vec3 p0, out vec3 p1, out vec3 p2) {
    inst = scene_instance(instance);
    uvec3 tri = scene_triangle(scene_geometry(inst.geometry), primitive);
    p0 = scene_position(tri.x);
    p1 = scene_position(tri.y);
    p2 = scene_position(tri.z);
}

// Where anchor `a` is in this frame: world position and glTF front-face geometric normal,
// computed as surface_at() does.
void anchored_point(Anchor a, out vec3 position, out vec3 ng_front) {
    GpuInstance inst;
    vec3 p0, p1, p2;
    anchor_triangle(a.instance, a.primitive, inst, p0, p1, p2);
    vec3 w = vec3(1.0 - a.bary.x - a.bary.y, a.bary.x, a.bary.y);
    position = (inst.object_to_world * vec4(w.x * p0 + w.y * p1 + w.z * p2, 1.0)).xyz;
    ng_front = normalize(mat3(inst.normal_to_world) * cross(p1 - p0, p2 - p0));
}

// Barycentrics (b1, b2) of world point `p`, which lies on the plane of triangle `primitive` of
// `instance` in this frame (possibly outside the triangle). Barycentrics are affine-invariant,
// so they are solved in object space.
vec2 anchor_barycentrics(uint instance, uint primitive, vec3 p) {
    GpuInstance inst;
    vec3 p0, p1, p2;
    anchor_triangle(instance, primitive, inst, p0, p1, p2);
    vec3 v = (inst.world_to_object * vec4(p, 1.0)).xyz - p0;
    vec3 e1 = p1 - p0, e2 = p2 - p0;
    float d11 = dot(e1, e1), d12 = dot(e1, e2), d22 = dot(e2, e2);
    float v1 = dot(v, e1), v2 = dot(v, e2);
    float det = d11 * d22 - d12 * d12;
    if (!(abs(det) > 1e-30)) {
        return vec2(0.0);
    }
    return vec2(d22 * v1 - d12 * v2, d11 * v2 - d12 * v1) / det;
}

// The entry cached at slot q of the previous cache, moved with its object to this frame: its
// position and normal are recomputed from its anchor and written back, so every later stage of
// the frame (shown records, classification, commit) sees where the sample is now. Run by the
// scatter, one invocation per slot.
CacheEntry moved_entry(uint q) {
    CacheEntry e = CACHE_PREV(q);
    if (!tracks_motion() || (e.meta & CACHE_VALID) == 0u || cache_miss(e)) {
        return e;
    }
    Anchor a = ANCHOR_PREV(q);
    if (a.instance == NO_ANCHOR) {
        return e;
    }
    vec3 p, ng;
    anchored_point(a, p, ng);
    // A surface that turned its other side to the camera (a rotating object's face going
    // round the back) hides the sample: the scatter drops it, so it cannot show through a
    // face that came into view without samples of its own (the rt path's edge test would not
    // catch that). The old side is judged from this frame's camera too.
    bool ortho = frame.ortho != 0u;
    vec3 view_before = ortho ? camera_forward() : e.position - frame.camera_pos;
    vec3 view_after = ortho ? camera_forward() : p - frame.camera_pos;
    bool front_before = dot(unpack_normal(e.normal), view_before) < 0.0;
    bool front_after = dot(ng, view_after) < 0.0;
    if (front_before != front_after) {
        e.meta = 0u;
        CACHE_PREV(q).meta = 0u;
        return e;
    }
    // A sample that moves with its object keeps the shading of where the object was
    // (shadows, highlights), so it is re-traced sooner (classify, MOVED_MAX_AGE). Moved: by
    // more than float noise relative to its distance (a traced hit point and the same point
    // recomputed from its anchor differ by that much).
    if (distance(p, e.position) > 1e-4 * max(distance(p, frame.camera_pos), 1e-6)) {
        e.meta |= CACHE_MOVED;
        CACHE_PREV(q).meta = e.meta;
    }
    e.position = p;
    e.normal = pack_normal(ng);
    CACHE_PREV(q).position = e.position;
    CACHE_PREV(q).normal = e.normal;
    return e;
}

// The anchor of the entry `e` that commit_entry() caches at slot q of the next cache for a
// pixel in state `st` reusing the previous cache's slot w: the source's anchor, or for a fill
// (whose entry commit_entry() moved to this pixel's primary hit) that hit, where known, or
// the point on the copied sample's triangle plane.
void anchor_commit(uint q, uint w, uint st, CacheEntry e, PixelHit hit) {
    if (!tracks_motion()) {
        return;
    }
    if (cache_miss(e)) {
        anchor_clear(q);
    } else if ((st & PX_FILLED) == 0u) {
        Anchor a = ANCHOR_PREV(w);
        anchor_store(q, a.instance, a.primitive, a.bary);
    } else if (hit.known && hit.found) {
        anchor_store(q, hit.instance, hit.primitive, hit.bary);
    } else if (hit.known) {
        anchor_clear(q);
    } else {
        Anchor a = ANCHOR_PREV(w);
        if (a.instance != NO_ANCHOR) {
            a.bary = anchor_barycentrics(a.instance, a.primitive, e.position);
        }
        anchor_store(q, a.instance, a.primitive, a.bary);
    }
}

#endif
