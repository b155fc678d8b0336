#version 460
// Linear HDR -> display sRGB 8-bit: exposure, operator (none / ACES / Khronos PBR Neutral),
// sRGB transfer. One thread per pixel.
#extension GL_EXT_scalar_block_layout : require
layout(local_size_x = 64) in;
#include "interface_passes.glsl"
layout(set = 0, binding = BINDING_TONEMAP_IN, scalar) readonly buffer In { vec4 color_in[]; };
layout(set = 0, binding = BINDING_TONEMAP_OUT, std430) writeonly buffer Out { uint pixels[]; };
layout(push_constant) uniform Push { TonemapPush pc; };

#include "tonemap.glsl"

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    // Colour buffers may hold (weighted sum, weight sum) from accumulation: resolve first.
    vec4 v = color_in[i];
    pixels[i] = tonemap_rgba8(v.a > 0.0 ? v.rgb / v.a : v.rgb, pc.op, pc.scale);
}
