#version 460
// Environment importance sampling on the device for tests/environment.rs: directions drawn
// from random u with their densities and map coordinates (ENV_TEST_SAMPLE), or irradiance estimates at +Y by one strategy
// (ENV_TEST_IRRADIANCE) with radiance read texel by texel (the density's own model).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#include "interface_environment.glsl"
#include "env_mapping.glsl"
#include "env_sampling.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { EnvSamplingTestPush pc; };
layout(set = 0, binding = 0) uniform sampler2D cdf;
layout(set = 0, binding = 1) uniform sampler2D radiance;
layout(buffer_reference, scalar, buffer_reference_align = 16) writeonly buffer Out { vec4 v[]; };

uint pcg(inout uint state) {
    state = state * 747796405u + 2891336453u;
    uint w = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (w >> 22u) ^ w;
}
float unit(inout uint state) { return float(pcg(state) >> 8) * (1.0 / 16777216.0); }

vec3 radiance_at(vec3 d) {
    ivec2 size = textureSize(radiance, 0);
    vec2 uv = env_uv(d);
    ivec2 t = min(ivec2(uv * vec2(size)), size - 1);
    return texelFetch(radiance, t, 0).rgb;
}

float lum(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }

vec3 cosine_direction(vec2 u) {
    float r = sqrt(u.x), phi = 2.0 * ENV_PI * u.y;
    return vec3(r * cos(phi), sqrt(max(1.0 - u.x, 0.0)), r * sin(phi));
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    uint state = i * 9781u + pc.seed * 6271u + 1u;
    pcg(state);
    if (pc.mode == ENV_TEST_SAMPLE) {
        vec2 u = vec2(unit(state), unit(state));
        float pdf;
        vec3 d = env_sample_map(cdf, u, pdf);
        Out(pc.texels_out).v[3u * i] = vec4(d, pdf);
        Out(pc.texels_out).v[3u * i + 1u] = vec4(u, env_pdf_map(cdf, d), 0.0);
        // The map coordinates of d, for the host to check against the mapping in f64.
        Out(pc.texels_out).v[3u * i + 2u] = vec4(env_uv(d), 0.0, 0.0);
        return;
    }
    // Irradiance at +Y (luminance): E = ∫ L cos⁺ dω.
    float sum = 0.0;
    uint half_n = max(pc.samples / 2u, 1u);
    for (uint k = 0u; k < pc.samples; ++k) {
        vec2 u = vec2(unit(state), unit(state));
        bool env = pc.strategy == ENV_STRATEGY_ENVIRONMENT || (pc.strategy == ENV_STRATEGY_MIS && k >= half_n);
        vec3 d;
        float p_env, p_cos;
        if (env) {
            d = env_sample_map(cdf, u, p_env);
            p_cos = max(d.y, 0.0) / ENV_PI;
        } else {
            d = cosine_direction(u);
            p_cos = max(d.y, 0.0) / ENV_PI;
            p_env = pc.strategy == ENV_STRATEGY_MIS ? env_pdf_map(cdf, d) : 0.0;
        }
        float f = lum(radiance_at(d)) * max(d.y, 0.0);
        if (f <= 0.0) continue;
        if (pc.strategy == ENV_STRATEGY_MIS) {
            // Balance heuristic, equal counts: w_s = p_s / (p_cos + p_env); f/p_s w_s / n_s.
            sum += f / (p_cos + p_env) / float(half_n);
        } else {
            sum += f / (env ? p_env : p_cos) / float(pc.samples);
        }
    }
    Out(pc.texels_out).v[i] = vec4(sum, 0.0, 0.0, 0.0);
}
