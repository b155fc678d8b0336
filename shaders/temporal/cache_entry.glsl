// Temporal reuse: a cached sample's meta word (flags, fill hops, age, material) and its
// normal packed into one word.
// Included by temporal.glsl (in its order: each part uses the ones before it).
// CacheEntry: a cached sample, the colour of one primary hit and where it was. meta holds
// CACHE_* flags in bits 0-3; bits 4-5 count how many fills away from where it was computed the
// colour is (an interpolated colour counts as one; a fill copies only samples below
// params.max_hops); bits 6-15 its age in frames (saturating at MAX_CACHE_AGE); bits 16-31 its
// material.
uint cache_hops(CacheEntry e) { return (e.meta >> CACHE_HOPS_SHIFT) & 3u; }
uint with_hops(uint meta, uint hops) { return (meta & ~(3u << CACHE_HOPS_SHIFT)) | (min(hops, 3u) << CACHE_HOPS_SHIFT); }
uint cache_age(uint meta) { return (meta >> CACHE_AGE_SHIFT) & MAX_CACHE_AGE; }
// One frame older (saturating).
uint aged(uint meta) { return cache_age(meta) < MAX_CACHE_AGE ? meta + (1u << CACHE_AGE_SHIFT) : meta; }
uint cache_material(CacheEntry e) { return e.meta >> CACHE_MATERIAL_SHIFT; }
// The meta word of a new sample of `material`, `hops` fills away from computed colour (an
// interpolated colour counts as one), age 0.
uint new_cache_meta(uint flags, uint hops, uint material) { return with_hops(flags, hops) | (material << CACHE_MATERIAL_SHIFT); }
bool cache_miss(CacheEntry e) { return (e.meta & CACHE_MISS) != 0u; }

// Unit normals in one word: octahedral coordinates (Cigolle et al. 2014), 14 bits each in
// bits 18-31 and 4-17 (bits 0-3 are left for Shown's flags). About 2e-4 rad of error, far
// below the normal and plane thresholds that read it.
vec2 oct_wrap(vec2 v) { return (1.0 - abs(v.yx)) * vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0); }
uint pack_normal(vec3 n) {
    n /= max(abs(n.x) + abs(n.y) + abs(n.z), 1e-20);
    vec2 o = n.z >= 0.0 ? n.xy : oct_wrap(n.xy);
    uvec2 u = uvec2(round(clamp(o * 0.5 + 0.5, 0.0, 1.0) * 16383.0));
    return (u.x << 18) | (u.y << 4);
}
// (The z < 0 half is unfolded without branches, Stubbe's form of oct_wrap, and normalized by
// one reciprocal square root: the edge test unpacks five normals per pixel.)
vec3 unpack_normal(uint p) {
    vec2 o = vec2(uvec2(p >> 18, (p >> 4) & 0x3FFFu)) * (2.0 / 16383.0) - 1.0;
    vec3 n = vec3(o, 1.0 - abs(o.x) - abs(o.y));
    float t = max(-n.z, 0.0);
    n.xy += vec2(n.x >= 0.0 ? -t : t, n.y >= 0.0 ? -t : t);
    return n * inversesqrt(dot(n, n));
}
