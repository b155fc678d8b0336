#version 460
// One level of the GGX-prefiltered specular map: for each texel's direction r (taken as normal
// and view, n = v = r, as the split-sum approximation does), the n·l-weighted mean of the
// environment over GGX-sampled light directions at push.roughness. Filtered importance
// sampling (Křivánek & Colbert 2008, without their +1 level bias, which blurred the roughest
// level by 2 %): each sample reads the source mip whose texels cover the sample's solid angle,
// so a few hundred samples give a smooth result.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#include "interface_environment.glsl"
#include "env_mapping.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(push_constant, scalar) uniform Push { EnvPreparePush pc; };
layout(set = 0, binding = BINDING_ENV_SOURCE) uniform sampler2D source;
layout(buffer_reference, scalar, buffer_reference_align = 16) writeonly buffer Out { vec4 v[]; };

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (p.x >= pc.width || p.y >= pc.height) return;
    vec3 n = env_direction((vec2(p) + 0.5) / vec2(pc.width, pc.height));
    vec3 color;
    if (pc.roughness <= 0.0) {
        // Mirror level: the source averaged over this level's texel.
        color = textureLod(source, env_uv(n), log2(float(pc.source_width) / float(pc.width))).rgb;
    } else {
        vec3 t, b;
        env_basis(n, t, b);
        float alpha = pc.roughness * pc.roughness;
        vec3 sum = vec3(0.0);
        float weight = 0.0;
        for (uint i = 0u; i < pc.samples; ++i) {
            vec3 h_local = env_ggx_half(env_hammersley(i, pc.samples), alpha);
            vec3 h = t * h_local.x + b * h_local.y + n * h_local.z;
            vec3 l = 2.0 * dot(n, h) * h - n;
            float n_dot_l = dot(n, l);
            if (n_dot_l <= 0.0) continue;
            // pdf of l: D(h) (n·h) / (4 v·h), with v = n.
            float pdf = env_d_ggx(h_local.z, alpha) * 0.25;
            float sample_angle = 1.0 / (float(pc.samples) * pdf + 1e-6);
            float sin_theta = sqrt(max(1.0 - l.y * l.y, 0.0));
            float texel_angle = env_texel_solid_angle(float(pc.source_width), sin_theta);
            float lod = clamp(0.5 * log2(sample_angle / texel_angle), 0.0, float(pc.source_levels - 1u));
            sum += textureLod(source, env_uv(l), lod).rgb * n_dot_l;
            weight += n_dot_l;
        }
        color = sum / max(weight, 1e-6);
    }
    Out(pc.texels_out).v[p.y * pc.width + p.x] = vec4(color, 1.0);
}
