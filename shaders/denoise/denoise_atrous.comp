#version 460
// Denoising, one à-trous iteration (Dammertz et al. 2010, as SVGF): a 5x5 B3-spline kernel
// whose taps lie `step` pixels apart, each weighted by the edge-stopping geometry weights and
// by luminance (the difference over phi_color x the pixel's standard deviation, from a 3x3
// Gaussian of the variance); diffuse and specular apart. The variance is filtered with the
// squared weights. The specular light's kernel also narrows with
// the surface's roughness (a Gaussian of SPECULAR_RADIUS x roughness pixels): the reflection
// in a mirror or a clear glass is as sharp as what it shows, and only accumulated over time.
// One thread per pixel.
#extension GL_GOOGLE_include_directive : require
#include "denoise.glsl"
#include "denoise_edges.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(push_constant) uniform Push { DenoiseAtrousPush pc; };

const float KERNEL[3] = float[3](3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0);
// 12 rather than 48: a metal's reflection of a sharp environment keeps its detail (DamagedHelmet
// at 512²: one frame's MSE 6.7e-4 against 8.3e-4, orbit 0.531x raw against 0.542x; the built-in
// room and the Cornell box's rough sphere unchanged).
const float SPECULAR_RADIUS = 12.0;

layout(buffer_reference, scalar, buffer_reference_align = 4) buffer Floats { float v[]; };

// 3x3 Gaussian of the diffuse (x) and specular (y) variance around p (the alphas of the
// pair, read alone: this is the first iteration's only 3x3 neighbourhood).
vec2 blurred_variance(ivec2 p) {
    const float g[2] = float[2](1.0 / 4.0, 1.0 / 8.0);
    vec2 sum = vec2(0.0);
    float sum_w = 0.0;
    for (int y = -1; y <= 1; ++y) {
        for (int x = -1; x <= 1; ++x) {
            ivec2 q = p + ivec2(x, y);
            if (!inside(q)) continue;
            float w = g[abs(x)] * g[abs(y)];
            uint at = 8u * pixel_index(q) + 3u;
            sum += w * vec2(Floats(pc.source).v[at], Floats(pc.source).v[at + 4u]);
            sum_w += w;
        }
    }
    return sum / sum_w;
}

void main() {
    ivec2 pix = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(pix)) return;
    uint i = pixel_index(pix);
    // The filter's reach shrinks as the history grows (an accumulation of f frames needs
    // less of the spatial footprint for the same variance, and every tap adds bias): taps up
    // to spatial_reach / f pixels apart, none at all for a converged pixel.
    float frames = Moments(params.moments).v[i].frames;
    // A pixel's iterations are therefore a prefix of the five (misses take none). The first
    // iteration it sits out copies its value into the other ping-pong buffer, so both hold
    // it; from then on it writes nothing (a still view's pixels mostly stop after one pass).
    bool first = pc.step == 1u;
    if (!first && frames * float(pc.step / 2u) > params.spatial_reach) return;
    EdgeCentre c = edge_centre(i);
    if (!first && !c.hit) return;
    vec4 d = pair_load(pc.source, i, 0u);
    vec4 s = pair_load(pc.source, i, 1u);
    if (c.hit && frames * float(pc.step) <= params.spatial_reach) {
        // The first iteration smooths the variance estimate over 3x3 (SVGF); later ones take
        // the pixel's own, already filtered by the iterations before.
        vec2 var = first ? blurred_variance(pix) : vec2(d.a, s.a);
        float var_d = var.x, var_s = var.y;
        float sigma_d = params.phi_color * sqrt(max(var_d, 0.0)) + 1e-10;
        float sigma_s = params.phi_color * sqrt(max(var_s, 0.0)) + 1e-10;
        float ld = luma(d.rgb), ls = luma(s.rgb);
        float radius = SPECULAR_RADIUS * Histories(params.history).v[i].specular_albedo.a;
        float inv_two_r2 = radius > 0.0 ? 0.5 / (radius * radius) : -1.0;
        vec4 sum_d = d * vec4(vec3(KERNEL[0] * KERNEL[0]), KERNEL[0] * KERNEL[0] * KERNEL[0] * KERNEL[0]);
        vec4 sum_s = s * vec4(vec3(KERNEL[0] * KERNEL[0]), KERNEL[0] * KERNEL[0] * KERNEL[0] * KERNEL[0]);
        float wd_sum = KERNEL[0] * KERNEL[0], ws_sum = wd_sum;
        for (int y = -2; y <= 2; ++y) {
            for (int x = -2; x <= 2; ++x) {
                if (x == 0 && y == 0) continue;
                ivec2 q = pix + ivec2(x, y) * int(pc.step);
                if (!inside(q)) continue;
                uint j = pixel_index(q);
                float plane;
                float wn = geometry_terms(c, j, plane);
                if (wn <= 0.0) continue;
                float k = KERNEL[abs(x)] * KERNEL[abs(y)] * wn;
                vec4 qd = pair_load(pc.source, j, 0u);
                float wd = k * exp(-plane - abs(ld - luma(qd.rgb)) / sigma_d);
                sum_d += vec4(wd * qd.rgb, wd * wd * qd.a);
                wd_sum += wd;
                // A surface too smooth for the specular kernel reads no specular light.
                if (inv_two_r2 > 0.0) {
                    vec4 qs = pair_load(pc.source, j, 1u);
                    float r2 = float(x * x + y * y) * float(pc.step * pc.step);
                    float ws = k * exp(-plane - abs(ls - luma(qs.rgb)) / sigma_s - r2 * inv_two_r2);
                    sum_s += vec4(ws * qs.rgb, ws * ws * qs.a);
                    ws_sum += ws;
                }
            }
        }
        d = vec4(sum_d.rgb / wd_sum, sum_d.a / (wd_sum * wd_sum));
        s = vec4(sum_s.rgb / ws_sum, sum_s.a / (ws_sum * ws_sum));
    }
    pair_store(pc.target, i, d, s);
}
