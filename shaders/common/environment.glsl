// Image-based lighting, shared by every path, backend and the temporal passes: the map's
// radiance for rays that miss, and the Whitted model's split-sum environment light
// (prefiltered specular, irradiance, BRDF table with Fdez-Agüera's multiple-scattering
// compensation, Charlie-prefiltered sheen), unshadowed as in the Khronos glTF Sample Viewer.
// Include after scene.glsl and frame.glsl. The textures are prepared by
// src/environment/gpu.rs.
#ifndef RQR_ENVIRONMENT_GLSL
#define RQR_ENVIRONMENT_GLSL
#include "interface_environment.glsl"
#include "env_mapping.glsl"
#include "env_sampling.glsl"

bool env_enabled() { return scene.environment >= 0; }

// World direction to the map's frame: the map turned by frame.env_rotation about +Y
// (counter-clockwise seen from above) shows at d what the unturned map shows at R(-angle) d.
vec3 env_map_direction(vec3 d) {
    float c = frame.env_rotation.x, s = frame.env_rotation.y;
    return vec3(c * d.x - s * d.z, d.y, s * d.x + c * d.z);
}

// The environment's textures are indexed without nonuniformEXT: scene.environment is the same
// for every invocation of a dispatch (dynamically uniform), and the qualifier makes drivers
// such as lavapipe wrap each fetch in a loop over the distinct indices of a subgroup.
vec4 env_texture(uint which, vec3 d, float lod) {
    return textureLod(textures[uint(scene.environment) + which], env_uv(env_map_direction(d)), lod);
}

// Radiance arriving along -d (seen looking towards d), at the map's full resolution.
vec3 env_radiance(vec3 d) { return frame.env_intensity * env_texture(ENV_TEX_RADIANCE, d, 0.0).rgb; }

// Radiance arriving along -d from the map's texel at d, unfiltered: the piecewise-constant
// function env_sample draws from, so light sampling's radiance / density stays bounded next to
// a bright sun (a bilinear lookup spreads it into texels the sampler rarely draws).
vec3 env_radiance_texel(vec3 d) {
    uint which = uint(scene.environment) + ENV_TEX_RADIANCE;
    ivec2 size = textureSize(textures[which], 0);
    ivec2 texel = clamp(ivec2(env_uv(env_map_direction(d)) * vec2(size)), ivec2(0), size - 1);
    return frame.env_intensity * texelFetch(textures[which], texel, 0).rgb;
}

// Cosine-weighted mean radiance around normal n (irradiance / π).
vec3 env_irradiance(vec3 n) { return frame.env_intensity * env_texture(ENV_TEX_IRRADIANCE, n, 0.0).rgb; }

// GGX-prefiltered radiance around r at `roughness`.
vec3 env_specular(vec3 r, float roughness) {
    return frame.env_intensity * env_texture(ENV_TEX_SPECULAR, r, clamp(roughness, 0.0, 1.0) * float(ENV_SPECULAR_LEVELS - 1u)).rgb;
}

// Split-sum scale and bias of F0 at (n·v, roughness).
vec2 env_brdf(float n_dot_v, float roughness) {
    return textureLod(textures[uint(scene.environment) + ENV_TEX_BRDF], vec2(n_dot_v, roughness), 0.0).rg;
}

// Charlie-prefiltered radiance around d at `sheen_roughness`: the sheen lobe's mean radiance
// with n = v = d (env_sheen.comp).
vec3 env_sheen(vec3 d, float sheen_roughness) {
    return frame.env_intensity * env_texture(ENV_TEX_SHEEN, d, clamp(sheen_roughness, 0.0, 1.0) * float(ENV_SPECULAR_LEVELS - 1u)).rgb;
}

// Directional albedo of the sheen lobe (Charlie, V_sheen) at (n·v, sheen roughness).
float env_sheen_albedo(float n_dot_v, float sheen_roughness) {
    return textureLod(textures[uint(scene.environment) + ENV_TEX_BRDF], vec2(n_dot_v, sheen_roughness), 0.0).b;
}

// From the map's frame to the world: the inverse of env_map_direction.
vec3 env_world_direction(vec3 d) {
    float c = frame.env_rotation.x, s = frame.env_rotation.y;
    return vec3(c * d.x + s * d.z, d.y, -s * d.x + c * d.z);
}

// A world direction towards the environment, drawn by luminance × solid angle, and its
// density (the rotation does not change densities).
vec3 env_sample(vec2 u, out float pdf) {
    return env_world_direction(env_sample_map(textures[uint(scene.environment) + ENV_TEX_SAMPLING], u, pdf));
}

// The density env_sample draws world direction d with.
float env_pdf(vec3 d) {
    return env_pdf_map(textures[uint(scene.environment) + ENV_TEX_SAMPLING], env_map_direction(d));
}

// What a ray that found nothing sees: the environment, or for camera rays under
// `--background` (FLAG_ENV_BACKGROUND clear) and without an environment, the background.
vec3 miss_radiance(vec3 dir, bool camera_ray) {
    if (env_enabled() && (!camera_ray || (frame.flags & FLAG_ENV_BACKGROUND) != 0u)) {
        return env_radiance(dir);
    }
    return background_radiance(dir);
}

// What a camera ray through `pixel` along `dir` shows where it finds nothing. In a denoised
// sequence (FLAG_SEQUENCE_JITTER), the background at the pixel's centre, and the environment
// averaged over the pixel's cone (the map's mip of that width), rather than point-sampled
// where the jittered sample went: the background is a known function, so one lookup gives the
// pixel's mean, which jittered samples reach only over frames of history, and such history,
// resampled as the view moves, blurs (as a rasterizer draws a sky box). Lights met on the way
// stay at the sample's direction.
vec3 camera_miss_radiance(uvec2 pixel, vec3 dir) {
    if ((frame.flags & FLAG_SEQUENCE_JITTER) == 0u) {
        return miss_radiance(dir, true);
    }
    vec3 centre = camera_ray(vec2(pixel) + 0.5).dir;
    if (env_enabled() && (frame.flags & FLAG_ENV_BACKGROUND) != 0u) {
        // A texel spans π / rows radians, a pixel frame.pixel_spread.
        float rows = float(textureSize(textures[uint(scene.environment) + ENV_TEX_RADIANCE], 0).y);
        float lod = max(log2(frame.pixel_spread * rows / ENV_PI), 0.0);
        return frame.env_intensity * env_texture(ENV_TEX_RADIANCE, centre, lod).rgb;
    }
    return background_radiance(centre);
}

// Single- and multiple-scattering specular energy of a GGX layer with Fresnel F0 = f0 (and
// F90 scaled by specular_weight, KHR_materials_specular), from the BRDF table's `ab` at
// (n_dot_v, roughness): ss = k_S A + B, ms = Ems ss F_avg / (1 - F_avg Ems) (Fdez-Agüera 2019).
void env_specular_energy(vec2 ab, vec3 f0, float specular_weight, float n_dot_v, float roughness, out vec3 ss, out vec3 ms) {
    vec3 fr = max(vec3(1.0 - roughness), f0) - f0;
    // (1 - n·v)^5 by multiplications: pow() is exp2(5 log2 x) on CPU devices, two polynomials.
    float m = 1.0 - n_dot_v;
    float m2 = m * m;
    vec3 k_s = f0 + fr * (m2 * m2 * m);
    ss = specular_weight * (k_s * ab.x + ab.y);
    float e_ms = 1.0 - (ab.x + ab.y);
    vec3 f_avg = specular_weight * (f0 + (1.0 - f0) / 21.0);
    ms = e_ms * ss * f_avg / (vec3(1.0) - f_avg * e_ms);
}

#endif
