// glTF metallic-roughness BRDF pieces (as in the Khronos glTF Sample Viewer) and the
// reflection/refraction vectors of the seed. Mirrors src/render/reference/optics.rs (unit-tested there).
#ifndef RQR_BRDF_GLSL
#define RQR_BRDF_GLSL

const float PI = 3.14159265358979;

vec3 fresnel_schlick(vec3 f0, float cos_theta) {
    return f0 + (vec3(1.0) - f0) * pow(1.0 - clamp(cos_theta, 0.0, 1.0), 5.0);
}

float d_ggx(float n_dot_h, float alpha) {
    float a2 = alpha * alpha;
    float d = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
    return a2 / (PI * d * d);
}

// Height-correlated Smith visibility V = G / (4 n.l n.v).
float v_smith_ggx(float n_dot_l, float n_dot_v, float alpha) {
    float a2 = alpha * alpha;
    float gv = n_dot_l * sqrt(n_dot_v * n_dot_v * (1.0 - a2) + a2);
    float gl = n_dot_v * sqrt(n_dot_l * n_dot_l * (1.0 - a2) + a2);
    float s = gv + gl;
    return s > 0.0 ? 0.5 / s : 0.0;
}

// KHR_materials_sheen as in the Khronos glTF Sample Viewer: the "Charlie" distribution
// (Estevez & Kulla 2017) with its fitted visibility term.
float d_charlie(float sheen_roughness, float n_dot_h) {
    float alpha = max(sheen_roughness * sheen_roughness, 1e-6);
    float inv_r = 1.0 / alpha;
    float sin2h = max(1.0 - n_dot_h * n_dot_h, 0.0);
    return (2.0 + inv_r) * pow(sin2h, inv_r * 0.5) / (2.0 * PI);
}

float sheen_lambda_fit(float x, float alpha) {
    float k = (1.0 - alpha) * (1.0 - alpha);
    float a = mix(21.5473, 25.3245, k);
    float b = mix(3.82987, 3.32435, k);
    float c = mix(0.19823, 0.16801, k);
    float d = mix(-1.97760, -1.27393, k);
    float e = mix(-4.32054, -4.85967, k);
    return a / (1.0 + b * pow(x, c)) + d * x + e;
}

float sheen_lambda(float cos_theta, float alpha) {
    return abs(cos_theta) < 0.5
        ? exp(sheen_lambda_fit(cos_theta, alpha))
        : exp(2.0 * sheen_lambda_fit(0.5, alpha) - sheen_lambda_fit(1.0 - cos_theta, alpha));
}

float v_sheen(float n_dot_l, float n_dot_v, float sheen_roughness) {
    float alpha = max(sheen_roughness * sheen_roughness, 1e-6);
    return clamp(1.0 / ((1.0 + sheen_lambda(n_dot_v, alpha) + sheen_lambda(n_dot_l, alpha)) * (4.0 * n_dot_v * n_dot_l)), 0.0, 1.0);
}

// Mirror direction of incident `i` about unit normal `n`: r = i - 2 (n.i) n.
vec3 reflect_dir(vec3 i, vec3 n) { return i - 2.0 * dot(n, i) * n; }

// Snell refraction of unit incident `i` through unit normal `n` facing against `i`, with
// eta = n1 / n2. Returns false on total internal reflection (the square root's argument < 0).
bool refract_dir(vec3 i, vec3 n, float eta, out vec3 t) {
    float cos_i = -dot(n, i);
    float k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
    if (k < 0.0) {
        t = vec3(0.0);
        return false;
    }
    t = eta * i + (eta * cos_i - sqrt(k)) * n;
    return true;
}

#endif
