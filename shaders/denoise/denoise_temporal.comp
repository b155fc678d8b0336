#version 460
// Denoising, temporal accumulation: this frame's reflected light is blended with the previous
// frame's accumulation, reprojected through the previous camera and (for moving objects) the
// previous pose, read bilinearly from the taps whose surface matches the pixel's (disocclusion.glsl, as temporal reuse tests its samples). The blend weight is
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

// Whether the previous frame's texel q holds history of the surface the pixel sees now.
bool history_matches(ivec2 q, uint instance, bool hit, DenoiseSurface here) {
    if (!inside(q)) return false;
    DenoiseSurface was = Surfaces(params.prev_surface).v[pixel_index(q)];
    return was.instance == instance
        && (!hit || surfaces_match(was.position, was.normal, here.position, here.normal, max(here.depth, 1e-6),
                                   params.plane_threshold, params.normal_threshold));
}

// Catmull-Rom weights of the texels at -1, 0, 1, 2 for a position f in [0, 1) past texel 0.
vec4 catmull_rom(float f) {
    return vec4(f * (-0.5 + f * (1.0 - 0.5 * f)),
                1.0 + f * f * (-2.5 + 1.5 * f),
                f * (0.5 + f * (2.0 - 1.5 * f)),
                f * f * (-0.5 + 0.5 * f));
}

const float BIG = 3.0e38;

// The unfiltered light of pixel j this frame: a miss's whole colour (with several samples,
// some may have hit).
vec3 unfiltered_light(uint j) {
    if (pixel_hit(j)) {
        vec4 u = Guides(params.guide).v[j].unfiltered;
        return u.rgb / (u.a > 0.0 ? u.a : 1.0);
    }
    vec4 c = Vec4s(params.color).v[j];
    return (params.flags & DN_WEIGHTED_COLOR) != 0u ? (c.a > 0.0 ? c.rgb / c.a : vec3(0.0)) : c.rgb;
}

// The range of this frame's diffuse and unfiltered light over the pixel's 3x3 neighbourhood
// (as temporal anti-aliasing clamps its history): under motion, lights seen directly move
// otherwise than the surface the history follows, and in an animated scene a still surface's
// light changes under moving shadows, so their history is clamped to what the neighbourhood
// shows now instead of being dropped. 1-spp light is noisy, so the range is wide where
// nothing changed and the history mostly survives.
void neighbourhood_range(ivec2 pix, out vec3 lo_d, out vec3 hi_d, out vec3 lo_u, out vec3 hi_u) {
    lo_d = vec3(BIG); hi_d = vec3(0.0); lo_u = vec3(BIG); hi_u = vec3(0.0);
    for (int y = -1; y <= 1; ++y) {
        for (int x = -1; x <= 1; ++x) {
            ivec2 q = pix + ivec2(x, y);
            if (!inside(q)) continue;
            uint j = pixel_index(q);
            vec3 dj, sj;
            reflected(j, dj, sj);
            vec3 uj = unfiltered_light(j);
            lo_d = min(lo_d, dj); hi_d = max(hi_d, dj);
            lo_u = min(lo_u, uj); hi_u = max(hi_u, uj);
        }
    }
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
    DenoiseHistory acc;
    acc.diffuse_albedo = vec4(max(guide.diffuse_albedo.rgb, vec3(MIN_ALBEDO)), 0.0);
    acc.specular_albedo = vec4(max(guide.specular_albedo.rgb, vec3(MIN_ALBEDO)), guide.specular_albedo.a);
    acc.unfiltered = vec4(unfiltered_light(i), 0.0);

    // What is accumulated is reflected light, and what is filtered is its quotient by the
    // accumulated albedo: the mean of products, not the product of means, so that with no
    // spatial filter the output is exactly the average of the frames even where a jittered
    // sample lands on another texel every frame. The moments are of this frame's illumination.
    vec3 d, s;
    reflected(i, d, s);
    vec3 id = d / acc.diffuse_albedo.rgb, is = s / acc.specular_albedo.rgb;
    vec4 m = vec4(luma(id), luma(id) * luma(id), luma(is), luma(is) * luma(is));

    vec3 hd = vec3(0.0), hs = vec3(0.0);
    vec4 hda = vec4(0.0), hsa = vec4(0.0), hu = vec4(0.0);
    vec4 hm = vec4(0.0);
    float hl = 0.0;
    float taps = 0.0;
    bool moved = false;
    if ((params.flags & DN_HISTORY) != 0u) {
        // Misses keep a history too (of what they show, the unfiltered light), so that a
        // jittered environment background averages over frames like the surfaces.
        vec2 p = (hit ? previous_pixel(pix, a) : previous_miss_pixel(pix)) - 0.5;
        ivec2 base = ivec2(floor(p));
        vec2 f = p - vec2(base);
        moved = length(p - vec2(pix)) > 1e-3;
        int matched = 0;
        // Where the history sits exactly on a texel (a still view: every pixel), only that
        // texel has weight and the Catmull-Rom resampling below does not run, so the other
        // three are neither tested nor read. A zero-weight tap adds nothing to the sums, so
        // it is not read either way (the Catmull-Rom branch reads the inner texels' bounds).
        bool on_texel = f.x == 0.0 && f.y == 0.0;
        for (int k = 0; k < 4; ++k) {
            ivec2 q = base + ivec2(k & 1, k >> 1);
            float w = ((k & 1) != 0 ? f.x : 1.0 - f.x) * ((k >> 1) != 0 ? f.y : 1.0 - f.y);
            if (w == 0.0 && on_texel) continue;
            if (!history_matches(q, a.instance, hit, here)) continue;
            matched += 1;
            if (w == 0.0) continue;
            uint j = pixel_index(q);
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
        // Where the history sits between texels (the view moved) and the whole 4x4
        // neighbourhood is the same surface, the light is resampled with Catmull-Rom instead
        // (as temporal anti-aliasing does): a bilinear resampling every frame is a blur that
        // compounds over the history's length. Clamped to the four inner texels against
        // ringing. The albedos too, since the filtered light is multiplied back by them;
        // moments, roughness and length stay bilinear.
        if (matched == 4 && (f.x != 0.0 || f.y != 0.0)) {
            vec4 wx = catmull_rom(f.x), wy = catmull_rom(f.y);
            vec3 cd = vec3(0.0), cs = vec3(0.0), cu = vec3(0.0), cda = vec3(0.0), csa = vec3(0.0);
            vec3 lo_d = vec3(BIG), hi_d = vec3(0.0), lo_s = vec3(BIG), hi_s = vec3(0.0);
            vec3 lo_u = vec3(BIG), hi_u = vec3(0.0);
            vec3 lo_da = vec3(BIG), hi_da = vec3(0.0), lo_sa = vec3(BIG), hi_sa = vec3(0.0);
            bool all = true;
            for (int y = 0; y < 4 && all; ++y) {
                for (int x = 0; x < 4; ++x) {
                    ivec2 q = base + ivec2(x - 1, y - 1);
                    bool inner = x >= 1 && x <= 2 && y >= 1 && y <= 2;
                    if (!inner && !history_matches(q, a.instance, hit, here)) {
                        all = false;
                        break;
                    }
                    float w = wx[x] * wy[y];
                    if (w == 0.0 && !inner) continue;
                    DenoiseHistory h = Histories(params.prev_history).v[pixel_index(q)];
                    if (inner) {
                        lo_d = min(lo_d, h.diffuse.rgb); hi_d = max(hi_d, h.diffuse.rgb);
                        lo_s = min(lo_s, h.specular.rgb); hi_s = max(hi_s, h.specular.rgb);
                        lo_u = min(lo_u, h.unfiltered.rgb); hi_u = max(hi_u, h.unfiltered.rgb);
                        lo_da = min(lo_da, h.diffuse_albedo.rgb); hi_da = max(hi_da, h.diffuse_albedo.rgb);
                        lo_sa = min(lo_sa, h.specular_albedo.rgb); hi_sa = max(hi_sa, h.specular_albedo.rgb);
                    }
                    if (w == 0.0) continue;
                    cd += w * h.diffuse.rgb;
                    cs += w * h.specular.rgb;
                    cu += w * h.unfiltered.rgb;
                    cda += w * h.diffuse_albedo.rgb;
                    csa += w * h.specular_albedo.rgb;
                }
            }
            if (all) {
                hd = clamp(cd, lo_d, hi_d);
                hs = clamp(cs, lo_s, hi_s);
                hu.rgb = clamp(cu, lo_u, hi_u);
                hda.rgb = clamp(cda, lo_da, hi_da);
                hsa.rgb = clamp(csa, lo_sa, hi_sa);
            }
        }
    }
    DenoiseMoments out_m;
    out_m.pad = vec3(0.0);
    if (taps > 0.01) {
        hd /= taps;
        hs /= taps;
        hm /= taps;
        // A history resampled between texels blurs a little more every frame (even through
        // Catmull-Rom), so a moving view keeps a shorter one. Lights seen directly move
        // otherwise than the surface that the motion follows: under motion the unfiltered
        // light's history is clamped to this frame's neighbourhood. While anything in the
        // scene moves, so is the diffuse history (a moving shadow would otherwise leave a
        // trail that fades over the history's length); the unfiltered history of a still view
        // is not (a pixel partly covered by the background would lose the light of its samples
        // that missed: the far edge of a floor went dark). Reflections move otherwise than the
        // surface too, but their history is kept short instead (MOVING_SPECULAR_HISTORY_CAP)
        // and not clamped: a 1-spp neighbourhood's range clamps a mirror's history towards this
        // frame's noise (orbit FLIP at 512² without the clamp: built-in room 0.555x raw against
        // 0.644x, the Cornell box 0.381x against 0.411x, DamagedHelmet 0.342x against 0.340x).
        // Under motion, a pixel whose samples all missed keeps no history: what it shows is
        // the background looked up at its centre (camera_miss_radiance), exact without one,
        // and a history would only add its resampling's blur (DamagedHelmet orbiting at 512²:
        // FLIP 0.375x raw against 0.508x with the moving cap). A miss whose sample hit
        // something (the first sample's albedos are not 0) keeps the history that
        // anti-aliases the silhouette.
        bool sample_hit = any(greaterThan(guide.diffuse_albedo.rgb + guide.specular_albedo.rgb, vec3(0.0)));
        float moving_cap = hit || sample_hit ? params.moving_history_cap : 1.0;
        float cap = moved ? min(float(params.history_cap), moving_cap) : float(params.history_cap);
        float frames = min(floor(hl / taps + 0.5) + 1.0, cap);
        bool animated = scene.prev_positions != scene.positions || scene.prev_instances != scene.instances;
        if (moved || animated) {
            vec3 lo_d, hi_d, lo_u, hi_u;
            neighbourhood_range(pix, lo_d, hi_d, lo_u, hi_u);
            if (animated) {
                // A history the neighbourhood clamps by over a tenth of its range is light
                // that changed (a moving shadow came or went): it restarts, so that this
                // frame's sample and the spatial filter's full reach take over at once, where
                // the clamped value would otherwise fade out at 1 / cap per frame (on the
                // floor under a walking figure, pixels uncovered 8 frames earlier: FLIP 0.109
                // against 0.175 at 128²).
                vec3 clamped = clamp(hd, lo_d, hi_d);
                if (any(greaterThan(abs(clamped - hd), 0.1 * (hi_d - lo_d) + 1e-6))) {
                    frames = 1.0;
                }
                hd = clamped;
            }
            if (moved) {
                hu.rgb = clamp(hu.rgb / taps, lo_u, hi_u) * taps;
            }
        }
        float alpha = 1.0 / frames;
        // The specular light's history is shorter still under motion (MOVING_SPECULAR_HISTORY_CAP).
        float specular_frames = moved ? min(frames, params.moving_specular_history_cap) : frames;
        float alpha_m = max(alpha, params.moments_alpha);
        d = mix(hd, d, alpha);
        s = mix(hs, s, 1.0 / specular_frames);
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
    pair_store(params.accumulated, i, vec4(d / acc.diffuse_albedo.rgb, var_d), vec4(s / acc.specular_albedo.rgb, var_s));
    // The accumulation itself, not its filtered image, is what the next frame blends with
    // (SVGF feeds the first à-trous iteration back; that blurs a static view a little more
    // every frame, where the accumulation converges to the unbiased mean).
    acc.diffuse = vec4(d, 0.0);
    acc.specular = vec4(s, 0.0);
    Histories(params.history).v[i] = acc;
}
