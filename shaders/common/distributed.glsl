// Distributed ray tracing (Cook, Porter & Carpenter 1984) shared by the pure ray-traced and
// hybrid passes: the Whitted model's materials (bsdf.glsl) with every lobe sampled, so rough
// surfaces reflect and transmit glossily, and direct light at every vertex from lights with a
// size: point and spot lights are spheres of radius GpuLight::size sampled by solid angle
// (spherical caps), directional lights cones of angular radius GpuLight::size, and the
// environment importance-sampled; one shadow ray per light sample through trace_any(). The
// sphere and cone lights and the environment are also found by the BSDF's own rays, and the
// two strategies are combined by multiple importance sampling (power heuristic). A size of 0
// keeps the punctual light (found by light sampling only, as in the Whitted model).
//
// One continuation ray per vertex follows a lobe chosen by its weight, up to frame.max_depth
// segments. Diffuse inter-reflection is off as in Cook's model until frame.diffuse_bounces
// allows that many diffuse bounces, with Russian roulette: a path tracer. Where the diffuse
// bounces are spent, a diffuse ray could only collect light: in a scene without emissive
// triangles (FLAG_DIFFUSE_LIGHT_SAMPLED) light sampling carries the cosine lobes' light, an
// any-hit ray their sky (sky_seen), and the continuation is drawn from the other lobes only;
// otherwise the diffuse ray is traced and collects the emission, lights and environment it
// meets (docs/techniques/distributed.md, "Spent diffuse lobes").
// Random numbers: Owen-scrambled Sobol (0,2) pairs (sampling.glsl's sobol_owen), indexed by
// the sample number and decorrelated by a hash of (seed, pixel, dimension): "padded" 2-D
// Sobol as in Burley 2020.
// Include after scene.glsl, trace.glsl, frame.glsl, sampling.glsl, brdf.glsl and shade.glsl.
#ifndef RQR_DISTRIBUTED_GLSL
#define RQR_DISTRIBUTED_GLSL
#include "interface_distributed.glsl"
#include "bsdf.glsl"

// Diffuse rays traced by this invocation (RAY_DIFFUSE; the other kinds are in rays_by_kind).
uint diffuse_rays = 0u;

struct Rng {
    uint stream;  // hash of seed and pixel
    uint index;   // sample number
    uint dim;     // next pair
};

Rng rng_new(uvec2 pixel, uint sample_index) {
    Rng r;
    r.stream = hash_u32(hash_u32(frame.seed ^ 0x5bd1e995u) ^ (pixel.x * 73856093u) ^ (pixel.y * 19349663u));
    r.index = sample_index;
    r.dim = 0u;
    return r;
}

vec2 rng_next(inout Rng r) {
    uint scramble = hash_u32(r.stream ^ ((r.dim + 1u) * 0x9e3779b9u));
    r.dim += 1u;
    return sobol_owen(r.index, scramble);
}

float power_heuristic(float a, float b) {
    float a2 = a * a;
    float b2 = b * b;
    return a2 + b2 > 0.0 ? a2 / (a2 + b2) : 0.0;
}

// 1 - cos of the cap a sphere of radius r subtends at distance d > r, without cancellation.
float cap_one_minus_cos(float r, float d) {
    float sin2 = (r * r) / (d * d);
    return sin2 / (1.0 + sqrt(max(1.0 - sin2, 0.0)));
}

// The distance window and spot cone of light `l` towards point p (as light_incidence).
float light_falloff(GpuLight l, vec3 p) {
    vec3 d = l.position - p;
    float dist = length(d);
    float window = l.range < 1e30 ? pow(clamp(1.0 - pow(dist / l.range, 4.0), 0.0, 1.0), 2.0) : 1.0;
    if (l.kind == LIGHT_SPOT) {
        float cd = dot(l.direction, -d / max(dist, 1e-12));
        float t = clamp((cd - l.outer_cos) / max(l.inner_cos - l.outer_cos, 1e-4), 0.0, 1.0);
        window *= t * t;
    }
    return window;
}

// Radiance of light `l` (size > 0) seen from p: a sphere of radius size emitting
// intensity / (π size²), or a cone of half-angle size giving irradiance `radiance` at normal
// incidence.
vec3 light_radiance(GpuLight l, vec3 p) {
    if (l.kind == LIGHT_DIRECTIONAL) {
        float s = sin(l.size);
        return l.radiance / (PI * s * s);
    }
    return l.radiance * light_falloff(l, p) / (PI * l.size * l.size);
}

// Samples light `l` from p with u: the direction, the distance to the sampled point
// (BIG_FLOAT for directional lights), the solid-angle density (0 for a punctual light, whose
// return value is then its incident irradiance), and radiance / density.
vec3 light_sample(GpuLight l, vec3 p, vec2 u, out vec3 dir, out float dist, out float pdf) {
    pdf = 0.0;
    if (l.size <= 0.0) {
        return light_incidence(l, p, dir, dist);
    }
    vec3 axis;
    float one_minus_cos;
    float center_dist = BIG_FLOAT;
    if (l.kind == LIGHT_DIRECTIONAL) {
        axis = -l.direction;
        one_minus_cos = 1.0 - cos(l.size);
    } else {
        vec3 d = l.position - p;
        center_dist = length(d);
        if (center_dist <= l.size * 1.0001) {
            // Inside the sphere: it surrounds p; light it as a point.
            return light_incidence(l, p, dir, dist);
        }
        axis = d / center_dist;
        one_minus_cos = cap_one_minus_cos(l.size, center_dist);
    }
    float cos_t = 1.0 - u.x * one_minus_cos;
    float sin_t = sqrt(max(1.0 - cos_t * cos_t, 0.0));
    float phi = 2.0 * PI * u.y;
    dir = to_world(vec3(sin_t * cos(phi), sin_t * sin(phi), cos_t), axis);
    pdf = 1.0 / (2.0 * PI * one_minus_cos);
    if (l.kind == LIGHT_DIRECTIONAL) {
        dist = BIG_FLOAT;
    } else {
        float b = center_dist * cos_t;
        dist = b - sqrt(max(l.size * l.size - center_dist * center_dist * sin_t * sin_t, 0.0));
    }
    return light_radiance(l, p) / pdf;
}

// The solid-angle density light_sample draws direction `dir` from p with (0 outside the
// light, or for punctual lights).
float light_pdf(GpuLight l, vec3 p, vec3 dir) {
    if (l.size <= 0.0) {
        return 0.0;
    }
    if (l.kind == LIGHT_DIRECTIONAL) {
        float one_minus_cos = 1.0 - cos(l.size);
        return 1.0 - dot(dir, -l.direction) <= one_minus_cos ? 1.0 / (2.0 * PI * one_minus_cos) : 0.0;
    }
    vec3 d = l.position - p;
    float dist = length(d);
    if (dist <= l.size * 1.0001) {
        return 0.0;
    }
    float one_minus_cos = cap_one_minus_cos(l.size, dist);
    return 1.0 - dot(dir, d / dist) <= one_minus_cos ? 1.0 / (2.0 * PI * one_minus_cos) : 0.0;
}

// Distance along the ray (o, d) to sphere light `l`, or BIG_FLOAT.
float light_hit(GpuLight l, vec3 o, vec3 d) {
    if (l.size <= 0.0 || l.kind == LIGHT_DIRECTIONAL) {
        return BIG_FLOAT;
    }
    vec3 oc = o - l.position;
    float b = dot(oc, d);
    float c = dot(oc, oc) - l.size * l.size;
    float disc = b * b - c;
    if (c <= 0.0 || disc < 0.0) {
        return BIG_FLOAT;
    }
    float t = -b - sqrt(disc);
    return t > 0.0 ? t : BIG_FLOAT;
}

// Light the segment (o, d) up to distance t_max meets: sphere lights in front of t_max, and
// when the segment escapes (t_max = BIG_FLOAT) the cones of directional lights. `bsdf_pdf` is
// the density the segment was drawn with; 0 for camera rays (no MIS: nothing else finds it).
vec3 lights_met(vec3 o, vec3 d, float t_max, float bsdf_pdf) {
    vec3 sum = vec3(0.0);
    for (uint i = 0u; i < scene.light_count; ++i) {
        GpuLight l = scene_light(i);
        if (l.size <= 0.0) {
            continue;
        }
        bool met = l.kind == LIGHT_DIRECTIONAL
            ? t_max >= BIG_FLOAT && light_pdf(l, o, d) > 0.0
            : light_hit(l, o, d) < t_max;
        if (met) {
            float w = bsdf_pdf > 0.0 ? power_heuristic(bsdf_pdf, light_pdf(l, o, d)) : 1.0;
            sum += w * light_radiance(l, o);
        }
    }
    return sum;
}

// The weighted BSDF x |n.l| of the last bsdf_eval (whose value was f, its density bsdf_pdf)
// for a light sample drawn with density light_pdf: against BSDF sampling by the power
// heuristic, or weight 1 where the BSDF's own ray is not traced (the `last` vertex; a punctual
// light, light_pdf = 0). With `cosine_by_light` (no diffuse ray leaves the vertex) the two
// parts of f are weighed apart, each against the density its own ray is drawn with: the other
// lobes' part against their continuation's (bsdf_traced_pdf), the cosine lobes' part against
// their any-hit ray's (bsdf_cosine_pdf) for the environment (`sky`), which that ray finds, and
// with weight 1 for the lights, which it does not look for. `diffuse_w`: the diffuse lobe's
// weight.
vec3 light_sample_weighted(vec3 f, float bsdf_pdf, float light_pdf, bool last, bool cosine_by_light, bool sky, out float diffuse_w) {
    diffuse_w = 1.0;
    if (!(light_pdf > 0.0) || last) {
        return f;
    }
    if (cosine_by_light) {
        diffuse_w = sky ? power_heuristic(light_pdf, bsdf_cosine_pdf) : 1.0;
        return bsdf_cosine_part * diffuse_w + bsdf_traced_part * power_heuristic(light_pdf, bsdf_traced_pdf);
    }
    diffuse_w = power_heuristic(light_pdf, bsdf_pdf);
    return f * diffuse_w;
}

// Direct light at surface s from every light (one sample each) and the environment (one
// sample), each through one shadow ray, weighted against BSDF sampling; at the `last` vertex
// of a path, whose BSDF ray is not traced, light sampling alone carries the light (weight 1).
// With `cosine_by_light` (no diffuse ray leaves this vertex) the cosine lobes take light
// sampling's estimate of the lights alone, and share the environment with sky_seen.
// `diffuse_part`: the share of the sum that came through the diffuse lobe (the denoiser's split).
vec3 direct_light_sampled(Surface s, BsdfFrame b, vec3 v, bool last, bool cosine_by_light, inout Rng rng, out vec3 diffuse_part) {
    vec3 sum = vec3(0.0);
    diffuse_part = vec3(0.0);
    vec3 origin = s.position + s.ng * eps_offset();
    float diffuse_w;
    for (uint i = 0u; i < scene.light_count; ++i) {
        GpuLight l = scene_light(i);
        vec2 u = rng_next(rng);
        vec3 dir;
        float dist, pdf;
        vec3 li = light_sample(l, s.position, u, dir, dist, pdf);
        if (max3(li) <= 0.0 || dot(s.ng, dir) <= 0.0) {
            continue;
        }
        float bsdf_pdf;
        vec3 f = bsdf_eval(s, b, v, dir, bsdf_pdf);
        if (max3(f) <= 0.0) {
            continue;
        }
        float tmax = dist < BIG_FLOAT ? dist - 2.0 * eps_offset() : BIG_FLOAT;
        rays_by_kind[RAY_SHADOW] += 1u;
        if (trace_any(origin, dir, 0.0, tmax)) {
            continue;
        }
        sum += light_sample_weighted(f, bsdf_pdf, pdf, last, cosine_by_light, false, diffuse_w) * li;
        diffuse_part += bsdf_diffuse_part * li * diffuse_w;
    }
    if (env_enabled()) {
        vec2 u = rng_next(rng);
        float pdf;
        vec3 dir = env_sample(u, pdf);
        if (pdf > 0.0 && dot(s.ng, dir) > 0.0) {
            float bsdf_pdf;
            vec3 f = bsdf_eval(s, b, v, dir, bsdf_pdf);
            if (max3(f) > 0.0) {
                rays_by_kind[RAY_SHADOW] += 1u;
                if (!trace_any(origin, dir, 0.0, BIG_FLOAT)) {
                    vec3 li = env_radiance_texel(dir) / pdf;
                    sum += light_sample_weighted(f, bsdf_pdf, pdf, last, cosine_by_light, true, diffuse_w) * li;
                    diffuse_part += bsdf_diffuse_part * li * diffuse_w;
                }
            }
        }
    }
    return sum;
}

// The sky (the environment, or without one the background) through the cosine lobes of
// surface s from v, when their ray would only collect light and bsdf_sample's lobe choice fell
// on them (probability lobe_p.x): along a cosine-drawn direction, drawn with density
// lobe_p.x n.l / π, its radiance x their BSDF x |n.l| / density if a shadow ray there escapes,
// weighted against the environment's light sampling (the background is not light-sampled).
// This any-hit ray stands in for the closest-hit diffuse ray that met the sky before; the
// lights that ray met are light-sampled alone. Returns whether the ray is worth tracing, with
// its origin, direction, `seen` (what it adds if it escapes) and `diffuse_part` (the Lambert
// share of that); the ray itself is traced by path_advance (PATH_SKY).
bool sky_ray(Surface s, BsdfFrame b, vec3 v, vec2 u, out vec3 origin, out vec3 dir, out vec3 seen, out vec3 diffuse_part) {
    seen = vec3(0.0);
    diffuse_part = vec3(0.0);
    origin = s.position + s.ng * eps_offset();
    dir = to_world(sample_cosine(u), s.n);
    float pdf = b.lobe_p.x * dot(s.n, dir) / PI;
    if (!(pdf > 0.0) || dot(s.ng, dir) <= 0.0) {
        return false;
    }
    float bsdf_pdf;
    bsdf_eval(s, b, v, dir, bsdf_pdf);
    if (max3(bsdf_cosine_part) <= 0.0) {
        return false;
    }
    vec3 li = env_enabled()
        ? env_radiance_texel(dir) * power_heuristic(bsdf_cosine_pdf, env_pdf(dir)) / bsdf_cosine_pdf
        : background_radiance(dir) / bsdf_cosine_pdf;
    diffuse_part = bsdf_diffuse_part * li;
    seen = bsdf_cosine_part * li;
    return true;
}

// Russian roulette on the background's ray (no environment): traced with probability
// q = SKY_SHARE x (the most it can add) / (the vertex's light so far), at least SKY_MIN_Q.
#define SKY_SHARE 4.0
#define SKY_MIN_Q 0.0625
// Russian roulette on the non-cosine lobes' continuation where the cosine lobes are light-
// sampled: survival CONTINUE_SHARE x (1 - lobe_p.x), at most 1.
#define CONTINUE_SHARE 1.0

// Alpha-blended surfaces a path may pass straight through before it stops.
#define MAX_PASS_THROUGH 16u

// The split of the last distributed() sample's radiance for the denoiser (DenoiseGuide): the
// part the first shaded vertex's diffuse lobe carried, the part it must not blur (what the
// camera ray met before that vertex, and its emission; the rest is specular), and that
// vertex's diffuse and specular albedos, which the denoiser divides the light by.
vec3 split_diffuse;
vec3 split_unfiltered;
vec3 split_diffuse_albedo;
vec3 split_specular_albedo;
float split_roughness;

// Directional albedo of the GGX lobe with Fresnel at normal incidence f0, roughness r
// (Karis 2014's fit of the split-sum table): a smooth stand-in the denoiser divides by.
vec3 specular_albedo_fit(vec3 f0, float roughness, float n_dot_v) {
    vec4 r = roughness * vec4(-1.0, -0.0275, -0.572, 0.022) + vec4(1.0, 0.0425, 1.04, -0.04);
    float a004 = min(r.x * r.x, exp2(-9.28 * n_dot_v)) * r.x + r.y;
    vec2 ab = vec2(-1.04, 1.04) * a004 + r.zw;
    return f0 * ab.x + ab.y;
}

// What becomes of a path after a vertex.
#define PATH_DONE 0u  // it ended
#define PATH_NEXT 1u  // its next segment (origin, dir) is to be traced
#define PATH_SKY 2u   // a sky ray (sky_ray) is to be traced, adding `throughput` if it escapes

// A path between two shaded vertices: everything the next one needs, so that an invocation
// can take its paths one vertex at a time (path regeneration, distributed/*.comp).
struct PathState {
    vec3 radiance;     // gathered so far
    float bsdf_pdf;    // the density the next segment was drawn with; 0 for camera rays
    vec3 throughput;   // PATH_SKY: what the sky ray adds
    float cone_width;
    vec3 origin;
    uint status;       // PATH_*
    vec3 dir;
    uint kind;         // RAY_* of the next segment
    vec3 sky_diffuse;  // PATH_SKY from the first shaded vertex: the denoiser's share of `throughput`
    uint depth;        // segments so far, the next one included
    uint diffuse_used;
    uint passes;       // alpha-blended surfaces passed through
    uint collect_only; // the next segment only collects light (a spent diffuse lobe)
    Rng rng;
};

// The current path's camera segment (path_advance's first vertex) and its split state (an
// invocation carries one path at a time).
uint camera_primary;
Surface camera_surface;
Hit camera_hit;
bool split_vertex;     // the next shaded vertex is the first
bool split_done;       // the first shaded vertex was reached
vec3 diffuse_branch;   // radiance when the first vertex chose its diffuse lobe
uvec2 camera_pixel;    // the pixel the path's camera ray goes through

// Carries path p on to its next shaded vertex: what its segment meets (passing through
// alpha-blended surfaces), the light gathered there, and the continuation it chooses, or the
// end (PATH_DONE). The camera segment (kind RAY_PRIMARY) records the primary hit in `info`,
// and is traced or handed in by the hybrid path (camera_primary).
void path_advance(inout PathState p, inout PrimaryInfo info) {
    bool first = p.kind == RAY_PRIMARY;
    if (p.status == PATH_SKY) {
        rays_by_kind[RAY_SHADOW] += 1u;
        if (trace_any(p.origin, p.dir, 0.0, BIG_FLOAT)) {
            p.sky_diffuse = vec3(0.0);
        } else {
            p.radiance += p.throughput;
        }
        p.status = PATH_DONE;
        return;
    }
    p.status = PATH_DONE;
    while (p.depth <= frame.max_depth) {
        Surface s;
        float t;
        bool found;
        if (first && camera_primary == PRIMARY_SURFACE) {
            s = camera_surface;
            t = camera_hit.t;
            found = true;
        } else {
            Hit h;
            if (first && camera_primary == PRIMARY_HIT) {
                h = camera_hit;
            } else {
                if (p.kind == RAY_DIFFUSE) {
                    diffuse_rays += 1u;
                } else {
                    rays_by_kind[p.kind] += 1u;
                }
                h = trace_closest(p.origin, p.dir, 0.0, BIG_FLOAT);
            }
            found = hit_found(h);
            t = found ? h.t : BIG_FLOAT;
            if (first) {
                record_primary_hit(info, h);
            }
            if (found) {
                s = surface_at(uint(h.instance), uint(h.primitive), h.barycentrics, p.dir, p.cone_width + frame.pixel_spread * h.t);
                if (first) {
                    record_primary_surface(info, s);
                }
            }
        }
        first = false;
        p.radiance += p.throughput * lights_met(p.origin, p.dir, t, p.bsdf_pdf);
        if (!found) {
            if (p.kind == RAY_PRIMARY) {
                p.radiance += camera_miss_radiance(camera_pixel, p.dir);
            } else if (env_enabled()) {
                p.radiance += p.throughput * env_radiance_texel(p.dir) * power_heuristic(p.bsdf_pdf, env_pdf(p.dir));
            } else {
                p.radiance += p.throughput * background_radiance(p.dir);
            }
            return;
        }
        p.cone_width += frame.pixel_spread * t;
        p.throughput *= volume_absorption(s, t);
        vec3 v = -p.dir;
        if (s.alpha_mode == ALPHA_BLEND && p.passes < MAX_PASS_THROUGH) {
            // Blending by coverage, stochastically: pass straight through with 1 - alpha.
            if (rng_next(p.rng).x >= clamp(s.alpha, 0.0, 1.0)) {
                p.passes += 1u;
                p.origin = s.position - s.ng * eps_offset();
                p.kind = RAY_REFRACTION;
                continue;
            }
        }
        BsdfFrame b = bsdf_frame(s, v);
        p.radiance += p.throughput * s.emissive * (1.0 - b.coat);
        bool splitting = split_vertex && p.collect_only == 0u;
        if (splitting) {
            split_vertex = false;
            split_done = true;
            split_unfiltered = p.radiance;
            split_diffuse_albedo = b.diffuse_color;
            split_roughness = s.roughness;
            split_specular_albedo = min(specular_albedo_fit(b.f0, s.roughness, b.n_dot_v) * (1.0 - b.coat)
                + b.transmission * s.base_color * (1.0 - b.coat) + vec3(b.coat), vec3(1.0));
        }
        if (p.collect_only != 0u) {
            return;
        }
        vec3 lit_here = vec3(0.0);  // this vertex's light so far, before the throughput
        if (!env_enabled() && frame.diffuse_bounces == 0u) {
            // The Whitted model's ambient term stands in for the untraced diffuse
            // inter-reflection (a path tracer, with diffuse bounces, traces it instead).
            lit_here = frame.ambient * s.base_color * (1.0 - s.metallic) * s.occlusion * (1.0 - b.coat);
            vec3 ambient = p.throughput * lit_here;
            p.radiance += ambient;
            if (splitting) {
                split_diffuse += ambient;
            }
        }
        bool last = p.depth >= frame.max_depth;
        // A diffuse ray from here could only collect light, and light sampling finds all of it.
        bool cosine_by_light = (frame.flags & FLAG_DIFFUSE_LIGHT_SAMPLED) != 0u && p.diffuse_used >= frame.diffuse_bounces;
        vec3 direct_diffuse;
        vec3 direct = direct_light_sampled(s, b, v, last, cosine_by_light, p.rng, direct_diffuse);
        lit_here += direct;
        p.radiance += p.throughput * direct;
        if (splitting) {
            split_diffuse += p.throughput * direct_diffuse;
        }
        if (last) {
            return;
        }
        vec2 u_choice = rng_next(p.rng);
        vec2 u_dir = rng_next(p.rng);
        if (cosine_by_light && u_choice.x < b.lobe_p.x) {
            // The cosine lobes' turn: light sampling found the lights for them; only the
            // sky is left for their ray, and then the path ends. The environment is a light
            // like the others; the background, often a dim fill, takes Russian roulette by the
            // most it can add to this vertex's light: that share at most, 1 / SKY_SHARE, rides
            // on a traced ray's 1 / q (none where the vertex is dark).
            float q = 1.0;
            if (!env_enabled()) {
                float cosine_albedo = max(max3(b.diffuse_color), s.layered ? max3(s.sheen_color) : 0.0);
                float most = max3(frame.background) * cosine_albedo;
                q = most > 0.0 ? clamp(SKY_SHARE * most / max(luminance(lit_here), 1e-8), SKY_MIN_Q, 1.0) : 0.0;
            }
            vec3 seen, seen_diffuse;
            if (u_choice.y < q && sky_ray(s, b, v, u_dir, p.origin, p.dir, seen, seen_diffuse)) {
                vec3 carried = p.throughput;
                p.status = PATH_SKY;
                p.throughput = carried * seen / q;
                p.sky_diffuse = splitting ? carried * seen_diffuse / q : vec3(0.0);
            }
            return;
        }
        vec3 l, weight;
        uint lobe;
        if (!bsdf_sample(s, b, v, u_choice.x, u_dir, !cosine_by_light, l, weight, p.bsdf_pdf, lobe)) {
            return;
        }
        if (cosine_by_light && b.lobe_p.x > 0.0) {
            // Russian roulette on the other lobes' continuation from a surface that is mostly
            // diffuse: their share of its light is about their share of the lobe choice,
            // 1 - lobe_p.x, so a path survives with CONTINUE_SHARE times that (a rough
            // dielectric wall's faint glossy inter-reflection then costs a ray in a few per
            // cent of its pixels, not in every one that drew the lobe). Mirrors, metals and
            // glass (lobe_p.x = 0) always continue.
            float q = min(1.0, CONTINUE_SHARE * (1.0 - b.lobe_p.x));
            if (rng_next(p.rng).x >= q) {
                return;
            }
            weight /= q;
        }
        p.throughput *= weight;
        if (splitting && lobe == LOBE_DIFFUSE) {
            diffuse_branch = p.radiance;
        }
        if (lobe == LOBE_DIFFUSE) {
            p.kind = RAY_DIFFUSE;
            if (p.diffuse_used >= frame.diffuse_bounces) {
                p.collect_only = 1u;
            }
            p.diffuse_used += 1u;
        } else {
            p.kind = lobe == LOBE_TRANSMISSION ? RAY_REFRACTION : RAY_REFLECTION;
        }
        if (frame.diffuse_bounces > 0u && p.depth >= 3u) {
            float q = min(max3(p.throughput), 0.95);
            if (u_choice.y >= q) {
                return;
            }
            p.throughput /= q;
        }
        p.origin = s.position + (dot(l, s.ng) > 0.0 ? s.ng : -s.ng) * eps_offset();
        p.dir = l;
        p.depth += 1u;
        p.status = PATH_NEXT;
        return;
    }
}

// Starts the path of camera sample `sample_index` of `pixel`; `primary` as whitted(): the
// hybrid path hands in what its raster pass saw.
PathState path_start(Ray camera, uint primary, Surface primary_surface, Hit primary_hit, uvec2 pixel, uint sample_index) {
    split_diffuse = vec3(0.0);
    split_diffuse_albedo = vec3(0.0);
    split_specular_albedo = vec3(0.0);
    split_roughness = 0.0;
    split_vertex = true;
    split_done = false;
    diffuse_branch = vec3(-1.0);
    camera_primary = primary;
    camera_surface = primary_surface;
    camera_hit = primary_hit;
    camera_pixel = pixel;
    PathState p;
    p.radiance = vec3(0.0);
    p.bsdf_pdf = 0.0;
    p.throughput = vec3(1.0);
    p.cone_width = 0.0;
    p.origin = camera.origin;
    p.status = PATH_NEXT;
    p.dir = camera.dir;
    p.kind = RAY_PRIMARY;
    p.sky_diffuse = vec3(0.0);
    p.depth = 1u;
    p.diffuse_used = 0u;
    p.passes = 0u;
    p.collect_only = 0u;
    p.rng = rng_new(pixel, sample_index);
    return p;
}

// The radiance of a finished path, and the last of its split for the denoiser.
vec3 path_finish(PathState p) {
    split_diffuse += p.sky_diffuse;
    if (!split_done) {
        split_unfiltered = p.radiance;
    } else if (diffuse_branch.x >= 0.0) {
        split_diffuse += p.radiance - diffuse_branch;
    }
    return p.radiance;
}

// Radiance along a camera ray in the distributed model, for camera sample `sample_index` of
// `pixel`, the whole path at once. `primary` as whitted(): the hybrid path hands in what its
// raster pass saw.
vec3 distributed(Ray camera, uint primary, Surface primary_surface, Hit primary_hit, inout PrimaryInfo info, uvec2 pixel, uint sample_index) {
    PathState p = path_start(camera, primary, primary_surface, primary_hit, pixel, sample_index);
    while (p.status != PATH_DONE) {
        path_advance(p, info);
    }
    return path_finish(p);
}

#endif
