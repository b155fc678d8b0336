#version 460
// Linear HDR -> display sRGB 8-bit: exposure, operator (none / ACES / Khronos PBR Neutral),
// sRGB transfer. One thread per pixel.
#extension GL_EXT_scalar_block_layout : require
layout(local_size_x = 64) in;
#include "interface_passes.glsl"
layout(set = 0, binding = BINDING_TONEMAP_IN, scalar) readonly buffer In { vec4 color_in[]; };
layout(set = 0, binding = BINDING_TONEMAP_OUT, std430) writeonly buffer Out { uint pixels[]; };
layout(push_constant) uniform Push { TonemapPush pc; };

vec3 aces(vec3 x) {
    // Narkowicz 2015 fit of the ACES filmic curve.
    return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

vec3 khronos_neutral(vec3 color) {
    // Khronos PBR Neutral (2024), reference GLSL.
    const float start_compression = 0.8 - 0.04;
    const float desaturation = 0.15;
    float x = min(color.r, min(color.g, color.b));
    float offset = x < 0.08 ? x - 6.25 * x * x : 0.04;
    color -= offset;
    float peak = max(color.r, max(color.g, color.b));
    if (peak < start_compression) return color;
    const float d = 1.0 - start_compression;
    float new_peak = 1.0 - d * d / (peak + d - start_compression);
    color *= new_peak / peak;
    float g = 1.0 - 1.0 / (desaturation * (peak - new_peak) + 1.0);
    return mix(color, vec3(new_peak), g);
}

float srgb(float x) {
    x = clamp(x, 0.0, 1.0);
    return x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    // Colour buffers may hold (weighted sum, weight sum) from accumulation: resolve first.
    vec4 v = color_in[i];
    vec3 c = max(v.a > 0.0 ? v.rgb / v.a : v.rgb, vec3(0.0)) * pc.scale;
    if (pc.op == TONEMAP_ACES) c = aces(c);
    else if (pc.op == TONEMAP_KHRONOS_NEUTRAL) c = khronos_neutral(c);
    uvec3 b = uvec3(round(vec3(srgb(c.r), srgb(c.g), srgb(c.b)) * 255.0));
    pixels[i] = b.r | (b.g << 8) | (b.b << 16) | (255u << 24);
}
