#version 460
// The irradiance map: for each texel's normal n, (1/π) ∫ L(l) max(n·l, 0) dω, summed exactly
// over every texel of one source mip level (area-weighted, so it integrates like the map).
// Quadrature instead of sampling: deterministic, and a sun of one texel is not missed.
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
    ivec2 size = textureSize(source, int(pc.source_level));
    float d_theta = ENV_PI / float(size.y);
    float d_phi = 2.0 * ENV_PI / float(size.x);
    vec3 sum = vec3(0.0);
    for (int y = 0; y < size.y; ++y) {
        float theta = (float(y) + 0.5) * d_theta;
        float row_angle = sin(theta) * d_theta * d_phi;
        for (int x = 0; x < size.x; ++x) {
            vec3 l = env_direction(vec2((float(x) + 0.5) / float(size.x), (float(y) + 0.5) / float(size.y)));
            float c = dot(n, l);
            if (c > 0.0) {
                sum += texelFetch(source, ivec2(x, y), int(pc.source_level)).rgb * (c * row_angle);
            }
        }
    }
    Out(pc.texels_out).v[p.y * pc.width + p.x] = vec4(sum / ENV_PI, 1.0);
}
