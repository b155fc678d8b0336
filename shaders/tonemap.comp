#version 460
// Linear HDR -> display sRGB 8-bit: exposure, operator (none / ACES / Khronos PBR Neutral),
// sRGB transfer. One thread per pixel.
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_buffer_reference2 : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
layout(local_size_x = 64) in;
#include "interface_passes.glsl"
#include "counters.glsl"
// In and out through buffer references at the addresses in the push constant (a CPU device
// gathers and scatters through them with vector instructions).
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer ColorIn { vec4 v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) writeonly buffer PixelsOut { uint v[]; };
layout(push_constant) uniform Push { TonemapPush pc; };

#include "tonemap.glsl"

void main() {
    // Rows of workgroups: a long image needs more than a device launches in one dimension.
    uint i = linear_invocation(gl_WorkGroupSize.x);
    if (i >= pc.count) return;
    // Colour buffers may hold (weighted sum, weight sum) from accumulation: resolve first.
    vec4 v = ColorIn(pc.color_in).v[i];
    PixelsOut(pc.pixels_out).v[i] = tonemap_rgba8(v.a > 0.0 ? v.rgb / v.a : v.rgb, pc.op, pc.scale);
}
