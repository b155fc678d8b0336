#version 460
// Evaluates brdf.glsl / sampling.glsl functions for the host to compare with src/render.
#include "brdf.glsl"
#include "sampling.glsl"
layout(local_size_x = 64) in;
layout(set = 0, binding = 0, std430) writeonly buffer Out { float values[]; };
layout(push_constant) uniform Push { uint count; } pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    float angle = 1.5 * float(i) / float(pc.count);
    vec3 inc = vec3(sin(angle), -cos(angle), 0.0);
    uint o = i * 16u;
    vec3 t;
    bool ok_in = refract_dir(inc, vec3(0, 1, 0), 1.0 / 1.5, t);
    values[o + 0] = ok_in ? 1.0 : 0.0;
    values[o + 1] = t.x; values[o + 2] = t.y;
    bool ok_out = refract_dir(inc, vec3(0, 1, 0), 1.5, t);
    values[o + 3] = ok_out ? 1.0 : 0.0;
    values[o + 4] = t.x; values[o + 5] = t.y;
    vec3 r = reflect_dir(inc, vec3(0, 1, 0));
    values[o + 6] = r.x; values[o + 7] = r.y;
    values[o + 8] = fresnel_schlick(vec3(0.04), cos(angle)).x;
    values[o + 9] = radical_inverse(2u, i + 1u);
    values[o + 10] = radical_inverse(3u, i + 1u);
    vec2 so = sobol_owen(i, 1234u);
    values[o + 11] = so.x; values[o + 12] = so.y;
    values[o + 13] = float(hash_u32(i) >> 8);
    values[o + 14] = 0.0; values[o + 15] = 0.0;
}
