// The glTF BSDF of the Whitted model, evaluated for any pair of directions and sampled, for the
// distributed model (distributed.glsl) in every path and backend. The lobes are the Whitted
// model's: Lambert diffuse, GGX/Smith specular reflection (height-correlated visibility), rough
// transmission (Walter et al. 2007) with the material's ior, KHR_materials_specular's Fresnel,
// the sheen lobe (Charlie, no albedo scaling) and a clearcoat GGX lobe with its own normal and
// roughness, over a base layer that receives what the coat lets through. Single scattering
// only, as Mitsuba's and pbrt's microfacet models: GGX at roughness 0.5 loses a few per cent.
// Sampling: cosine for diffuse and sheen, visible normals (Heitz 2018) for GGX reflection,
// transmission and the coat; one lobe drawn by its estimated weight, and the density of a
// direction is the mixture over every lobe (so any lobe's direction is weighted correctly), or
// over the non-cosine lobes where the cosine ones are not drawn (bsdf_sample's cosine_lobes).
// Include after shade.glsl (Surface, surface_fresnel, clearcoat_reflectance, brdf.glsl).
#ifndef RQR_BSDF_GLSL
#define RQR_BSDF_GLSL

#define LOBE_DIFFUSE 0u
#define LOBE_SPECULAR 1u
#define LOBE_TRANSMISSION 2u
#define LOBE_CLEARCOAT 3u

float luminance(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }

// Directions in the orthonormal basis around unit n of env_mapping.glsl (Duff et al. 2017).
vec3 to_world(vec3 local, vec3 n) {
    vec3 t, b;
    env_basis(n, t, b);
    return local.x * t + local.y * b + local.z * n;
}

vec3 to_local(vec3 w, vec3 n) {
    vec3 t, b;
    env_basis(n, t, b);
    return vec3(dot(w, t), dot(w, b), dot(w, n));
}

vec3 sample_cosine(vec2 u) {
    float r = sqrt(u.x);
    float phi = 2.0 * PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), sqrt(max(1.0 - u.x, 0.0)));
}

// Smith masking of one direction for isotropic GGX.
float smith_g1(float n_dot_w, float alpha) {
    float a2 = alpha * alpha;
    float c = abs(n_dot_w);
    return 2.0 * c / (c + sqrt(a2 + (1.0 - a2) * c * c));
}

// A microfacet normal drawn from GGX's distribution of normals visible from v (local frame,
// z = normal, v.z > 0), Heitz 2018.
vec3 sample_ggx_visible(vec3 v, float alpha, vec2 u) {
    vec3 vh = normalize(vec3(alpha * v.x, alpha * v.y, v.z));
    float len2 = vh.x * vh.x + vh.y * vh.y;
    vec3 t1 = len2 > 0.0 ? vec3(-vh.y, vh.x, 0.0) * inversesqrt(len2) : vec3(1.0, 0.0, 0.0);
    vec3 t2 = cross(vh, t1);
    float r = sqrt(u.x);
    float phi = 2.0 * PI * u.y;
    float p1 = r * cos(phi);
    float p2 = r * sin(phi);
    float s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * sqrt(max(1.0 - p1 * p1, 0.0)) + s * p2;
    vec3 nh = p1 * t1 + p2 * t2 + sqrt(max(1.0 - p1 * p1 - p2 * p2, 0.0)) * vh;
    return normalize(vec3(alpha * nh.x, alpha * nh.y, max(nh.z, 1e-6)));
}

// Density of reflecting v about a visible-normal sample into l: D_v(h) / (4 v.h)
// = G1(v) D(h) / (4 n.v).
float ggx_reflection_pdf(float n_dot_v, float n_dot_h, float alpha) {
    return smith_g1(n_dot_v, alpha) * d_ggx(n_dot_h, alpha) / (4.0 * n_dot_v);
}

// The cosine Schlick's Fresnel takes at microfacet cosine c seen from the side of relative
// index etap (the far side's index over v's side): the angle on the less dense side, 0 (F = 1)
// under total internal reflection.
float fresnel_cosine(float c, float etap) {
    if (etap >= 1.0) {
        return c;
    }
    float sin2_t = (1.0 - c * c) / (etap * etap);
    return sin2_t >= 1.0 ? 0.0 : sqrt(1.0 - sin2_t);
}

// What a surface's lobes need, computed once per vertex.
struct BsdfFrame {
    vec3 f0;
    vec3 diffuse_color;
    float transmission;  // transmission weight (transmission x (1 - metallic))
    float alpha;
    float coat;          // clearcoat reflectance at v (0 without a coat)
    float c_alpha;
    float etap;          // index beyond the surface over the index on v's side
    float n_dot_v;
    vec4 lobe_p;         // selection probabilities: diffuse (+ sheen), specular, transmission, coat
};

BsdfFrame bsdf_frame(Surface s, vec3 v) {
    BsdfFrame b;
    b.f0 = mix(vec3(pow((s.ior - 1.0) / (s.ior + 1.0), 2.0)), s.base_color, s.metallic);
    b.diffuse_color = s.base_color * (1.0 - s.metallic) * (1.0 - s.transmission);
    b.transmission = s.transmission * (1.0 - s.metallic);
    b.alpha = max(s.roughness * s.roughness, 1e-3);
    b.coat = s.layered && s.clearcoat > 0.0 ? clearcoat_reflectance(s, v) : 0.0;
    b.c_alpha = max(s.clearcoat_roughness * s.clearcoat_roughness, 1e-3);
    b.etap = b.transmission > 0.0 ? (s.front_face ? s.ior : 1.0 / s.ior) : 1.0;
    b.n_dot_v = max(dot(s.n, v), 1e-4);
    vec3 f = surface_fresnel(s, b.f0, fresnel_cosine(b.n_dot_v, b.etap));
    vec3 f_dielectric = dielectric_fresnel(s, fresnel_cosine(b.n_dot_v, b.etap));
    if ((frame.flags & FLAG_NO_SPECULAR) != 0u) {
        f = f_dielectric = vec3(0.0);
    }
    float base = 1.0 - b.coat;
    float sheen = s.layered ? max3(s.sheen_color) : 0.0;
    vec4 w = vec4(
        (luminance(b.diffuse_color * (vec3(1.0) - f_dielectric)) + sheen) * base,
        luminance(f) * base,
        b.transmission * luminance((vec3(1.0) - f_dielectric) * s.base_color) * base,
        b.coat);
    float total = w.x + w.y + w.z + w.w;
    b.lobe_p = total > 0.0 ? w / total : vec4(0.0);
    return b;
}

// The diffuse lobe's share of the last bsdf_eval (its Lambert term x |n.l|, under the coat):
// the denoiser filters diffuse and specular light apart (denoise_split.glsl).
vec3 bsdf_diffuse_part = vec3(0.0);

// The last bsdf_eval split by how bsdf_sample draws its lobes: the cosine-sampled ones
// (Lambert and sheen, under the coat; lobe_p.x) and the rest ("traced": GGX reflection,
// transmission, the coat), each with its own term of the mixture density. A vertex that traces
// no diffuse ray (distributed.glsl) estimates the first part by light sampling alone and draws
// its continuation from the second only.
vec3 bsdf_cosine_part = vec3(0.0);
float bsdf_cosine_pdf = 0.0;
vec3 bsdf_traced_part = vec3(0.0);
float bsdf_traced_pdf = 0.0;

// BSDF x |n.l| of surface `s` from v (towards the viewer) to l (towards the light), and the
// density `pdf` bsdf_sample draws l with (solid angle).
vec3 bsdf_eval(Surface s, BsdfFrame b, vec3 v, vec3 l, out float pdf) {
    pdf = 0.0;
    bsdf_diffuse_part = vec3(0.0);
    bsdf_cosine_part = vec3(0.0);
    bsdf_cosine_pdf = 0.0;
    bsdf_traced_part = vec3(0.0);
    bsdf_traced_pdf = 0.0;
    float n_dot_l = dot(s.n, l);
    float g_dot_l = dot(s.ng, l);
    bool no_specular = (frame.flags & FLAG_NO_SPECULAR) != 0u;
    if (n_dot_l > 0.0 && g_dot_l > 0.0) {
        vec3 h = normalize(v + l);
        float n_dot_h = max(dot(s.n, h), 0.0);
        float v_dot_h = max(dot(v, h), 0.0);
        vec3 f = no_specular ? vec3(0.0) : surface_fresnel(s, b.f0, fresnel_cosine(v_dot_h, b.etap));
        vec3 f_dielectric = no_specular ? vec3(0.0) : dielectric_fresnel(s, fresnel_cosine(v_dot_h, b.etap));
        vec3 lambert = (vec3(1.0) - f_dielectric) * b.diffuse_color / PI;
        bsdf_diffuse_part = lambert * n_dot_l * (1.0 - b.coat);
        vec3 specular = f * d_ggx(n_dot_h, b.alpha) * v_smith_ggx(n_dot_l, b.n_dot_v, b.alpha);
        vec3 base = lambert + specular;
        vec3 cosine = lambert;
        if (s.layered && max3(s.sheen_color) > 0.0) {
            vec3 sheen = s.sheen_color * d_charlie(s.sheen_roughness, n_dot_h) * v_sheen(n_dot_l, b.n_dot_v, s.sheen_roughness);
            base += sheen;
            cosine += sheen;
        }
        vec3 result = base * n_dot_l;
        float specular_pdf = b.lobe_p.y * ggx_reflection_pdf(b.n_dot_v, n_dot_h, b.alpha);
        bsdf_cosine_pdf = b.lobe_p.x * n_dot_l / PI;
        pdf = bsdf_cosine_pdf + specular_pdf;
        bsdf_cosine_part = cosine * n_dot_l * (1.0 - b.coat);
        bsdf_traced_part = specular * n_dot_l * (1.0 - b.coat);
        bsdf_traced_pdf = specular_pdf;
        if (b.coat > 0.0) {
            float c_dot_l = dot(s.clearcoat_n, l);
            float c_dot_v = max(dot(s.clearcoat_n, v), 1e-4);
            float c_dot_h = max(dot(s.clearcoat_n, h), 0.0);
            result *= 1.0 - b.coat;
            if (c_dot_l > 0.0) {
                float fc = s.clearcoat * fresnel_schlick(vec3(0.04), v_dot_h).x;
                vec3 coat = vec3(fc * d_ggx(c_dot_h, b.c_alpha) * v_smith_ggx(c_dot_l, c_dot_v, b.c_alpha) * c_dot_l);
                float coat_pdf = b.lobe_p.w * ggx_reflection_pdf(c_dot_v, c_dot_h, b.c_alpha);
                result += coat;
                pdf += coat_pdf;
                bsdf_traced_part += coat;
                bsdf_traced_pdf += coat_pdf;
            }
        }
        return result;
    }
    if (n_dot_l < 0.0 && g_dot_l < 0.0 && b.transmission > 0.0 && !no_specular) {
        // Generalised half vector of refraction, on v's side.
        vec3 h = normalize(v + b.etap * l);
        if (dot(h, s.n) < 0.0) h = -h;
        float v_dot_h = dot(v, h);
        float l_dot_h = dot(l, h);
        if (v_dot_h <= 0.0 || l_dot_h >= 0.0) {
            return vec3(0.0);
        }
        float n_dot_h = max(dot(s.n, h), 0.0);
        vec3 f = dielectric_fresnel(s, fresnel_cosine(v_dot_h, b.etap));
        float a = b.alpha;
        float denom = l_dot_h + v_dot_h / b.etap;
        float d = d_ggx(n_dot_h, a);
        float g2 = 1.0 / (1.0 + (1.0 / smith_g1(b.n_dot_v, a) - 1.0) + (1.0 / smith_g1(n_dot_l, a) - 1.0));
        // Radiance (not importance) transport: the 1/etap² of pbrt's rough dielectric.
        float bt = d * g2 * abs(l_dot_h * v_dot_h) / (denom * denom * b.n_dot_v * abs(n_dot_l)) / (b.etap * b.etap);
        vec3 result = b.transmission * (vec3(1.0) - f) * s.base_color * bt * abs(n_dot_l) * (1.0 - b.coat);
        float visible = smith_g1(b.n_dot_v, a) * d * v_dot_h / b.n_dot_v;
        pdf = b.lobe_p.z * visible * abs(l_dot_h) / (denom * denom);
        bsdf_traced_part = result;
        bsdf_traced_pdf = pdf;
        return result;
    }
    return vec3(0.0);
}

// Draws a direction l from the BSDF at (lobe choice u_lobe, direction u). Returns false when
// the drawn direction carries nothing (below the surface, total internal reflection); else
// `weight` = bsdf_eval / pdf and `lobe` the lobe drawn. Without `cosine_lobes` the cosine-
// sampled lobes are not drawn: their share of u_lobe (lobe_p.x) ends the path (returns false;
// Russian roulette on the lobe choice), and the other lobes' draws carry only their own part of
// the BSDF over their own part of the density (bsdf_traced_part / bsdf_traced_pdf, the density
// they are drawn with, returned as `pdf` for MIS), so the cosine lobes' light, which the caller
// then estimates by light sampling alone, is neither lost nor counted twice.
bool bsdf_sample(Surface s, BsdfFrame b, vec3 v, float u_lobe, vec2 u, bool cosine_lobes, out vec3 l, out vec3 weight, out float pdf, out uint lobe) {
    l = vec3(0.0);
    weight = vec3(0.0);
    pdf = 0.0;
    lobe = LOBE_DIFFUSE;
    vec4 p = b.lobe_p;
    if (p.x + p.y + p.z + p.w <= 0.0 || (!cosine_lobes && u_lobe < p.x)) {
        return false;
    }
    if (u_lobe < p.x) {
        lobe = LOBE_DIFFUSE;
        l = to_world(sample_cosine(u), s.n);
    } else if (u_lobe < p.x + p.y || u_lobe < p.x + p.y + p.z) {
        lobe = u_lobe < p.x + p.y ? LOBE_SPECULAR : LOBE_TRANSMISSION;
        vec3 h = to_world(sample_ggx_visible(to_local(v, s.n), b.alpha, u), s.n);
        if (lobe == LOBE_SPECULAR) {
            l = reflect_dir(-v, h);
        } else if (!refract_dir(-v, h, 1.0 / b.etap, l)) {
            return false;
        }
    } else {
        lobe = LOBE_CLEARCOAT;
        vec3 h = to_world(sample_ggx_visible(to_local(v, s.clearcoat_n), b.c_alpha, u), s.clearcoat_n);
        l = reflect_dir(-v, h);
    }
    l = normalize(l);
    vec3 f = bsdf_eval(s, b, v, l, pdf);
    if (!cosine_lobes) {
        f = bsdf_traced_part;
        pdf = bsdf_traced_pdf;
    }
    if (!(pdf > 0.0) || max3(f) <= 0.0) {
        return false;
    }
    weight = f / pdf;
    return true;
}

#endif
