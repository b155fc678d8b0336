#version 460
// The split-sum BRDF table (Karis 2013): for n·v = x and roughness = y at texel centres, the
// directional albedo of GGX with height-correlated Smith visibility as scale A and bias B of
// F0: E = F0 A + B (Schlick), in .rg. In .b, at sheen roughness = y, the directional albedo of
// the sheen lobe (KHR_materials_sheen), E_sheen = ∫ D_charlie V_sheen (n·l) dl with the shading
// code's own d_charlie and v_sheen (brdf.glsl). Independent of the environment.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#include "interface_environment.glsl"
#include "env_mapping.glsl"
#include "brdf.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(push_constant, scalar) uniform Push { EnvPreparePush pc; };
layout(buffer_reference, scalar, buffer_reference_align = 16) writeonly buffer Out { vec4 v[]; };

// E_sheen at (n_dot_v, sheen_roughness) from `samples` half vectors drawn uniformly over the
// hemisphere (density 1 / 2π; dl = 4 (v·h) dh). D_charlie peaks at half vectors perpendicular
// to n, a band that uniform sampling covers evenly; its own importance sampling would give
// weights with 1 / (n·h) there.
float sheen_albedo(vec3 v, float n_dot_v, float sheen_roughness, uint samples) {
    float sum = 0.0;
    for (uint i = 0u; i < samples; ++i) {
        vec2 xi = env_hammersley(i, samples);
        float n_dot_h = xi.x;
        float sin_h = sqrt(max(1.0 - n_dot_h * n_dot_h, 0.0));
        float phi = 2.0 * ENV_PI * xi.y;
        vec3 h = vec3(sin_h * cos(phi), sin_h * sin(phi), n_dot_h);
        float v_dot_h = dot(v, h);
        float n_dot_l = 2.0 * v_dot_h * n_dot_h - n_dot_v;
        if (v_dot_h <= 0.0 || n_dot_l <= 0.0) continue;
        sum += d_charlie(sheen_roughness, n_dot_h) * v_sheen(n_dot_l, n_dot_v, sheen_roughness) * n_dot_l * 4.0 * v_dot_h;
    }
    return sum * 2.0 * ENV_PI / float(samples);
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
        float w = v_smith_ggx(n_dot_l, n_dot_v, alpha) * n_dot_l * 4.0 * v_dot_h / max(h.z, 1e-6);
        float fc = pow(1.0 - v_dot_h, 5.0);
        a += (1.0 - fc) * w;
        b += fc * w;
    }
    float e_sheen = sheen_albedo(v, n_dot_v, roughness, pc.samples);
    Out(pc.texels_out).v[p.y * pc.width + p.x] = vec4(a / float(pc.samples), b / float(pc.samples), e_sheen, 1.0);
}
