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
#ifndef RQR_SHADE_GLSL
#define RQR_SHADE_GLSL

#define RAY_PRIMARY 0u
#define RAY_SHADOW 1u
#define RAY_REFLECTION 2u
#define RAY_REFRACTION 3u

#define STACK_SIZE 20
#define BIG_FLOAT 3.0e38

// Rays traced by this invocation, by kind; flushed once with atomics at the end.
uint rays_by_kind[4] = uint[4](0u, 0u, 0u, 0u);

struct Surface {
    vec3 position;
    vec3 ng;          // geometric normal, facing the incoming ray
    vec3 n;           // shading normal (normal-mapped), same side as ng
    vec3 ng_front;    // geometric normal of the glTF front face (unflipped)
    bool front_face;
    vec3 base_color;
    float alpha;
    float metallic;
    float roughness;
    vec3 emissive;
    float occlusion;
    float transmission;
    float ior;
    vec3 atten_color;
    float atten_dist;
    uint alpha_mode;
    uint material;
};

float eps_offset() { return frame.epsilon; }

vec4 sample_slot(GpuTextureSlot slot, vec2 uv0, vec2 uv1, float lod_base) {
    ivec2 size = textureSize(textures[nonuniformEXT(slot.texture)], 0);
    float lod = lod_base + 0.5 * log2(float(size.x) * float(size.y));
    return textureLod(textures[nonuniformEXT(slot.texture)], texture_uv(slot, uv0, uv1), max(lod, 0.0));
}

// Shades the material of triangle (instance, prim) at barycentrics `bary`.
// `cone_width` is the ray cone's width at the hit (texture LOD, Akenine-Moller et al. 2019);
// pass a negative width to sample mip 0. `dir` is the unit ray direction.
Surface surface_at(uint instance, uint prim, vec2 bary, vec3 dir, float cone_width) {
    GpuInstance inst = scene_instance(instance);
    GpuGeometry g = scene_geometry(inst.geometry);
    GpuMaterial m = scene_material(g.material);
    uvec3 tri = scene_triangle(g, prim);
    vec3 w = vec3(1.0 - bary.x - bary.y, bary.x, bary.y);
    vec3 p0 = scene_position(tri.x), p1 = scene_position(tri.y), p2 = scene_position(tri.z);
    GpuVertex a = scene_vertex(tri.x), b = scene_vertex(tri.y), c = scene_vertex(tri.z);

    Surface s;
    s.material = g.material;
    mat3 n2w = mat3(inst.normal_to_world);
    s.position = (inst.object_to_world * vec4(w.x * p0 + w.y * p1 + w.z * p2, 1.0)).xyz;
    vec3 ng_obj = cross(p1 - p0, p2 - p0);
    s.ng_front = normalize(n2w * ng_obj);
    s.front_face = dot(s.ng_front, dir) < 0.0;
    s.ng = s.front_face ? s.ng_front : -s.ng_front;
    vec3 n = n2w * (w.x * a.normal + w.y * b.normal + w.z * c.normal);
    n = dot(n, n) > 0.0 ? normalize(n) : s.ng_front;
    vec2 uv0 = w.x * a.uv0 + w.y * b.uv0 + w.z * c.uv0;
    vec2 uv1 = w.x * a.uv1 + w.y * b.uv1 + w.z * c.uv1;
    vec4 vcolor = w.x * a.color + w.y * b.color + w.z * c.color;

    float lod_base = -100.0;
    if (cone_width > 0.0) {
        mat3 o2w = mat3(inst.object_to_world);
        float world_area = length(cross(o2w * (p1 - p0), o2w * (p2 - p0)));
        float uv_area = abs((b.uv0.x - a.uv0.x) * (c.uv0.y - a.uv0.y) - (c.uv0.x - a.uv0.x) * (b.uv0.y - a.uv0.y));
        float cos_theta = max(abs(dot(s.ng, dir)), 1e-3);
        if (world_area > 0.0 && uv_area > 0.0) {
            lod_base = 0.5 * log2(uv_area / world_area) + log2(cone_width / cos_theta);
        }
    }

    vec4 base = m.base_color * vcolor;
    if (m.base_color_texture.texture >= 0) {
        base *= sample_slot(m.base_color_texture, uv0, uv1, lod_base);
    }
    s.base_color = base.rgb;
    s.alpha = m.alpha_mode == ALPHA_OPAQUE ? 1.0 : base.a;
    s.alpha_mode = m.alpha_mode;
    s.metallic = m.metallic;
    s.roughness = m.roughness;
    if (m.metallic_roughness_texture.texture >= 0) {
        vec4 mr = sample_slot(m.metallic_roughness_texture, uv0, uv1, lod_base);
        s.roughness *= mr.g;
        s.metallic *= mr.b;
    }
    s.metallic = clamp(s.metallic, 0.0, 1.0);
    s.roughness = clamp(s.roughness, 0.0, 1.0);
    s.emissive = m.emissive;
    if (m.emissive_texture.texture >= 0) {
        s.emissive *= sample_slot(m.emissive_texture, uv0, uv1, lod_base).rgb;
    }
    s.occlusion = 1.0;
    if (m.occlusion_texture.texture >= 0) {
        s.occlusion = 1.0 + m.occlusion_strength * (sample_slot(m.occlusion_texture, uv0, uv1, lod_base).r - 1.0);
    }
    s.transmission = m.transmission;
    if (m.transmission_texture.texture >= 0) {
        s.transmission *= sample_slot(m.transmission_texture, uv0, uv1, lod_base).r;
    }
    s.ior = m.ior;
    s.atten_color = m.attenuation_color;
    s.atten_dist = m.thickness > 0.0 ? m.attenuation_distance : BIG_FLOAT;

    if (m.normal_texture.texture >= 0 && (g.flags & GEOMETRY_HAS_TANGENTS) != 0u) {
        vec4 t4 = w.x * a.tangent + w.y * b.tangent + w.z * c.tangent;
        vec3 t = mat3(inst.object_to_world) * t4.xyz;
        t = normalize(t - n * dot(n, t));
        vec3 bt = cross(n, t) * (t4.w < 0.0 ? -1.0 : 1.0);
        vec3 tn = sample_slot(m.normal_texture, uv0, uv1, lod_base).xyz * 2.0 - 1.0;
        tn.xy *= m.normal_scale;
        n = normalize(t * tn.x + bt * tn.y + n * tn.z);
    }
    s.n = s.front_face ? n : -n;
    return s;
}

// Radiance (per unit light radiance) arriving from light `l` at `p`: direction to the light,
// distance, and the attenuated radiance (inverse square, KHR range window, spot cone).
vec3 light_incidence(GpuLight l, vec3 p, out vec3 to_light, out float dist) {
    if (l.kind == LIGHT_DIRECTIONAL) {
        to_light = -l.direction;
        dist = BIG_FLOAT;
        return l.radiance;
    }
    vec3 d = l.position - p;
    float d2 = max(dot(d, d), 1e-12);
    dist = sqrt(d2);
    to_light = d / dist;
    float window = l.range < 1e30 ? pow(clamp(1.0 - pow(dist / l.range, 4.0), 0.0, 1.0), 2.0) : 1.0;
    vec3 e = l.radiance * window / d2;
    if (l.kind == LIGHT_SPOT) {
        float cd = dot(l.direction, -to_light);
        float t = clamp((cd - l.outer_cos) / max(l.inner_cos - l.outer_cos, 1e-4), 0.0, 1.0);
        e *= t * t;
    }
    return e;
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
        vec3 h = normalize(to_light + v);
        vec3 f = fresnel_schlick(f0, dot(v, h));
        vec3 brdf = (vec3(1.0) - f) * diffuse_color / PI;
        if ((frame.flags & FLAG_NO_SPECULAR) == 0u) {
            brdf += f * d_ggx(max(dot(s.n, h), 0.0), alpha) * v_smith_ggx(n_dot_l, n_dot_v, alpha);
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
    vec3 normal;
    vec3 position;
};

PathRay path_stack[STACK_SIZE];

float max3(vec3 v) { return max(v.x, max(v.y, v.z)); }

// Shades surface `s` hit by `r` and pushes the reflection/refraction continuations.
vec3 shade_and_spawn(Surface s, PathRay r, float t, inout int sp) {
    vec3 v = -r.dir;
    vec3 color = s.emissive + direct_light(s, v) + frame.ambient * s.base_color * (1.0 - s.metallic) * s.occlusion;
    float coverage = s.alpha_mode == ALPHA_BLEND ? clamp(s.alpha, 0.0, 1.0) : 1.0;
    float cone = r.cone_width + frame.pixel_spread * t;
    if (coverage < 1.0 && sp < STACK_SIZE) {
        PathRay through = PathRay(s.position - s.ng * eps_offset(), r.dir, r.weight * (1.0 - coverage), r.depth, RAY_REFRACTION, cone);
        if (max3(through.weight) >= frame.min_weight) {
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
            vec3 f = fresnel_schlick(f0, c);
            reflect_weight *= f;
            refract_weight = w * transmission * (vec3(1.0) - f) * s.base_color;
        } else {
            // Total internal reflection: all energy goes to the reflected ray.
            reflect_weight = w * (transmission + (1.0 - transmission) * gloss * fresnel_schlick(f0, cos_i));
        }
    } else {
        reflect_weight *= fresnel_schlick(f0, cos_i);
    }
    if (max3(reflect_weight) >= frame.min_weight && sp < STACK_SIZE) {
        vec3 d = normalize(reflect_dir(r.dir, s.n));
        // Keep reflected rays above the geometric surface (shading normals can tilt them under).
        if (dot(d, s.ng) <= 0.0) d = normalize(reflect_dir(r.dir, s.ng));
        path_stack[sp++] = PathRay(s.position + s.ng * eps_offset(), d, reflect_weight, r.depth + 1u, RAY_REFLECTION, cone);
    }
    if (max3(refract_weight) >= frame.min_weight && sp < STACK_SIZE) {
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

// Radiance along a camera ray. When `have_surface` is true the primary hit is `primary_surface`
// at distance `primary_t` (the hybrid path's G-buffer) and no primary ray is traced.
vec3 whitted(Ray camera, bool have_surface, Surface primary_surface, float primary_t, inout PrimaryInfo info) {
    int sp = 0;
    path_stack[sp++] = PathRay(camera.origin, camera.dir, vec3(1.0), 1u, RAY_PRIMARY, 0.0);
    vec3 color = vec3(0.0);
    bool first = true;
    while (sp > 0) {
        PathRay r = path_stack[--sp];
        Surface s;
        float t;
        if (first && have_surface) {
            s = primary_surface;
            t = primary_t;
            first = false;
        } else {
            rays_by_kind[r.kind] += 1u;
            Hit h = trace_closest(r.origin, r.dir, 0.0, BIG_FLOAT);
            if (first) {
                info.hit = hit_found(h);
                info.t = info.hit ? h.t : 0.0;
                info.instance = h.instance;
                info.primitive = h.primitive;
                info.bary = h.barycentrics;
            }
            if (!hit_found(h)) {
                color += r.weight * background_radiance(r.dir);
                first = false;
                continue;
            }
            float cone = r.cone_width + frame.pixel_spread * h.t;
            s = surface_at(uint(h.instance), uint(h.primitive), h.barycentrics, r.dir, cone);
            t = h.t;
            if (first) {
                info.normal = s.ng_front;
                info.position = s.position;
                first = false;
            }
        }
        r.weight *= volume_absorption(s, t);
        color += r.weight * shade_and_spawn(s, r, t, sp);
    }
    return color;
}

#endif
