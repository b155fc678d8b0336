// Linear HDR -> display sRGB 8-bit: exposure scale, operator (TONEMAP_* of
// src/interface/passes.rs), sRGB transfer. Shared by tonemap.comp and the reprojection passes,
// which write each pixel's display value where they write its colour (fused: no pass over the
// image to read the colours back).
#ifndef RQR_TONEMAP_GLSL
#define RQR_TONEMAP_GLSL
#include "interface_passes.glsl"

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

// RGBA8 (alpha 255) of linear colour `c`, `scale` = 2^exposure.
uint tonemap_rgba8(vec3 c, uint op, float scale) {
    c = max(c, vec3(0.0)) * scale;
    if (op == TONEMAP_ACES) c = aces(c);
    else if (op == TONEMAP_KHRONOS_NEUTRAL) c = khronos_neutral(c);
    uvec3 b = uvec3(round(vec3(srgb(c.r), srgb(c.g), srgb(c.b)) * 255.0));
    return b.r | (b.g << 8) | (b.b << 16) | (255u << 24);
}

#endif
