// Importance sampling of an environment map by luminance × solid angle, from the tables of
// src/environment/sampling.rs (its host twin): an R32F texture of (width + 1) × (height + 1)
// values, row y < height the conditional CDF of map row y, row height the marginal CDF of the
// rows. Directions are in the map's frame; the caller turns them into the world
// (environment.glsl's env_sample / env_pdf). Include after env_mapping.glsl.
#ifndef RQR_ENV_SAMPLING_GLSL
#define RQR_ENV_SAMPLING_GLSL

// Bin i of the n-bin CDF in `row` with cdf[i] <= u < cdf[i + 1]; `t` where u falls in it and
// `p` the bin's probability.
int env_cdf_find(sampler2D cdf, int row, int n, float u, out float t, out float p) {
    int lo = 0, hi = n;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (texelFetch(cdf, ivec2(mid, row), 0).r <= u) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    float c0 = texelFetch(cdf, ivec2(lo, row), 0).r;
    float c1 = texelFetch(cdf, ivec2(lo + 1, row), 0).r;
    t = c1 > c0 ? clamp((u - c0) / (c1 - c0), 0.0, 1.0) : 0.5;
    p = c1 - c0;
    return lo;
}

// dω / (du dv) = 2π² sin θ at direction d (sin θ from d.y, so a drawn direction and its
// density agree to rounding, where acos near the poles would not).
float env_jacobian(vec3 d) {
    return 2.0 * ENV_PI * ENV_PI * max(sqrt(max(1.0 - d.y * d.y, 0.0)), 1e-6);
}

// A map-frame direction for u in [0, 1)², with its solid-angle density.
vec3 env_sample_map(sampler2D cdf, vec2 u, out float pdf) {
    ivec2 size = textureSize(cdf, 0) - 1;
    float ty, py, tx, px;
    int y = env_cdf_find(cdf, size.y, size.y, u.y, ty, py);
    int x = env_cdf_find(cdf, y, size.x, u.x, tx, px);
    vec2 uv = vec2((float(x) + tx) / float(size.x), (float(y) + ty) / float(size.y));
    vec3 d = env_direction(uv);
    pdf = py * float(size.y) * px * float(size.x) / env_jacobian(d);
    return d;
}

// The solid-angle density of map-frame direction d.
float env_pdf_map(sampler2D cdf, vec3 d) {
    ivec2 size = textureSize(cdf, 0) - 1;
    vec2 uv = env_uv(d);
    int x = min(int(uv.x * float(size.x)), size.x - 1);
    int y = min(int(uv.y * float(size.y)), size.y - 1);
    float py = texelFetch(cdf, ivec2(y + 1, size.y), 0).r - texelFetch(cdf, ivec2(y, size.y), 0).r;
    float px = texelFetch(cdf, ivec2(x + 1, y), 0).r - texelFetch(cdf, ivec2(x, y), 0).r;
    return py * float(size.y) * px * float(size.x) / env_jacobian(d);
}

#endif
