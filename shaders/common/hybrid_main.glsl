// Hybrid path, shading pass (main of hybrid.comp and hybrid_vis.comp): primary visibility
// comes from the raster pass; shadows, reflections and refractions go through the same whitted()
// loop as the pure ray-traced pass.
// Bindings: 0-2 scene/textures/ray backend, 3 frame, 4 accumulation (rgb sum, weight sum),
// 5 AOVs, 6 ray counters, then the raster pass's images: with HYBRID_VISIBILITY one visibility
// image at 7 (instance, primitive), otherwise the full G-buffer at 7-13.
#include "scene.glsl"
#include "trace.glsl"
#include "frame.glsl"
#include "sampling.glsl"
#include "brdf.glsl"
#include "shade.glsl"
#include "counters.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
#define HYBRID_FIRST_SAMPLE 1u
#define HYBRID_WRITE_AOV 4u
layout(push_constant) uniform Push { uint flags; float weight; } pc;

layout(set = 0, binding = 4, scalar) buffer Accum { vec4 accum[]; };
struct Aov {
    vec4 normal_depth;
    vec4 position_inst;
    vec4 bary_prim;
};
layout(set = 0, binding = 5, scalar) writeonly buffer AovOut { Aov aov_out[]; };
layout(set = 0, binding = 6, std430) buffer Counters { uint counters[]; };
#ifdef HYBRID_VISIBILITY
layout(set = 0, binding = 7, rg32ui) uniform readonly uimage2D g_visibility;
#else
layout(set = 0, binding = 7, rgba32f) uniform readonly image2D g_position;
layout(set = 0, binding = 8, rgba32f) uniform readonly image2D g_normal;
layout(set = 0, binding = 9, rgba32f) uniform readonly image2D g_geometric;
layout(set = 0, binding = 10, rgba16f) uniform readonly image2D g_base;
layout(set = 0, binding = 11, rgba16f) uniform readonly image2D g_emissive;
layout(set = 0, binding = 12, rgba32ui) uniform readonly uimage2D g_ids;
layout(set = 0, binding = 13, rgba32f) uniform readonly image2D g_bary;
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
    c = whitted(camera, PRIMARY_HIT, unused_surface, h, info);
    if (!info.hit) {
        info.t = 0.0;
        info.bary = vec2(0.0);
        info.normal = vec3(0.0);
        info.position = vec3(0.0);
    }
#else
    vec4 p = imageLoad(g_position, ip);
    uvec4 ids = imageLoad(g_ids, ip);
    bool hit = ids.x != 0xFFFFFFFFu;
    info.hit = hit;
    if (hit) {
        vec4 n = imageLoad(g_normal, ip);
        vec4 ng = imageLoad(g_geometric, ip);
        vec4 base = imageLoad(g_base, ip);
        vec4 em = imageLoad(g_emissive, ip);
        Surface s;
        s.position = p.xyz;
        s.n = n.xyz;
        s.roughness = n.w;
        s.ng_front = ng.xyz;
        s.metallic = ng.w;
        s.base_color = base.rgb;
        s.alpha = base.a;
        s.emissive = em.rgb;
        s.occlusion = em.a;
        s.material = ids.z & 0x7FFFFFFFu;
        s.front_face = (ids.z >> 31) != 0u;
        s.ng = s.front_face ? s.ng_front : -s.ng_front;
        s.transmission = uintBitsToFloat(ids.w);
        GpuMaterial m = scene_material(s.material);
        s.ior = m.ior;
        s.atten_color = m.attenuation_color;
        s.atten_dist = m.thickness > 0.0 ? m.attenuation_distance : BIG_FLOAT;
        s.alpha_mode = m.alpha_mode;
        // The full G-buffer keeps no layer textures: their factors only.
        surface_layers(s, m);
        Hit at = miss_hit(BIG_FLOAT);
        at.t = p.w;
        c = whitted(camera, PRIMARY_SURFACE, s, at, info);
        vec4 b = imageLoad(g_bary, ip);
        info.t = p.w;
        info.instance = int(ids.x);
        info.primitive = int(ids.y);
        info.bary = b.xy;
        info.normal = s.ng_front;
        info.position = s.position;
    } else {
        c = background_radiance(camera.dir);
        info.t = 0.0;
        info.instance = -1;
        info.primitive = -1;
        info.bary = vec2(0.0);
        info.normal = vec3(0.0);
        info.position = vec3(0.0);
    }
#endif
    vec4 contribution = vec4(c * pc.weight, pc.weight);
    accum[index] = (pc.flags & HYBRID_FIRST_SAMPLE) != 0u ? contribution : accum[index] + contribution;
    if ((pc.flags & HYBRID_WRITE_AOV) != 0u) {
        Aov a;
        a.normal_depth = vec4(info.normal, info.t);
        a.position_inst = vec4(info.position, float(info.instance));
        a.bary_prim = vec4(info.bary, float(info.primitive), 1.0);
        aov_out[index] = a;
    }
    for (uint k = 0u; k < 4u; ++k) {
        COUNTER_ADD(counters[k], rays_by_kind[k]);
    }
    COUNTER_ADD(counters[4], 1u);
}
