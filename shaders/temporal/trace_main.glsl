// Temporal reuse, trace (main of temporal_trace.comp and temporal_trace_distributed.comp):
// traces the pixels on the job list (every pixel that needs new colour, or one level of
// adaptive sub-sampling's samples) with the shared Whitted loop, or with SHADING_DISTRIBUTED
// the distributed one (camera sample number frame.sample_base: one sample per pixel and frame),
// writes their colour and caches the new sample for the next frame, which a reused pixel then
// shows as it was (noise included). The primary hit comes from the G-buffer on the hybrid path;
// on the rt path the shading loop traces the primary ray.
//
// ONE shading call site: lavapipe's JIT time grows with every inlined copy of the loop.
#include "scene.glsl"
#include "trace.glsl"
#include "frame.glsl"
#include "sampling.glsl"
#include "brdf.glsl"
#include "shade.glsl"
#include "gbuffer_decode.glsl"
#include "counters.glsl"
#include "temporal.glsl"
#ifdef SHADING_DISTRIBUTED
#include "distributed.glsl"
#endif

layout(local_size_x = 64) in;
// TracePush: the job list this pass works through (LIST_TRACE first, then LIST_VERIFY for the
// later adaptive levels).
layout(push_constant) uniform Push { TracePush pc; };

Surface unused_surface;

void main() {
    // Job lists longer than a device launches in one dimension come in rows of workgroups.
    uint i = linear_invocation(gl_WorkGroupSize.x);
    if (i >= job_count(pc.list)) {
        return;
    }
    uint q = job_at(pc.list, i);
    ivec2 pix = ivec2(pixel_of(q));
    uint st = STATE(q);
    Ray camera = camera_ray(vec2(pix) + 0.5);
    // The rt path traces its own primary ray, also for a candidate the verify pass
    // rejected (a second ray for a few pixels costs less than a G-buffer round trip for all).
    bool known = (params.flags & RP_GBUFFER) != 0u;

    PrimaryInfo info = primary_miss();
    Surface s = unused_surface;
    float t = 0.0;
    if (known) {
        GbufferTexel g;
        g.ids = imageLoad(g_ids, pix);
        info.hit = gbuffer_hit(g.ids);
        if (info.hit) {
            g.position = imageLoad(g_position, pix);
            g.normal = imageLoad(g_normal, pix);
            g.geometric = imageLoad(g_geometric, pix);
            g.base = imageLoad(g_base, pix);
            g.emissive = imageLoad(g_emissive, pix);
            gbuffer_decode(g, s);
            t = g.position.w;
            info.t = t;
            info.instance = int(g.ids.x);
            info.primitive = int(g.ids.y);
            info.normal = s.ng_front;
            info.position = s.position;
        }
    }

    vec3 c;
    if (known && !info.hit) {
        c = miss_radiance(camera.dir, true);
    } else {
        Hit at = miss_hit(BIG_FLOAT);
        at.t = t;
#ifdef SHADING_DISTRIBUTED
        c = distributed(camera, known ? PRIMARY_SURFACE : PRIMARY_TRACE, s, at, info, uvec2(pix), frame.sample_base);
#else
        c = whitted(camera, known ? PRIMARY_SURFACE : PRIMARY_TRACE, s, at, info);
#endif
    }
    uint display = store_color(q, c);
    STATE(q) = (st & ~PX_KIND_MASK) | PX_TRACED;

    CacheEntry e;
    e.color = c;
    e.display = display;
    if (info.hit) {
        uint material = known ? s.material : scene_geometry(scene_instance(uint(info.instance)).geometry).material;
        // A path that spawned reflection or refraction rays (Fresnel at grazing angles, glass,
        // alpha blending) looks different from elsewhere, whatever its material says.
        bool spawned = rays_by_kind[RAY_REFLECTION] + rays_by_kind[RAY_REFRACTION] > 0u;
        bool view_dependent = spawned || (known
            ? surface_view_dependent(s.metallic, s.roughness, s.transmission, s.alpha_mode, s.alpha)
            : material_view_dependent(material));
        e.position = info.position;
        e.normal = pack_normal(info.normal);
        e.meta = new_cache_meta(CACHE_VALID | (view_dependent ? CACHE_VIEW_DEPENDENT : 0u), 0u, material);
        // The G-buffer's barycentrics where the primary hit came from there.
        anchor_store(q, uint(info.instance), uint(info.primitive), known ? imageLoad(g_bary, pix).xy : info.bary);
    } else {
        e.position = camera.dir;
        e.normal = 0u;
        e.meta = CACHE_VALID | CACHE_MISS;
        anchor_clear(q);
    }
    CACHE_NEXT(q) = e;

    [[unroll]] for (uint k = 0u; k < 4u; ++k) {
        COUNTER_ADD(counters[stat_slot(k)], rays_by_kind[k]);
    }
    COUNTER_ADD(counters[stat_slot(C_SAMPLES)], 1u);
#ifdef SHADING_DISTRIBUTED
    COUNTER_ADD(counters[stat_slot(RAY_DIFFUSE)], diffuse_rays);
#endif
    COUNTER_ADD(counters[stat_slot(C_TRACED)], 1u);
}
