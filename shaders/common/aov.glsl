// Per-pixel AOVs of the primary hit (the Aov struct: src/interface/passes.rs), written by the
// ray-traced and hybrid passes alike. Include after shade.glsl (PrimaryInfo).
#ifndef RQR_AOV_GLSL
#define RQR_AOV_GLSL
#include "interface_passes.glsl"

// The AOVs of `info` after `samples` camera samples. A miss has t 0, zero normals, position and
// albedo, and ids AOV_NO_ID. The albedo is the surface's base colour for every material (the
// diffuse colour of a dielectric, F0 of a metal, the tint of a transmissive surface), clamped to
// [0, 1] as an external denoiser's albedo guide expects.
Aov primary_aov(PrimaryInfo info, uint samples) {
    Aov a;
    a.normal_depth = vec4(info.hit ? info.shading_normal : vec3(0.0), info.hit ? info.t : 0.0);
    a.geometric_samples = vec4(info.hit ? info.normal : vec3(0.0), float(samples));
    a.position = vec4(info.hit ? info.position : vec3(0.0), 0.0);
    a.albedo = info.hit ? clamp(info.albedo, 0.0, 1.0) : vec4(0.0);
    a.bary = info.hit ? info.bary : vec2(0.0);
    a.instance = info.hit ? uint(info.instance) : AOV_NO_ID;
    a.primitive = info.hit ? uint(info.primitive) : AOV_NO_ID;
    return a;
}

#ifdef SHADING_DISTRIBUTED
// The primary hit at the pixel's centre, found by a ray of its own, for the AOVs of a denoised
// sequence. Its camera samples are jittered (so that accumulated frames anti-alias), and the
// denoiser tests each pixel's history against the pixel's surface: a jittered sample lands on
// another surface at every silhouette and on geometry finer than a pixel, which would reset the
// history there about every other frame. The centre's surface only changes when the view does.
PrimaryInfo pixel_centre_info(uvec2 pix) {
    Ray r = camera_ray(vec2(pix) + 0.5);
    Hit h = trace_closest(r.origin, r.dir, 0.0, BIG_FLOAT);
    rays_by_kind[RAY_PRIMARY] += 1u;
    PrimaryInfo info = primary_miss();
    if (hit_found(h)) {
        record_primary_hit(info, h);
        record_primary_surface(info, surface_at(uint(h.instance), uint(h.primitive), h.barycentrics, r.dir, frame.pixel_spread * h.t));
    }
    return info;
}
#endif
#endif
