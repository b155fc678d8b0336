// Whitted trace()/shade() shared by the pure ray-traced and hybrid passes. Include after
// scene.glsl, trace.glsl, frame.glsl and brdf.glsl.
//
// Model: direct light from every punctual light with a shadow ray (glTF metallic-roughness:
// Lambert + GGX/Smith), ambient, emissive; then a reflection ray weighted by Fresnel (Schlick)
// times (1 - roughness)^2 (Whitted is specular-only, so rough surfaces fade their mirror term)
// and, for transmissive materials, a refraction ray by Snell's law (total internal reflection
// sends all of it to reflection); Beer-Lambert absorption inside KHR_materials_volume media.
// A path stops at frame.max_depth segments or when its weight's largest channel falls below
// frame.min_weight. Alpha BLEND continues the ray straight through with weight (1 - alpha).
// Layered materials (KHR_materials_specular / clearcoat / sheen, Surface.layered) add the
// specular extension's Fresnel, a sheen lobe in direct and environment light, and a clearcoat
// lobe with its own mirror ray; other materials never enter that code.
#ifndef RQR_SHADE_GLSL
#define RQR_SHADE_GLSL
#include "surface.glsl"
#include "environment.glsl"

float eps_offset() { return frame.epsilon; }

float max3(vec3 v) { return max(v.x, max(v.y, v.z)); }

// RAY_* kinds (also the counter slots).
#include "interface_shared.glsl"

#define STACK_SIZE 20

// Rays traced by this invocation, by kind; flushed once with atomics at the end.
uint rays_by_kind[4] = uint[4](0u, 0u, 0u, 0u);

// F0 of the base layer's dielectric part: from the ior, tinted by KHR_materials_specular's
// colour on layered materials.
vec3 dielectric_f0(Surface s) {
    vec3 f0_ior = vec3(pow((s.ior - 1.0) / (s.ior + 1.0), 2.0));
    return s.layered ? min(f0_ior * s.specular_color, vec3(1.0)) : f0_ior;
}

// Fresnel of the base layer at cosine `c`. Plain materials: Schlick with `f0`. Layered ones
// (KHR_materials_specular): the dielectric part has F0 = min(F0(ior) * specularColor, 1) and
// F90 = 1, both scaled by specularFactor; metals keep Schlick with F0 = base colour.
vec3 surface_fresnel(Surface s, vec3 f0, float c) {
    if (!s.layered) {
        return fresnel_schlick(f0, c);
    }
    return mix(s.specular * fresnel_schlick(dielectric_f0(s), c), fresnel_schlick(s.base_color, c), s.metallic);
}

// Fresnel of the base layer's dielectric part alone: what the diffuse and transmission lobes
// under it lose. glTF's BRDF mixes a dielectric (diffuse or transmission under a Fresnel-weighted
// specular lobe) with a metal by `metallic`, so a half-metal's diffuse loses only the dielectric's
// reflection, not the metal's (which the mixed F0 of surface_fresnel would take from it twice).
vec3 dielectric_fresnel(Surface s, float c) {
    vec3 f = fresnel_schlick(dielectric_f0(s), c);
    return s.layered ? s.specular * f : f;
}

// Fraction of light the clearcoat reflects at its normal (F0 = 0.04, i.e. ior 1.5), times
// its strength: the base layer under it receives (1 - this).
float clearcoat_reflectance(Surface s, vec3 v) {
    return s.clearcoat * fresnel_schlick(vec3(0.04), max(dot(s.clearcoat_n, v), 0.0)).x;
}

// Direct radiance factor (BRDF x cosine) of a layered material for light from `l`: the base
// layer (with the specular extension's Fresnel), plus the sheen lobe (Charlie; the Sample
// Viewer's albedo scaling of the base is left out), under a clearcoat GGX lobe with its own
// roughness and normal.
vec3 layered_direct(Surface s, vec3 v, vec3 l) {
    vec3 h = normalize(l + v);
    float n_dot_l = max(dot(s.n, l), 0.0);
    float n_dot_v = max(dot(s.n, v), 1e-4);
    float n_dot_h = max(dot(s.n, h), 0.0);
    float v_dot_h = dot(v, h);
    float alpha = max(s.roughness * s.roughness, 1e-3);
    vec3 diffuse_color = s.base_color * (1.0 - s.metallic) * (1.0 - s.transmission);
    vec3 f = surface_fresnel(s, vec3(0.0), v_dot_h);
    vec3 base = ((vec3(1.0) - dielectric_fresnel(s, v_dot_h)) * diffuse_color / PI + f * d_ggx(n_dot_h, alpha) * v_smith_ggx(n_dot_l, n_dot_v, alpha)) * n_dot_l;
    if (max3(s.sheen_color) > 0.0) {
        base += s.sheen_color * d_charlie(s.sheen_roughness, n_dot_h) * v_sheen(n_dot_l, n_dot_v, s.sheen_roughness) * n_dot_l;
    }
    if (s.clearcoat <= 0.0) {
        return base;
    }
    float c_dot_l = max(dot(s.clearcoat_n, l), 0.0);
    float c_dot_v = max(dot(s.clearcoat_n, v), 1e-4);
    float c_alpha = max(s.clearcoat_roughness * s.clearcoat_roughness, 1e-3);
    float fc = s.clearcoat * fresnel_schlick(vec3(0.04), v_dot_h).x;
    float coat = fc * d_ggx(max(dot(s.clearcoat_n, h), 0.0), c_alpha) * v_smith_ggx(c_dot_l, c_dot_v, c_alpha) * c_dot_l;
    return base * (1.0 - clearcoat_reflectance(s, v)) + vec3(coat);
}

// Direct light with shadow rays: the seed's "for each light: if not inShadow: diffuse + specular".
vec3 direct_light(Surface s, vec3 v) {
    vec3 f0 = mix(vec3(pow((s.ior - 1.0) / (s.ior + 1.0), 2.0)), s.base_color, s.metallic);
    vec3 diffuse_color = s.base_color * (1.0 - s.metallic) * (1.0 - s.transmission);
    float alpha = max(s.roughness * s.roughness, 1e-3);
    float n_dot_v = max(dot(s.n, v), 1e-4);
    vec3 sum = vec3(0.0);
    for (uint i = 0u; i < scene.light_count; ++i) {
        GpuLight l = scene_light(i);
        vec3 to_light;
        float dist;
        vec3 e = light_incidence(l, s.position, to_light, dist);
        float n_dot_l = dot(s.n, to_light);
        if (n_dot_l <= 0.0 || dot(s.ng, to_light) <= 0.0 || max(e.r, max(e.g, e.b)) <= 0.0) {
            continue;
        }
        vec3 origin = s.position + s.ng * eps_offset();
        float tmax = dist < BIG_FLOAT ? dist - 2.0 * eps_offset() : BIG_FLOAT;
        rays_by_kind[RAY_SHADOW] += 1u;
        if (trace_any(origin, to_light, 0.0, tmax)) {
            continue;
        }
        if (s.layered && (frame.flags & FLAG_NO_SPECULAR) == 0u) {
            sum += layered_direct(s, v, to_light) * e;
            continue;
        }
        vec3 h = normalize(to_light + v);
        vec3 f = fresnel_schlick(f0, dot(v, h));
        vec3 brdf;
        if ((frame.flags & FLAG_NO_SPECULAR) != 0u) {
            brdf = diffuse_color / PI;  // pure Lambert (energy tests)
        } else {
            brdf = (vec3(1.0) - dielectric_fresnel(s, dot(v, h))) * diffuse_color / PI
                + f * d_ggx(max(dot(s.n, h), 0.0), alpha) * v_smith_ggx(n_dot_l, n_dot_v, alpha);
        }
        sum += brdf * e * n_dot_l;
    }
    return sum;
}

struct PathRay {
    vec3 origin;
    vec3 dir;
    vec3 weight;
    uint depth;       // segments so far including this one (primary = 1)
    uint kind;
    float cone_width; // ray-cone width at the origin
};

// What the primary hit of a path looked like (for AOVs).
struct PrimaryInfo {
    bool hit;
    float t;
    int instance;
    int primitive;
    vec2 bary;
    vec3 normal;          // geometric normal of the glTF front face
    vec3 position;
    vec3 shading_normal;  // Surface::n (normal-mapped, towards the viewer)
    vec4 albedo;          // Surface::base_color, alpha
};

// The primary ray's hit `h` (found or not) into `info`, for the AOVs.
void record_primary_hit(inout PrimaryInfo info, Hit h) {
    info.hit = hit_found(h);
    info.t = info.hit ? h.t : 0.0;
    info.instance = h.instance;
    info.primitive = h.primitive;
    info.bary = h.barycentrics;
}

// The surface the primary ray hit into `info`, for the AOVs.
void record_primary_surface(inout PrimaryInfo info, Surface s) {
    info.normal = s.ng_front;
    info.position = s.position;
    info.shading_normal = s.n;
    info.albedo = vec4(s.base_color, s.alpha);
}

// What a pixel whose primary ray found nothing reports.
PrimaryInfo primary_miss() {
    return PrimaryInfo(false, 0.0, -1, -1, vec2(0.0), vec3(0.0), vec3(0.0), vec3(0.0), vec4(0.0));
}

PathRay path_stack[STACK_SIZE];

// Whether a continuation of weight `w` is traced: above `--min-weight`, and never at weight 0
// (with `--min-weight 0` such rays cost traces and made NaN pixels under an environment).
bool worth_tracing(vec3 w) { return max3(w) > 0.0 && max3(w) >= frame.min_weight; }

// The environment's light on surface `s` seen from `v` in the Whitted model (split sum, no
// shadows). `traced` and `coat_traced` are the shares of the base layer's and the clearcoat's
// mirror lobes that their reflection rays carry (their gloss when the ray is traced, else 0):
// the prefiltered map gives the rest, so a mirror keeps its inter-reflections and the lookup
// takes over as roughness grows.
// `single` returns the base layer's single-scattering specular energy, which its traced
// mirror ray is weighted by so the two shares add up to the split sum's total.
vec3 environment_light(Surface s, vec3 v, float traced, float coat, float coat_traced, out vec3 single) {
    float n_dot_v = clamp(dot(s.n, v), 1e-4, 1.0);
    // glTF's mix of a dielectric and a metal: each layer's energy from one table lookup, the
    // diffuse under the dielectric's alone.
    vec2 ab = env_brdf(n_dot_v, s.roughness);
    // A layer whose share is 0 is left at 0: mix() then returns the other exactly, and a
    // plain dielectric or metal pays for one layer.
    vec3 ss_dielectric = vec3(0.0), ms_dielectric = vec3(0.0), ss_metal = vec3(0.0), ms_metal = vec3(0.0);
    bool specular = (frame.flags & FLAG_NO_SPECULAR) == 0u;
    if (specular && s.metallic < 1.0) {
        env_specular_energy(ab, dielectric_f0(s), s.layered ? s.specular : 1.0, n_dot_v, s.roughness, ss_dielectric, ms_dielectric);
    }
    if (specular && s.metallic > 0.0) {
        env_specular_energy(ab, s.base_color, 1.0, n_dot_v, s.roughness, ss_metal, ms_metal);
    }
    vec3 ss = mix(ss_dielectric, ss_metal, s.metallic);
    vec3 ms = mix(ms_dielectric, ms_metal, s.metallic);
    single = ss;
    vec3 diffuse_color = s.base_color * (1.0 - s.metallic) * (1.0 - s.transmission);
    vec3 diffuse_share = max(vec3(1.0) - ss_dielectric - ms_dielectric, vec3(0.0));
    // A lookup whose weight is exactly zero adds exactly zero (the maps are finite), so it is
    // skipped: the irradiance of a black or metal surface without multiple scattering, the
    // prefiltered specular of a traced mirror or of a surface without specular.
    vec3 light = vec3(0.0);
    if (max3(diffuse_color * diffuse_share) > 0.0 || max3(ms) > 0.0) {
        vec3 irradiance = env_irradiance(s.n);
        light = diffuse_color * diffuse_share * irradiance + ms * irradiance;
    }
    if (traced < 1.0 && max3(ss) > 0.0) {
        light += ss * (1.0 - traced) * env_specular(reflect_dir(-v, s.n), s.roughness);
    }
    if (s.layered && max3(s.sheen_color) > 0.0 && (frame.flags & FLAG_NO_SPECULAR) == 0u) {
        // The sheen lobe's split sum: its directional albedo times the Charlie-prefiltered map.
        // The map is looked up at n, not at the mirror direction as the Sample Viewer's
        // getIBLRadianceCharlie does: its texel at d averages the lobe at n = v = d, a band at
        // the horizon of d, and the horizon of n is where the sheen's light comes from at every
        // view (against the distributed model under interior.hdr: 0.25 mean relative difference
        // at n, 0.41 at the mirror direction). Added on top of the base layer without albedo
        // scaling, as in direct light (layered_direct) and the distributed BSDF (bsdf.glsl).
        light += s.sheen_color * env_sheen_albedo(n_dot_v, s.sheen_roughness)
            * env_sheen(s.n, s.sheen_roughness);
    }
    light *= s.occlusion;
    if (coat > 0.0) {
        vec3 coat_ss, coat_ms;
        float c_dot_v = clamp(dot(s.clearcoat_n, v), 1e-4, 1.0);
        env_specular_energy(env_brdf(c_dot_v, s.clearcoat_roughness), vec3(0.04), 1.0, c_dot_v, s.clearcoat_roughness, coat_ss, coat_ms);
        light = light * (1.0 - coat)
            + s.clearcoat * coat_ss.x * (1.0 - coat_traced) * s.occlusion
                * env_specular(reflect_dir(-v, s.clearcoat_n), s.clearcoat_roughness);
    }
    return light;
}

// Shades surface `s` hit by `r` and pushes the reflection/refraction continuations.
vec3 shade_and_spawn(Surface s, PathRay r, float t, inout int sp) {
    vec3 v = -r.dir;
    vec3 direct = direct_light(s, v);
    vec3 color = s.emissive + direct + frame.ambient * s.base_color * (1.0 - s.metallic) * s.occlusion;
    float coat = 0.0;
    if (s.layered) {
        // Emission and ambient light pass through the clearcoat (direct light has it already).
        coat = clearcoat_reflectance(s, v);
        color = (s.emissive + frame.ambient * s.base_color * (1.0 - s.metallic) * s.occlusion) * (1.0 - coat) + direct;
    }
    float coverage = s.alpha_mode == ALPHA_BLEND ? clamp(s.alpha, 0.0, 1.0) : 1.0;
    float cone = r.cone_width + frame.pixel_spread * t;
    vec3 env_single = vec3(0.0);
    if (env_enabled()) {
        // The environment replaces the ambient term; a lobe whose ray is not traced (last
        // segment) is lit by the prefiltered map alone.
        bool last = r.depth >= frame.max_depth;
        float traced = last ? 0.0 : (1.0 - s.roughness) * (1.0 - s.roughness);
        float coat_traced = last ? 0.0 : (1.0 - s.clearcoat_roughness) * (1.0 - s.clearcoat_roughness);
        color = s.emissive * (1.0 - coat) + direct + environment_light(s, v, traced, coat, coat_traced, env_single);
    }
    if (coverage < 1.0 && sp < STACK_SIZE) {
        PathRay through = PathRay(s.position - s.ng * eps_offset(), r.dir, r.weight * (1.0 - coverage), r.depth, RAY_REFRACTION, cone);
        if (worth_tracing(through.weight)) {
            path_stack[sp++] = through;
        }
    }
    if (r.depth >= frame.max_depth) {
        return color * coverage;
    }
    float cos_i = max(dot(s.n, v), 0.0);
    vec3 f0 = mix(vec3(pow((s.ior - 1.0) / (s.ior + 1.0), 2.0)), s.base_color, s.metallic);
    float gloss = (1.0 - s.roughness) * (1.0 - s.roughness);
    vec3 w = r.weight * coverage;
    vec3 reflect_weight = w * gloss;
    vec3 refract_weight = vec3(0.0);
    vec3 refracted = vec3(0.0);
    float transmission = s.transmission * (1.0 - s.metallic);
    if (transmission > 0.0) {
        float eta = s.front_face ? 1.0 / s.ior : s.ior;
        if (refract_dir(r.dir, s.n, eta, refracted)) {
            // Schlick uses the angle on the less dense side.
            float c = s.front_face ? cos_i : max(-dot(s.n, refracted), 0.0);
            reflect_weight *= surface_fresnel(s, f0, c);
            refract_weight = w * transmission * (vec3(1.0) - dielectric_fresnel(s, c)) * s.base_color;
        } else {
            // Total internal reflection: all energy goes to the reflected ray.
            reflect_weight = w * (transmission + (1.0 - transmission) * gloss * surface_fresnel(s, f0, cos_i));
        }
    } else if (env_enabled()) {
        reflect_weight *= env_single;
    } else {
        reflect_weight *= surface_fresnel(s, f0, cos_i);
    }
    if (coat > 0.0) {
        // The clearcoat's own mirror ray (its normal, its roughness' gloss); the base layer's
        // rays carry what the coat lets through.
        reflect_weight *= 1.0 - coat;
        refract_weight *= 1.0 - coat;
        float coat_gloss = (1.0 - s.clearcoat_roughness) * (1.0 - s.clearcoat_roughness);
        vec3 coat_weight = w * coat * coat_gloss;
        if (worth_tracing(coat_weight) && sp < STACK_SIZE) {
            vec3 d = normalize(reflect_dir(r.dir, s.clearcoat_n));
            if (dot(d, s.ng) <= 0.0) d = normalize(reflect_dir(r.dir, s.ng));
            path_stack[sp++] = PathRay(s.position + s.ng * eps_offset(), d, coat_weight, r.depth + 1u, RAY_REFLECTION, cone);
        }
    }
    if (worth_tracing(reflect_weight) && sp < STACK_SIZE) {
        vec3 d = normalize(reflect_dir(r.dir, s.n));
        // Keep reflected rays above the geometric surface (shading normals can tilt them under).
        if (dot(d, s.ng) <= 0.0) d = normalize(reflect_dir(r.dir, s.ng));
        path_stack[sp++] = PathRay(s.position + s.ng * eps_offset(), d, reflect_weight, r.depth + 1u, RAY_REFLECTION, cone);
    }
    if (worth_tracing(refract_weight) && sp < STACK_SIZE) {
        path_stack[sp++] = PathRay(s.position - s.ng * eps_offset(), normalize(refracted), refract_weight, r.depth + 1u, RAY_REFRACTION, cone);
    }
    return color * coverage;
}

// Beer-Lambert: a ray leaving a volume through its back face was absorbed along distance t.
vec3 volume_absorption(Surface s, float t) {
    if (s.front_face || s.transmission <= 0.0 || s.atten_dist >= 1e30) {
        return vec3(1.0);
    }
    return exp(log(max(s.atten_color, vec3(1e-6))) * (t / s.atten_dist));
}

// Where the first segment of a camera path comes from.
#define PRIMARY_TRACE 0u   // trace_closest() (pure ray-traced path)
#define PRIMARY_SURFACE 1u // a shaded surface at distance primary_hit.t (full G-buffer)
#define PRIMARY_HIT 2u     // primary_hit, shaded like a traced hit (visibility buffer)

// Radiance along a camera ray. Only the first segment depends on `primary`: the hybrid path
// hands in what its raster pass saw instead of tracing a primary ray.
vec3 whitted(Ray camera, uint primary, Surface primary_surface, Hit primary_hit, inout PrimaryInfo info) {
    int sp = 0;
    path_stack[sp++] = PathRay(camera.origin, camera.dir, vec3(1.0), 1u, RAY_PRIMARY, 0.0);
    vec3 color = vec3(0.0);
    bool first = true;
    while (sp > 0) {
        PathRay r = path_stack[--sp];
        Surface s;
        float t;
        if (first && primary == PRIMARY_SURFACE) {
            s = primary_surface;
            t = primary_hit.t;
            first = false;
        } else {
            Hit h;
            if (first && primary == PRIMARY_HIT) {
                h = primary_hit;
            } else {
                rays_by_kind[r.kind] += 1u;
                h = trace_closest(r.origin, r.dir, 0.0, BIG_FLOAT);
            }
            if (first) {
                record_primary_hit(info, h);
            }
            if (!hit_found(h)) {
                color += r.weight * miss_radiance(r.dir, r.kind == RAY_PRIMARY);
                first = false;
                continue;
            }
            float cone = r.cone_width + frame.pixel_spread * h.t;
            s = surface_at(uint(h.instance), uint(h.primitive), h.barycentrics, r.dir, cone);
            t = h.t;
            if (first) {
                record_primary_surface(info, s);
                first = false;
            }
        }
        r.weight *= volume_absorption(s, t);
        color += r.weight * shade_and_spawn(s, r, t, sp);
    }
    return color;
}

#endif
