#version 460
// Denoising, variance estimate: pixels with a short history (under 4 frames) take their
// luminance variance from a 7x7 neighbourhood's moments instead of their own, weighted by the
// same normal and plane edge-stopping the filter uses, and boosted by 4 / length as in SVGF.
// Writes the à-trous iterations' input (illumination, variance). One thread per pixel.
#extension GL_GOOGLE_include_directive : require
#include "denoise.glsl"
#include "denoise_edges.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    ivec2 pix = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(pix)) return;
    uint i = pixel_index(pix);
    vec4 d = pair_load(params.accumulated, i, 0u);
    vec4 s = pair_load(params.accumulated, i, 1u);
    float frames = Moments(params.moments).v[i].frames;
    if (frames > 0.0 && frames < 4.0) {
        EdgeCentre c = edge_centre(i);
        vec4 sum_m = vec4(0.0);
        float sum_w = 0.0;
        for (int y = -3; y <= 3; ++y) {
            for (int x = -3; x <= 3; ++x) {
                ivec2 q = pix + ivec2(x, y);
                if (!inside(q)) continue;
                uint j = pixel_index(q);
                float w = (x == 0 && y == 0) ? 1.0 : geometry_weight(c, j);
                if (w <= 0.0) continue;
                sum_m += w * Moments(params.moments).v[j].moments;
                sum_w += w;
            }
        }
        vec4 m = sum_m / sum_w;
        float boost = 4.0 / frames;
        d = vec4(d.rgb, max(m.y - m.x * m.x, 0.0) * boost);
        s = vec4(s.rgb, max(m.w - m.z * m.z, 0.0) * boost);
    }
    pair_store(params.ping, i, d, s);
}
