#version 460
// Denoising, temporal accumulation: this frame's demodulated illumination is blended with the
// previous frame's fed-back illumination, reprojected through the previous camera and (for
// moving objects) the previous pose, read bilinearly from the taps whose surface matches the
// pixel's (disocclusion.glsl, as temporal reuse tests its samples). The blend weight is
// 1 / history length, never below 1 / history_cap; a pixel with no matching tap starts again.
// Also keeps the luminance moments (variance) and this frame's surface. One thread per pixel.
#extension GL_GOOGLE_include_directive : require
#include "scene.glsl"
#include "disocclusion.glsl"
#include "denoise.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

// Pixel coordinates (x + 0.5 = centre) of world point p through view_proj, or far outside the
// image behind the camera.
vec2 to_pixels(mat4 view_proj, vec3 p) {
    vec4 clip = view_proj * vec4(p, 1.0);
    if (!(clip.w > 0.0)) {
        return vec2(-1e9);
    }
    return (clip.xy / clip.w * 0.5 + 0.5) * vec2(params.width, params.height);
}

// Where the pixel's centre was in the previous frame: the centre plus the motion of its
// surface point (through the previous camera and, for moving objects, the previous pose).
// Motion rather than the point's own projection, so that a sample placed off the centre
// (a jittered sampler) does not shift the history by its offset every frame.
vec2 previous_pixel(ivec2 pix, Aov a) {
    vec3 world = a.position.xyz;
    vec3 prev_world = world;
    if (scene.prev_positions != scene.positions || scene.prev_instances != scene.instances) {
        GpuInstance inst = scene_prev_instance(a.instance);
        uvec3 tri = scene_triangle(scene_geometry(inst.geometry), a.primitive);
        vec3 w = vec3(1.0 - a.bary.x - a.bary.y, a.bary.x, a.bary.y);
        vec3 p = w.x * scene_prev_position(tri.x) + w.y * scene_prev_position(tri.y) + w.z * scene_prev_position(tri.z);
        prev_world = (inst.object_to_world * vec4(p, 1.0)).xyz;
    }
    vec2 motion = to_pixels(params.prev_view_proj, prev_world) - to_pixels(params.view_proj, world);
    return vec2(pix) + 0.5 + motion;
}

// The same for a miss: the motion of the far-plane point its pixel looks through (the
// camera's rotation; a miss has no surface point).
vec2 previous_miss_pixel(ivec2 pix) {
    vec2 centre = vec2(pix) + 0.5;
    vec2 ndc = centre / vec2(params.width, params.height) * 2.0 - 1.0;
    vec4 far = params.inv_view_proj * vec4(ndc, 1.0, 1.0);
    vec3 world = far.xyz / far.w;
    return centre + to_pixels(params.prev_view_proj, world) - to_pixels(params.view_proj, world);
}

void main() {
    ivec2 pix = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(pix)) return;
    uint i = pixel_index(pix);
    Aov a = Aovs(params.aov).v[i];
    bool hit = a.instance != AOV_NO_ID;
    DenoiseSurface here;
    here.position = a.position.xyz;
    here.instance = a.instance;
    here.normal = a.geometric_samples.xyz;
    here.depth = a.normal_depth.w;
    Surfaces(params.surface).v[i] = here;
    Vec4s(params.edges).v[i] = hit ? vec4(here.position, uintBitsToFloat(encode_normal(a.normal_depth.xyz)))
                                   : vec4(0.0, 0.0, 0.0, uintBitsToFloat(EDGE_MISS));
    DenoiseGuide guide = Guides(params.guide).v[i];
    float gw = guide.unfiltered.a > 0.0 ? guide.unfiltered.a : 1.0;
    DenoiseHistory acc;
    acc.diffuse_albedo = vec4(max(guide.diffuse_albedo.rgb, vec3(MIN_ALBEDO)), 0.0);
    acc.specular_albedo = vec4(max(guide.specular_albedo.rgb, vec3(MIN_ALBEDO)), guide.specular_albedo.a);
    acc.unfiltered = vec4(guide.unfiltered.rgb / gw, 0.0);
    if (!hit) {
        // All of a miss's colour is unfiltered (with several samples, some may have hit).
        vec4 c = Vec4s(params.color).v[i];
        acc.unfiltered = vec4((params.flags & DN_WEIGHTED_COLOR) != 0u ? (c.a > 0.0 ? c.rgb / c.a : vec3(0.0)) : c.rgb, 0.0);
    }

    vec3 d, s;
    demodulated(i, d, s);
    vec4 m = vec4(luma(d), luma(d) * luma(d), luma(s), luma(s) * luma(s));

    vec3 hd = vec3(0.0), hs = vec3(0.0);
    vec4 hda = vec4(0.0), hsa = vec4(0.0), hu = vec4(0.0);
    vec4 hm = vec4(0.0);
    float hl = 0.0;
    float taps = 0.0;
    if ((params.flags & DN_HISTORY) != 0u) {
        // Misses keep a history too (of what they show, the unfiltered light), so that a
        // jittered environment background averages over frames like the surfaces.
        vec2 p = (hit ? previous_pixel(pix, a) : previous_miss_pixel(pix)) - 0.5;
        ivec2 base = ivec2(floor(p));
        vec2 f = p - vec2(base);
        for (int k = 0; k < 4; ++k) {
            ivec2 q = base + ivec2(k & 1, k >> 1);
            if (!inside(q)) continue;
            uint j = pixel_index(q);
            DenoiseSurface was = Surfaces(params.prev_surface).v[j];
            if (was.instance != a.instance
                || (hit && !surfaces_match(was.position, was.normal, here.position, here.normal, max(here.depth, 1e-6),
                                           params.plane_threshold, params.normal_threshold))) {
                continue;
            }
            float w = ((k & 1) != 0 ? f.x : 1.0 - f.x) * ((k >> 1) != 0 ? f.y : 1.0 - f.y);
            DenoiseHistory h = Histories(params.prev_history).v[j];
            hd += w * h.diffuse.rgb;
            hs += w * h.specular.rgb;
            hda += w * h.diffuse_albedo;
            hsa += w * h.specular_albedo;
            hu += w * h.unfiltered;
            DenoiseMoments pm = Moments(params.prev_moments).v[j];
            hm += w * pm.moments;
            hl += w * pm.frames;
            taps += w;
        }
    }
    DenoiseMoments out_m;
    out_m.pad = vec3(0.0);
    if (taps > 0.01) {
        hd /= taps;
        hs /= taps;
        hm /= taps;
        float frames = min(floor(hl / taps + 0.5) + 1.0, float(params.history_cap));
        float alpha = 1.0 / frames;
        float alpha_m = max(alpha, params.moments_alpha);
        d = mix(hd, d, alpha);
        s = mix(hs, s, alpha);
        acc.diffuse_albedo = mix(hda / taps, acc.diffuse_albedo, alpha);
        acc.specular_albedo = mix(hsa / taps, acc.specular_albedo, alpha);
        acc.unfiltered = mix(hu / taps, acc.unfiltered, alpha);
        m = mix(hm, m, alpha_m);
        out_m.frames = frames;
    } else {
        out_m.frames = 1.0;
    }
    out_m.moments = m;
    Moments(params.moments).v[i] = out_m;
    // The variance of the accumulated estimate: the samples' (from the moments) over the
    // frames behind it, so that the filter's luminance edges tighten as a pixel converges
    // and a static view sharpens towards the accumulated image instead of staying blurred.
    // The variance pass replaces it for young pixels.
    float frames_behind = max(out_m.frames, 1.0);
    float var_d = max(m.y - m.x * m.x, 0.0) / frames_behind;
    float var_s = max(m.w - m.z * m.z, 0.0) / frames_behind;
    pair_store(params.accumulated, i, vec4(d, var_d), vec4(s, var_s));
    // The accumulation itself, not its filtered image, is what the next frame blends with
    // (SVGF feeds the first à-trous iteration back; that blurs a static view a little more
    // every frame, where the accumulation converges to the unbiased mean).
    acc.diffuse = vec4(d, 0.0);
    acc.specular = vec4(s, 0.0);
    Histories(params.history).v[i] = acc;
}
