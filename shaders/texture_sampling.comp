#version 460
// The texture-format measurement of `rqr::autotune`: every invocation takes trilinear samples
// of one texture at places scattered over it and over its mip levels, as shading passes do,
// so the dispatch's time is the cost of sampling that texture's format (BC7 / ASTC blocks, or
// RGBA8) on this device. A CPU device (lavapipe) decodes block formats in software per texel.
#extension GL_GOOGLE_include_directive : require
#include "interface_passes.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(push_constant) uniform Push { TextureSamplingPush pc; };
layout(set = 0, binding = BINDING_TEXTURE_SAMPLING_IMAGE) uniform sampler2D image;
layout(set = 0, binding = BINDING_TEXTURE_SAMPLING_SUMS, std430) buffer Sums { vec4 sums[]; };

void main() {
    uvec2 id = gl_GlobalInvocationID.xy;
    if (id.x >= pc.side || id.y >= pc.side) {
        return;
    }
    vec2 uv = (vec2(id) + 0.5) / float(pc.side);
    vec4 sum = vec4(0.0);
    for (uint i = 0u; i < pc.samples; i++) {
        // Golden-ratio steps: each sample lands somewhere else in the texture, at a level
        // between 0 and 2.25 (trilinear: two levels per sample).
        vec2 p = fract(uv + vec2(0.618034, 0.381966) * float(i));
        sum += textureLod(image, p, 0.75 * float(i % 4u));
    }
    sums[id.y * pc.side + id.x] = sum;
}
