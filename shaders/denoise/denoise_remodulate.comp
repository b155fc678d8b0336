#version 460
// Denoising, last pass: the filtered diffuse and specular illumination multiplied back by
// their albedos, plus what was never filtered (emission), both accumulated over the pixel's
// history like the illumination (a miss's colour is all unfiltered light). One thread per pixel.
#extension GL_GOOGLE_include_directive : require
#include "denoise.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
// source: the illumination to remodulate (the last à-trous output, or the accumulation);
// target: this frame's history, whose accumulated albedos multiply it back.
layout(push_constant) uniform Push { DenoiseAtrousPush pc; };

void main() {
    ivec2 pix = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(pix)) return;
    uint i = pixel_index(pix);
    // This frame's accumulated albedos and unfiltered light (pc.target: the history); a miss
    // has only unfiltered light (what it shows, accumulated).
    DenoiseHistory h = Histories(pc.target).v[i];
    vec3 c = h.unfiltered.rgb;
    if (pixel_hit(i)) {
        c += h.diffuse_albedo.rgb * pair_load(pc.source, i, 0u).rgb
           + h.specular_albedo.rgb * pair_load(pc.source, i, 1u).rgb;
    }
    Vec4s(params.denoised).v[i] = vec4(c, 1.0);
}
