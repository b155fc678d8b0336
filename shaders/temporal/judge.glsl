// Temporal reuse: view dependence and the disocclusion tests of a cached sample against this
// frame's primary hit.
// Included by temporal.glsl (in its order: each part uses the ones before it).
#include "disocclusion.glsl"
// Whether a surface looks different from another viewpoint: transmissive, metal, see-through
// blending, or glossy enough for the Whitted mirror term ((1 - roughness)^2 of the reflection).
bool surface_view_dependent(float metallic, float roughness, float transmission, uint alpha_mode, float alpha) {
    return transmission > 0.0 || metallic >= params.specular_metallic || roughness < params.specular_roughness
        || (alpha_mode == ALPHA_BLEND && alpha < 1.0);
}

// The same test on a material's factors (where no texture-modulated values are at hand).
bool material_view_dependent(uint material) {
    GpuMaterial m = scene_material(material);
    return surface_view_dependent(m.metallic, m.roughness, m.transmission, m.alpha_mode, m.base_color.a);
}

// ReBLUR / SVGF-style disocclusion test of a cached sample against this frame's primary hit
// `p` with front-face normal `ng` and `material`: same plane (distance relative to the view
// depth), similar normal, same material.
bool sample_matches(CacheEntry e, vec3 p, vec3 ng, uint material) {
    if (cache_miss(e)) {
        return false;
    }
    float z = max(view_depth(p), 1e-6);
    return surfaces_match(e.position, unpack_normal(e.normal), p, ng, z, params.plane_threshold, params.normal_threshold)
        && cache_material(e) == material;
}

// Decides a pixel with candidate sample `e` from this frame's primary hit there.
uint judge_primary(CacheEntry e, bool hit, vec3 p, vec3 ng, uint material, float metallic, float roughness,
                   float transmission, float alpha) {
    if (!hit) {
        return cache_miss(e) ? PX_REUSE : (PX_TRACE | PX_REJECTED);
    }
    if (surface_view_dependent(metallic, roughness, transmission, scene_material(material).alpha_mode, alpha)) {
        return PX_TRACE | PX_VIEW_DEPENDENT;
    }
    return sample_matches(e, p, ng, material) ? PX_REUSE : (PX_TRACE | PX_REJECTED);
}

// The same from the primary hit in the G-buffer images at `pix`.
uint judge_against_gbuffer(ivec2 pix, CacheEntry e) {
    uvec4 ids = imageLoad(g_ids, pix);
    if (ids.x == 0xFFFFFFFFu) {
        return judge_primary(e, false, vec3(0.0), vec3(0.0), 0u, 0.0, 1.0, 0.0, 1.0);
    }
    vec4 p = imageLoad(g_position, pix);
    vec4 n = imageLoad(g_normal, pix);
    vec4 ng = imageLoad(g_geometric, pix);
    vec4 base = imageLoad(g_base, pix);
    return judge_primary(e, true, p.xyz, ng.xyz, ids.z & 0x7FFFFFFFu, ng.w, n.w, uintBitsToFloat(ids.w), base.a);
}

// A pixel's own primary hit, where the pass that commits the pixel knows it: the G-buffer's
// (hybrid path), or the ray the rt verify pass has just traced, kept in registers (that
// pass stored it in G-buffer images for its readers once: a quarter of its time on lavapipe).
struct PixelHit {
    bool known;
    bool found;
    vec3 position;
    vec3 ng_front;
    uint instance;
    uint primitive;
    vec2 bary;
};

// For passes that traced no primary ray for the pixel.
PixelHit unknown_pixel_hit() {
    return PixelHit(false, false, vec3(0.0), vec3(0.0), 0u, 0u, vec2(0.0));
}
