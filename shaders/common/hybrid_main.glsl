// Hybrid path, shading pass (main of hybrid.comp and hybrid_vis.comp, and of their distributed
// variants): primary visibility comes from the raster pass; shadows, reflections and
// refractions go through the same whitted() loop as the pure ray-traced pass, or with
// SHADING_DISTRIBUTED the same distributed paths, with each invocation taking
// PIXELS_PER_INVOCATION pixels in turn as raytrace_distributed.comp does (camera sample
// frame.sample_base: each sample's uniform has its own).
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
#include "interface_denoise.glsl"
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer GuideAccum { DenoiseGuide v[]; };
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

// What the raster pass saw at pixel pix: the camera ray, and how its shading starts (`primary`,
// with the surface or hit it hands in); false where it saw no surface (the full G-buffer),
// whose pixel shows the background. `info` is complete for a surface handed in; for a hit,
// the shading records it (hybrid_visibility_info finishes it).
bool hybrid_primary(uvec2 pix, out Ray camera, out uint primary, out Surface s, out Hit h, out PrimaryInfo info) {
    ivec2 ip = ivec2(pix);
    vec2 film = vec2(pix) + 0.5 + frame.jitter;
    camera = camera_ray(film);
    h = miss_hit(BIG_FLOAT);
    info = primary_miss();
#ifdef HYBRID_VISIBILITY
    primary = PRIMARY_HIT;
    uvec2 vis = imageLoad(g_visibility, ip).xy;
    if (vis.x != 0xFFFFFFFFu) {
        vec3 bt = ray_triangle_hit(vis.x, vis.y, camera.origin, camera.dir, vec2(1.0 / 3.0));
        h.t = bt.z;
        h.instance = int(vis.x);
        h.primitive = int(vis.y);
        h.barycentrics = bt.xy;
    }
    return true;
#else
    primary = PRIMARY_SURFACE;
    vec4 p = imageLoad(g_position, ip);
    uvec4 ids = imageLoad(g_ids, ip);
    if (!gbuffer_hit(ids)) {
        return false;
    }
    GbufferTexel g;
    g.position = p;
    g.normal = imageLoad(g_normal, ip);
    g.geometric = imageLoad(g_geometric, ip);
    g.base = imageLoad(g_base, ip);
    g.emissive = imageLoad(g_emissive, ip);
    g.ids = ids;
    gbuffer_decode(g, s);
    h.t = p.w;
    info.hit = true;
    info.t = p.w;
    info.instance = int(ids.x);
    info.primitive = int(ids.y);
    info.bary = imageLoad(g_bary, ip).xy;
    record_primary_surface(info, s);
    return true;
#endif
}

// The AOV of a pixel whose primary hit the shading recorded: zeros where it found nothing.
void hybrid_visibility_info(inout PrimaryInfo info) {
    if (!info.hit) {
        info.t = 0.0;
        info.bary = vec2(0.0);
        info.normal = vec3(0.0);
        info.position = vec3(0.0);
        info.shading_normal = vec3(0.0);
        info.albedo = vec4(0.0);
    }
}

// Adds sample colour c to pixel pix's accumulation and writes its AOVs (and, distributed, the
// denoiser's split of c).
void hybrid_write(uvec2 pix, vec3 c, PrimaryInfo info) {
    uint index = pix.y * frame.width + pix.x;
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
}

void flush_counters(uint samples) {
    for (uint k = 0u; k < 4u; ++k) {
        COUNTER_ADD(counters[ray_counter_slot(k)], rays_by_kind[k]);
    }
    COUNTER_ADD(counters[ray_counter_slot(COUNTER_SAMPLES)], samples);
#ifdef SHADING_DISTRIBUTED
    COUNTER_ADD(counters[ray_counter_slot(RAY_DIFFUSE)], diffuse_rays);
#endif
}

#ifdef SHADING_DISTRIBUTED
// A pixel without a surface (the full G-buffer's misses): the background and the lights a
// camera ray meets, nothing to split.
vec3 hybrid_background(uvec2 pix, Ray camera) {
    vec3 c = camera_miss_radiance(pix, camera.dir) + lights_met(camera.origin, camera.dir, BIG_FLOAT, 0.0);
    split_diffuse = vec3(0.0);
    split_unfiltered = c;
    split_diffuse_albedo = vec3(0.0);
    split_specular_albedo = vec3(0.0);
    split_roughness = 0.0;
    return c;
}

void main() {
    uint rows = (frame.height + PIXELS_PER_INVOCATION - 1u) / PIXELS_PER_INVOCATION;
    uvec2 base = gl_GlobalInvocationID.xy;
    uint samples = 0u;
    uint next = 0u;  // the next of this invocation's pixels
    uvec2 pix = uvec2(0u);
    PrimaryInfo info = primary_miss();
    PathState p;
    p.status = PATH_DONE;
    bool in_flight = false;
    for (;;) {
        if (p.status == PATH_DONE) {
            if (in_flight) {
                vec3 c = path_finish(p);
#ifdef HYBRID_VISIBILITY
                hybrid_visibility_info(info);
#endif
                hybrid_write(pix, c, info);
                samples += 1u;
                in_flight = false;
            }
            // Pixels without a surface are written at once, and the next one taken.
            for (;;) {
                pix = uvec2(base.x, base.y + next * rows);
                if (next >= PIXELS_PER_INVOCATION || base.y >= rows || pix.x >= frame.width || pix.y >= frame.height) {
                    break;
                }
                next += 1u;
                Ray camera;
                uint primary;
                Surface s;
                Hit h;
                if (hybrid_primary(pix, camera, primary, s, h, info)) {
                    p = path_start(camera, primary, s, h, pix, frame.sample_base);
                    in_flight = true;
                    break;
                }
                hybrid_write(pix, hybrid_background(pix, camera), primary_miss());
                samples += 1u;
            }
            if (!in_flight) {
                break;
            }
        }
        path_advance(p, info);
    }
    flush_counters(samples);
}
#else
void main() {
    uvec2 pix = gl_GlobalInvocationID.xy;
    if (pix.x >= frame.width || pix.y >= frame.height) return;
    Ray camera;
    uint primary;
    Surface s;
    Hit h;
    PrimaryInfo info;
    vec3 c;
    if (hybrid_primary(pix, camera, primary, s, h, info)) {
        c = whitted(camera, primary, s, h, info);
#ifdef HYBRID_VISIBILITY
        hybrid_visibility_info(info);
#endif
    } else {
        c = miss_radiance(camera.dir, true);
    }
    hybrid_write(pix, c, info);
    flush_counters(1u);
}
#endif
