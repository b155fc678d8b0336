// Temporal reuse: committing a settled pixel's sample into the next cache.
// Included by temporal.glsl (in its order: each part uses the ones before it).
// The G-buffer's primary hit at `pix` (hybrid path), as far as commit_entry() reads it: the
// triangle and barycentrics only for moving geometry (the anchor).
PixelHit gbuffer_pixel_hit(ivec2 pix) {
    PixelHit h = unknown_pixel_hit();
    h.known = true;
    h.found = true;
    h.position = imageLoad(g_position, pix).xyz;
    h.ng_front = imageLoad(g_geometric, pix).xyz;
    if (tracks_motion()) {
        uvec4 ids = imageLoad(g_ids, pix);
        h.found = ids.x != 0xFFFFFFFFu;
        h.instance = ids.x;
        h.primitive = ids.y;
        h.bary = imageLoad(g_bary, pix).xy;
    }
    return h;
}

#ifndef RQR_KEY_WINNER_64
// Reused pixels take their sample's colour (a miss: the background seen along this pixel's
// own ray) and carry the sample, one frame older, into the next cache. Every other pixel
// starts the next cache empty; the tracing pass fills the ones it traces. Run by the pass
// that settles pixel q (state `st`).
// `e` is the sample the pixel shows (CACHE_PREV(resolved_winner(q))), read by the caller,
// which has usually read it already for its own tests; `hit` the pixel's primary hit where
// the caller traced it (a fill is cached there).
void commit_entry(uint q, uint st, CacheEntry e, PixelHit hit) {
    if ((st & PX_KIND_MASK) != PX_REUSE) {
        clear_entry(q);
        return;
    }
    if (cache_miss(e) && ((frame.flags & FLAG_SKY) != 0u || env_enabled())) {
        // The sky or environment seen through this pixel. (A uniform background needs no
        // recomputing.) The entry holds the colour the pixel shows (adaptive sub-sampling
        // reads it).
        e.color = miss_radiance(camera_ray(vec2(pixel_of(q)) + 0.5).dir, true);
        e.display = store_color(q, e.color);
    } else {
        // Shown as computed: no tonemapping per reused pixel.
        show_color(q, e.color, e.display);
    }
    e.meta = aged(e.meta);
    if ((st & PX_FILLED) != 0u && cache_miss(e)) {
        // A miss's colour is recomputed per pixel: the copy simply becomes this pixel's.
        e.position = camera_ray(vec2(pixel_of(q)) + 0.5).dir;
    } else if ((st & PX_FILLED) != 0u) {
        // A fill carries a copy of a neighbour's colour. Cached as it is, the copy would
        // collide with its original next frame and leave the pixel empty again, so the
        // sample density of a surface seen larger and larger would only fall. Instead it
        // becomes this pixel's sample at this pixel's primary hit: the G-buffer's or the
        // verify pass's where there is one, else where this pixel's ray meets the copied
        // sample's plane (the neighbourhood passed the edge test, so it is that smooth
        // surface).
        if ((params.flags & RP_GBUFFER) != 0u) {
            hit = gbuffer_pixel_hit(ivec2(pixel_of(q)));
        }
        if (hit.known) {
            e.position = hit.position;
            e.normal = pack_normal(hit.ng_front);
        } else {
            vec3 p;
            if (pixel_ray_meets_plane(pixel_of(q), e.position, unpack_normal(e.normal), p)) {
                e.position = p;
            }
        }
        e.meta = with_hops(e.meta, cache_hops(e) + 1u);
    }
    anchor_commit(q, resolved_winner(q), st, e, hit);
    CACHE_NEXT(q) = e;
}

#endif
