#version 460
// The split-sum BRDF table (Karis 2013): for n·v = x and roughness = y at texel centres, the
// directional albedo of GGX with height-correlated Smith visibility as scale A and bias B of
// F0: E = F0 A + B (Schlick). Independent of the environment.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#include "interface_environment.glsl"
#include "env_mapping.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(push_constant, scalar) uniform Push { EnvPreparePush pc; };
layout(buffer_reference, scalar, buffer_reference_align = 16) writeonly buffer Out { vec4 v[]; };

float v_smith(float n_dot_l, float n_dot_v, float alpha) {
    float a2 = alpha * alpha;
    float gv = n_dot_l * sqrt(n_dot_v * n_dot_v * (1.0 - a2) + a2);
    float gl = n_dot_v * sqrt(n_dot_l * n_dot_l * (1.0 - a2) + a2);
    float s = gv + gl;
    return s > 0.0 ? 0.5 / s : 0.0;
}

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (p.x >= pc.width || p.y >= pc.height) return;
    float n_dot_v = (float(p.x) + 0.5) / float(pc.width);
    float roughness = (float(p.y) + 0.5) / float(pc.height);
    float alpha = max(roughness * roughness, 1e-3);
    vec3 v = vec3(sqrt(1.0 - n_dot_v * n_dot_v), 0.0, n_dot_v);
    float a = 0.0, b = 0.0;
    for (uint i = 0u; i < pc.samples; ++i) {
        vec3 h = env_ggx_half(env_hammersley(i, pc.samples), alpha);
        vec3 l = 2.0 * dot(v, h) * h - v;
        float n_dot_l = l.z;
        float v_dot_h = max(dot(v, h), 0.0);
        if (n_dot_l <= 0.0) continue;
        // f n·l / pdf with pdf = D (n·h) / (4 v·h) and f = D V F.
        float w = v_smith(n_dot_l, n_dot_v, alpha) * n_dot_l * 4.0 * v_dot_h / max(h.z, 1e-6);
        float fc = pow(1.0 - v_dot_h, 5.0);
        a += (1.0 - fc) * w;
        b += fc * w;
    }
    Out(pc.texels_out).v[p.y * pc.width + p.x] = vec4(a / float(pc.samples), b / float(pc.samples), 0.0, 1.0);
}
