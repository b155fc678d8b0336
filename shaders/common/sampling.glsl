// Sub-pixel sample positions. Mirrors src/render/sampling.rs (unit-tested there).
#ifndef RQR_SAMPLING_GLSL
#define RQR_SAMPLING_GLSL

// SAMPLER_* and FILTER_* codes.
#include "interface_shared.glsl"



uint hash_u32(uint x) {
    // lowbias32 (Chris Wellons): a well-mixed 32-bit integer hash.
    x ^= x >> 16; x *= 0x7feb352du;
    x ^= x >> 15; x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

float u32_to_unit(uint x) { return float(x >> 8) * (1.0 / 16777216.0); }

float radical_inverse(uint base, uint i) {
    float inv = 1.0 / float(base), f = inv, r = 0.0;
    while (i > 0u) {
        r += f * float(i % base);
        i /= base;
        f *= inv;
    }
    return r;
}

// Second Sobol dimension: direction numbers v_k = v_{k-1} ^ (v_{k-1} >> 1), v_0 = 2^31.
uint sobol_dim1(uint i) {
    uint v = 0x80000000u, r = 0u;
    for (; i != 0u; i >>= 1) {
        if ((i & 1u) != 0u) r ^= v;
        v ^= v >> 1;
    }
    return r;
}

// Owen scrambling via hashing (Burley 2020, "Practical Hash-based Owen Scrambling").
uint laine_karras(uint x, uint seed) {
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}
uint nested_uniform_scramble(uint x, uint seed) { return bitfieldReverse(laine_karras(bitfieldReverse(x), seed)); }

vec2 sobol_owen(uint index, uint seed) {
    uint i = nested_uniform_scramble(index, hash_u32(seed));
    uint x = nested_uniform_scramble(bitfieldReverse(i), hash_u32(seed ^ 0xa511e9b3u));
    uint y = nested_uniform_scramble(sobol_dim1(i), hash_u32(seed ^ 0x63d83595u));
    return vec2(u32_to_unit(x), u32_to_unit(y));
}

// Interleaved gradient noise (Jimenez 2014): a cheap per-pixel value with a blue-noise-like
// spectrum; offsets an R2 low-discrepancy sequence for the "bluenoise" sampler.
float ign(vec2 pixel) { return fract(52.9829189 * fract(dot(pixel, vec2(0.06711056, 0.00583715)))); }

// Sample `s` of `n` for pixel `pixel` in [0,1)^2 (the filter maps it to the footprint).
// center/grid/halton/sobol place sample s at the same offset in every pixel, so a raster pass
// jittered by that offset sees exactly the same positions (the hybrid path relies on it); jitter
// and bluenoise vary per pixel (ray-traced path only).
vec2 sample_2d(uint kind, uvec2 pixel, uint s, uint n, uint seed) {
    uint k = max(1u, uint(round(sqrt(float(n)))));
    if (kind == SAMPLER_GRID) {
        return (vec2(s % k, s / k) + 0.5) / float(k);
    } else if (kind == SAMPLER_JITTER) {
        uint pix_seed = hash_u32(pixel.x * 73856093u ^ pixel.y * 19349663u ^ seed);
        vec2 j = vec2(u32_to_unit(hash_u32(pix_seed ^ (2u * s))), u32_to_unit(hash_u32(pix_seed ^ (2u * s + 1u))));
        return (vec2(s % k, s / k) + j) / float(k);
    } else if (kind == SAMPLER_HALTON) {
        return vec2(radical_inverse(2u, s + 1u), radical_inverse(3u, s + 1u));
    } else if (kind == SAMPLER_SOBOL) {
        return sobol_owen(s, seed);
    } else if (kind == SAMPLER_BLUENOISE) {
        vec2 r2 = fract(vec2(s) * vec2(0.7548776662466927, 0.5698402909980532));
        return fract(r2 + vec2(ign(vec2(pixel)), ign(vec2(pixel) + vec2(5.588238, 5.588238))));
    }
    return vec2(0.5);
}

#endif
