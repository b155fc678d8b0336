// Hybrid path, shading pass (main of hybrid.comp and hybrid_vis.comp): primary visibility
// comes from the raster pass; shadows, reflections and refractions go through the same whitted()
// loop as the pure ray-traced pass, or with SHADING_DISTRIBUTED the same distributed() one
// (camera sample frame.sample_base: each sample's uniform has its own).
// Bindings (src/interface/passes.rs): the shared ones, BINDING_HYBRID_ACCUM (rgb sum, weight
// sum), _AOV, _COUNTERS, then the raster pass's images from BINDING_HYBRID_GBUFFER on: with
// HYBRID_VISIBILITY one visibility image (instance, primitive), otherwise the full G-buffer in
// GBUFFER_* order.
#include "scene.glsl"
#include "trace.glsl"
#include "frame.glsl"
#include "sampling.glsl"
#include "brdf.glsl"
#include "shade.glsl"
#include "counters.glsl"
#include "aov.glsl"
#include "gbuffer_decode.glsl"
#ifdef SHADING_DISTRIBUTED
#include "distributed.glsl"
#define SHADE_CAMERA_RAY(camera, primary, surface, hit, info) distributed(camera, primary, surface, hit, info, pix, frame.sample_base)
#include "interface_denoise.glsl"
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer GuideAccum { DenoiseGuide v[]; };
#else
#define SHADE_CAMERA_RAY(camera, primary, surface, hit, info) whitted(camera, primary, surface, hit, info)
#endif

layout(local_size_x = 8, local_size_y = 8) in;
layout(push_constant) uniform Push { HybridPush pc; };

layout(set = 0, binding = BINDING_HYBRID_ACCUM, scalar) buffer Accum { vec4 accum[]; };
layout(set = 0, binding = BINDING_HYBRID_AOV, scalar) writeonly buffer AovOut { Aov aov_out[]; };
layout(set = 0, binding = BINDING_HYBRID_COUNTERS, std430) buffer Counters { uint counters[]; };
#ifdef HYBRID_VISIBILITY
layout(set = 0, binding = BINDING_HYBRID_GBUFFER, rg32ui) uniform readonly uimage2D g_visibility;
#else
layout(set = 0, binding = BINDING_HYBRID_GBUFFER + GBUFFER_POSITION, rgba32f) uniform readonly image2D g_position;
layout(set = 0, binding = BINDING_HYBRID_GBUFFER + GBUFFER_NORMAL, rgba32f) uniform readonly image2D g_normal;
layout(set = 0, binding = BINDING_HYBRID_GBUFFER + GBUFFER_GEOMETRIC, rgba32f) uniform readonly image2D g_geometric;
layout(set = 0, binding = BINDING_HYBRID_GBUFFER + GBUFFER_BASE, rgba16f) uniform readonly image2D g_base;
layout(set = 0, binding = BINDING_HYBRID_GBUFFER + GBUFFER_EMISSIVE, rgba16f) uniform readonly image2D g_emissive;
layout(set = 0, binding = BINDING_HYBRID_GBUFFER + GBUFFER_IDS, rgba32ui) uniform readonly uimage2D g_ids;
layout(set = 0, binding = BINDING_HYBRID_GBUFFER + GBUFFER_BARY, rgba32f) uniform readonly image2D g_bary;
#endif

Surface unused_surface;

void main() {
    uvec2 pix = gl_GlobalInvocationID.xy;
    if (pix.x >= frame.width || pix.y >= frame.height) return;
    ivec2 ip = ivec2(pix);
    uint index = pix.y * frame.width + pix.x;
    vec2 film = vec2(pix) + 0.5 + frame.jitter;
    Ray camera = camera_ray(film);

    PrimaryInfo info;
    vec3 c;
#ifdef HYBRID_VISIBILITY
    uvec2 vis = imageLoad(g_visibility, ip).xy;
    Hit h = miss_hit(BIG_FLOAT);
    if (vis.x != 0xFFFFFFFFu) {
        vec3 bt = ray_triangle_hit(vis.x, vis.y, camera.origin, camera.dir, vec2(1.0 / 3.0));
        h.t = bt.z;
        h.instance = int(vis.x);
        h.primitive = int(vis.y);
        h.barycentrics = bt.xy;
    }
    c = SHADE_CAMERA_RAY(camera, PRIMARY_HIT, unused_surface, h, info);
    if (!info.hit) {
        info.t = 0.0;
        info.bary = vec2(0.0);
        info.normal = vec3(0.0);
        info.position = vec3(0.0);
        info.shading_normal = vec3(0.0);
        info.albedo = vec4(0.0);
    }
#else
    vec4 p = imageLoad(g_position, ip);
    uvec4 ids = imageLoad(g_ids, ip);
    bool hit = gbuffer_hit(ids);
    info.hit = hit;
    if (hit) {
        GbufferTexel g;
        g.position = p;
        g.normal = imageLoad(g_normal, ip);
        g.geometric = imageLoad(g_geometric, ip);
        g.base = imageLoad(g_base, ip);
        g.emissive = imageLoad(g_emissive, ip);
        g.ids = ids;
        Surface s;
        gbuffer_decode(g, s);
        Hit at = miss_hit(BIG_FLOAT);
        at.t = p.w;
        c = SHADE_CAMERA_RAY(camera, PRIMARY_SURFACE, s, at, info);
        vec4 b = imageLoad(g_bary, ip);
        info.t = p.w;
        info.instance = int(ids.x);
        info.primitive = int(ids.y);
        info.bary = b.xy;
        record_primary_surface(info, s);
    } else {
        c = miss_radiance(camera.dir, true);
#ifdef SHADING_DISTRIBUTED
        c += lights_met(camera.origin, camera.dir, BIG_FLOAT, 0.0);
        split_diffuse = vec3(0.0);
        split_unfiltered = c;
        split_diffuse_albedo = vec3(0.0);
        split_specular_albedo = vec3(0.0);
        split_roughness = 0.0;
#endif
        info = primary_miss();
    }
#endif
    vec4 contribution = vec4(c * pc.weight, pc.weight);
    accum[index] = (pc.flags & HYBRID_FIRST_SAMPLE) != 0u ? contribution : accum[index] + contribution;
    if ((pc.flags & HYBRID_WRITE_AOV) != 0u) {
#ifdef SHADING_DISTRIBUTED
        if ((frame.flags & FLAG_SEQUENCE_JITTER) != 0u) {
            info = pixel_centre_info(pix);
        }
#endif
        aov_out[index] = primary_aov(info, 1u);
    }
#ifdef SHADING_DISTRIBUTED
    if (pc.guide != 0ul) {
        GuideAccum g = GuideAccum(pc.guide);
        vec4 d = vec4(split_diffuse * pc.weight, pc.weight);
        vec4 u = vec4(split_unfiltered * pc.weight, pc.weight);
        if ((pc.flags & HYBRID_FIRST_SAMPLE) != 0u) {
            DenoiseGuide first;
            first.diffuse = d;
            first.unfiltered = u;
            first.diffuse_albedo = vec4(split_diffuse_albedo, 0.0);
            first.specular_albedo = vec4(split_specular_albedo, split_roughness);
            g.v[index] = first;
        } else {
            g.v[index].diffuse += d;
            g.v[index].unfiltered += u;
        }
    }
#endif
    for (uint k = 0u; k < 4u; ++k) {
        COUNTER_ADD(counters[ray_counter_slot(k)], rays_by_kind[k]);
    }
    COUNTER_ADD(counters[ray_counter_slot(COUNTER_SAMPLES)], 1u);
#ifdef SHADING_DISTRIBUTED
    COUNTER_ADD(counters[ray_counter_slot(RAY_DIFFUSE)], diffuse_rays);
#endif
}
