// variants: hw bvh
#version 460
// Pure ray-traced path in the distributed model (bindings: raytrace_main.glsl). Each
// invocation shades PIXELS_PER_INVOCATION pixels, all samples of one before the next, one
// shaded vertex per step of its loop, and starts the next path as soon as one ends (path
// regeneration): a path's lobe choices and its end are random per pixel, and an invocation
// that traced each path to its end would keep its SIMD group (subgroup) stepping for the one
// lane still going. The images are those of one thread per pixel.
#extension GL_GOOGLE_include_directive : require
#define SHADING_DISTRIBUTED 1
#include "raytrace_main.glsl"

void main() {
    uint rows = (frame.height + PIXELS_PER_INVOCATION - 1u) / PIXELS_PER_INVOCATION;
    uvec2 base = gl_GlobalInvocationID.xy;
    uint samples = 0u;
    uint next = 0u;  // the next (pixel, sample) item of this invocation
    uvec2 pix = uvec2(0u);
    uint job = 0u;
    float w = 1.0;
    vec3 sum = vec3(0.0);
    float weight_sum = 0.0;
    DenoiseGuide guide;
    PrimaryInfo info = primary_miss();
    PrimaryInfo sample_info = primary_miss();
    PathState p;
    p.status = PATH_DONE;
    bool in_flight = false;
    for (;;) {
        if (p.status == PATH_DONE) {
            if (in_flight) {
                vec3 c = path_finish(p);
                samples += 1u;
                sum += w * c;
                weight_sum += w;
                guide.diffuse += vec4(w * split_diffuse, w);
                guide.unfiltered += vec4(w * split_unfiltered, w);
                if (job == 0u) {
                    info = sample_info;
                    guide.diffuse_albedo = vec4(split_diffuse_albedo, 0.0);
                    guide.specular_albedo = vec4(split_specular_albedo, split_roughness);
                }
                if (job + 1u == frame.spp) {
                    uint index = pix.y * frame.width + pix.x;
                    ColorOut(pc.color).v[index] = vec4(weight_sum > 0.0 ? sum / weight_sum : vec3(0.0), 1.0);
                    if ((pc.flags & FLAG_WRITE_AOV) != 0u) {
                        if ((frame.flags & FLAG_SEQUENCE_JITTER) != 0u) {
                            info = pixel_centre_info(pix);
                        }
                        aov_out[index] = primary_aov(info, frame.spp);
                    }
                    if (pc.guide != 0ul) {
                        float ws = guide.diffuse.w > 0.0 ? guide.diffuse.w : 1.0;
                        guide.diffuse = vec4(guide.diffuse.rgb / ws, 1.0);
                        guide.unfiltered = vec4(guide.unfiltered.rgb / ws, 1.0);
                        GuideOut(pc.guide).v[index] = guide;
                    }
                }
                in_flight = false;
            }
            pix = uvec2(base.x, base.y + (next / frame.spp) * rows);
            job = next % frame.spp;
            if (next >= PIXELS_PER_INVOCATION * frame.spp || base.y >= rows || pix.x >= frame.width || pix.y >= frame.height) {
                break;
            }
            next += 1u;
            if (job == 0u) {
                sum = vec3(0.0);
                weight_sum = 0.0;
                guide.diffuse = vec4(0.0);
                guide.unfiltered = vec4(0.0);
            }
            vec2 film = film_sample(pix, job, w);
            sample_info = primary_miss();
            p = path_start(camera_ray(film), PRIMARY_TRACE, unused_surface, unused_hit, pix, frame.sample_base + job);
            in_flight = true;
        }
        path_advance(p, sample_info);
    }
    flush_counters(samples);
}
