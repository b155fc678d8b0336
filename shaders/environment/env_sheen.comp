#version 460
// One level of the Charlie-prefiltered sheen map, the radiance half of the sheen lobe's split
// sum (the Khronos glTF Sample Viewer prefilters a Charlie cube the same way): for each
// texel's direction d, taken as normal and view (n = v = d, the split sum's assumption), the
// mean of the environment weighted by the sheen lobe f_sheen(l, n) (n·l) at sheen roughness
// pc.roughness, with the shading code's own d_charlie and v_sheen (brdf.glsl).
//
// Sampling: light directions uniform over the hemisphere (Hammersley), each weighted by the
// lobe, rather than the Sample Viewer's Charlie importance sampling of half vectors. At n = v
// the lobe peaks at the horizon, and a Charlie half vector reflects the view above it only when
// it lies within 45° of n: at sheen roughness 0.25 that is 0.2 % of them, so with the Sample
// Viewer's 64 samples its level comes out black or noisy. Uniform samples reach the horizon
// band evenly. Filtered importance sampling as in env_specular.comp: each sample reads the
// source mip whose texels cover its solid angle, 2π / samples.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#include "interface_environment.glsl"
#include "env_mapping.glsl"
#include "brdf.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(push_constant, scalar) uniform Push { EnvPreparePush pc; };
layout(set = 0, binding = BINDING_ENV_SOURCE) uniform sampler2D source;
layout(buffer_reference, scalar, buffer_reference_align = 16) writeonly buffer Out { vec4 v[]; };

// Below this sheen roughness the lobe at n = v is a ring at the horizon narrower than the
// samples' spacing (and its weights underflow); such levels are filtered at this roughness.
// The sheen's albedo there is nearly 0 but at grazing views, so little depends on it.
const float SHEEN_MIN_ROUGHNESS = 0.1;

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (p.x >= pc.width || p.y >= pc.height) return;
    vec3 n = env_direction((vec2(p) + 0.5) / vec2(pc.width, pc.height));
    vec3 t, b;
    env_basis(n, t, b);
    float roughness = max(pc.roughness, SHEEN_MIN_ROUGHNESS);
    float sample_angle = 2.0 * ENV_PI / float(pc.samples);
    vec3 sum = vec3(0.0);
    float weight = 0.0;
    for (uint i = 0u; i < pc.samples; ++i) {
        vec2 xi = env_hammersley(i, pc.samples);
        float n_dot_l = xi.x;
        float sin_l = sqrt(max(1.0 - n_dot_l * n_dot_l, 0.0));
        float phi = 2.0 * ENV_PI * xi.y;
        vec3 l = (t * cos(phi) + b * sin(phi)) * sin_l + n * n_dot_l;
        // h = normalize(l + n), so n·h = sqrt((1 + n·l) / 2).
        float n_dot_h = sqrt(0.5 * (1.0 + n_dot_l));
        float w = d_charlie(roughness, n_dot_h) * v_sheen(n_dot_l, 1.0, roughness) * n_dot_l;
        float sin_theta = sqrt(max(1.0 - l.y * l.y, 0.0));
        float texel_angle = env_texel_solid_angle(float(pc.source_width), sin_theta);
        float lod = clamp(0.5 * log2(sample_angle / texel_angle), 0.0, float(pc.source_levels - 1u));
        sum += textureLod(source, env_uv(l), lod).rgb * w;
        weight += w;
    }
    Out(pc.texels_out).v[p.y * pc.width + p.x] = vec4(sum / max(weight, 1e-30), 1.0);
}
