#version 460
// The importance-sampling table's marginal row (src/environment/sampling.rs, the host
// reference): one workgroup scans the row weights env_sampling_rows.comp left in entries
// 1 ..= height of table row `height` into the rows' normalised CDF, in place, and zeroes the
// row's entries after it (height + 1 ..= width).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "interface_environment.glsl"
#include "environment/env_cdf.glsl"

layout(local_size_x = ENV_CDF_GROUP) in;
layout(push_constant, scalar) uniform Push { EnvPreparePush pc; };

uint marginal_base() {
    return pc.height * (pc.width + 1u);
}

float env_cdf_value(uint y) {
    return EnvTable(pc.texels_out).v[marginal_base() + y + 1u];
}

void main() {
    EnvTable table = EnvTable(pc.texels_out);
    env_cdf_build(table, marginal_base(), pc.height);
    for (uint i = pc.height + 1u + gl_LocalInvocationID.x; i <= pc.width; i += ENV_CDF_GROUP) {
        table.v[marginal_base() + i] = 0.0;
    }
}
