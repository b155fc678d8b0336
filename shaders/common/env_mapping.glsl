// The equirectangular convention of environment maps (world +Y up), shared by the shading
// code (environment.glsl) and the preparation passes (shaders/environment/). Mirrors
// src/environment/mod.rs (direction_to_uv, uv_to_direction):
//   u = atan2(d.x, -d.z) / 2π wrapped to [0, 1), v = acos(d.y) / π (row 0 = zenith),
// the Khronos glTF Sample Viewer's default orientation: a camera looking down -Z faces the
// map's left/right edge (u = 0), +Z meets its centre.
#ifndef RQR_ENV_MAPPING_GLSL
#define RQR_ENV_MAPPING_GLSL

const float ENV_PI = 3.14159265358979;

// atan(y, x) in [-π, π] to within 1.2e-5 rad, by a minimax polynomial on [0, 1] and the
// octant's symmetries; drivers' atan(y, x) (range reduction, infinity and signed-zero rules)
// costs more on CPU devices.
float env_atan2(float y, float x) {
    float ax = abs(x), ay = abs(y);
    float a = min(ax, ay) / max(max(ax, ay), 1e-30);
    float s = a * a;
    float r = a * ((((0.0208351 * s - 0.085133) * s + 0.180141) * s - 0.3302995) * s + 0.999866);
    r = ay > ax ? 1.57079637 - r : r;
    r = x < 0.0 ? 3.14159274 - r : r;
    return y < 0.0 ? -r : r;
}

// acos(c) to within 6.8e-5 rad (Abramowitz and Stegun 4.4.45), for the same reason.
float env_acos(float c) {
    float x = min(abs(c), 1.0);
    float r = sqrt(1.0 - x) * (((-0.0187293 * x + 0.0742610) * x - 0.2121144) * x + 1.5707288);
    return c < 0.0 ? 3.14159265 - r : r;
}

// The map's coordinates of direction d: u = atan2(d.x, -d.z) / 2π wrapped to [0, 1),
// v = acos(d.y) / π (row 0 is the zenith), through the polynomials above: within 2e-6 of the
// exact mapping in u and 2.2e-5 in v (tested), closer than lavapipe's own atan and acos, and
// cheaper on every shading point's lookups.
vec2 env_uv(vec3 d) {
    float u = env_atan2(d.x, -d.z) * (0.5 / ENV_PI);
    return vec2(u < 0.0 ? u + 1.0 : u, env_acos(d.y) * (1.0 / ENV_PI));
}

vec3 env_direction(vec2 uv) {
    float phi = 2.0 * ENV_PI * uv.x;
    float theta = ENV_PI * uv.y;
    float s = sin(theta);
    return vec3(s * sin(phi), cos(theta), -s * cos(phi));
}

// Solid angle of one texel of a width x (width/2) map at polar angle theta.
float env_texel_solid_angle(float width, float sin_theta) {
    return (2.0 * ENV_PI / width) * (2.0 * ENV_PI / width) * max(sin_theta, 1e-4);
}

// An orthonormal basis around n (Duff et al. 2017).
void env_basis(vec3 n, out vec3 t, out vec3 b) {
    float sign_z = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sign_z + n.z);
    float c = n.x * n.y * a;
    t = vec3(1.0 + sign_z * n.x * n.x * a, sign_z * c, -sign_z * n.x);
    b = vec3(c, sign_z + n.y * n.y * a, -n.y);
}

// Point i of an n-point Hammersley set.
vec2 env_hammersley(uint i, uint n) {
    return vec2((float(i) + 0.5) / float(n), float(bitfieldReverse(i)) * 2.3283064365386963e-10);
}

// A GGX half vector around +Z (tangent space) with density D(h) (n·h).
vec3 env_ggx_half(vec2 xi, float alpha) {
    float phi = 2.0 * ENV_PI * xi.x;
    float cos_theta = sqrt((1.0 - xi.y) / (1.0 + (alpha * alpha - 1.0) * xi.y));
    float sin_theta = sqrt(max(1.0 - cos_theta * cos_theta, 0.0));
    return vec3(sin_theta * cos(phi), sin_theta * sin(phi), cos_theta);
}

float env_d_ggx(float n_dot_h, float alpha) {
    float a2 = alpha * alpha;
    float d = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
    return a2 / (ENV_PI * d * d);
}

#endif
