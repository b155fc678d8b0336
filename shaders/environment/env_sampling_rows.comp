#version 460
// The importance-sampling table's rows (src/environment/sampling.rs, the host reference): one
// workgroup per map row y writes the conditional CDF of the row's luminance into table row y
// (width + 1 floats) and the row's weight, Σ luminance · sin θ_y, into entry y + 1 of the
// marginal row (row height), which env_sampling_marginal.comp then scans in place. sin θ_y is
// the same for the whole row, so the conditional CDF is that of the luminance alone and the
// sine multiplies only the sum (one rounding, not one per texel).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "interface_environment.glsl"
#include "env_mapping.glsl"
#include "environment/env_cdf.glsl"

layout(local_size_x = ENV_CDF_GROUP) in;
layout(push_constant, scalar) uniform Push { EnvPreparePush pc; };
layout(set = 0, binding = BINDING_ENV_SOURCE) uniform sampler2D source;

float env_cdf_value(uint x) {
    vec3 c = texelFetch(source, ivec2(x, gl_WorkGroupID.x), 0).rgb;
    // `precise`: the host's f32 luminance, without a fused multiply-add.
    precise float l = 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b;
    return max(l, 0.0);
}

void main() {
    uint y = gl_WorkGroupID.x;
    EnvTable table = EnvTable(pc.texels_out);
    uint stride = pc.width + 1u;
    float sum = env_cdf_build(table, y * stride, pc.width);
    if (gl_LocalInvocationID.x == 0u) {
        // sin θ_y by the row nearer its pole: the argument stays within [0, π/2], where f32
        // sine keeps its relative accuracy (near θ = π it would not).
        float k = min(float(y) + 0.5, float(pc.height - y) - 0.5);
        table.v[pc.height * stride + y + 1u] = sum * sin(ENV_PI * k / float(pc.height));
    }
}
