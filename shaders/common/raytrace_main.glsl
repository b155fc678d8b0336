// Pure ray-traced path: the bindings and, for raytrace.comp, the main: one thread per pixel, all
// of its samples, in the Whitted model. With SHADING_DISTRIBUTED (distributed.glsl) the main is
// distributed/raytrace_distributed.comp's.
// Bindings (src/interface/passes.rs): the shared ones, BINDING_RT_AOV, _COUNTERS,
// _CORNERS (adaptive corner samples, (w+1) x (h+1)); the colour out through a buffer reference
// (RaytracePush::color).
#include "scene.glsl"
#include "trace.glsl"
#include "frame.glsl"
#include "sampling.glsl"
#include "brdf.glsl"
#include "shade.glsl"
#include "counters.glsl"
#include "aov.glsl"
#ifdef SHADING_DISTRIBUTED
#include "distributed.glsl"
#include "interface_denoise.glsl"
layout(buffer_reference, scalar, buffer_reference_align = 4) writeonly buffer GuideOut { DenoiseGuide v[]; };
#endif

layout(local_size_x = 8, local_size_y = 8) in;
// FLAG_ADAPTIVE_CORNERS selects the corner pass; FLAG_WRITE_AOV enables AOV output.
layout(push_constant) uniform Push { RaytracePush pc; };

layout(buffer_reference, scalar, buffer_reference_align = 4) writeonly buffer ColorOut { vec4 v[]; };
layout(set = 0, binding = BINDING_RT_AOV, scalar) writeonly buffer AovOut { Aov aov_out[]; };
layout(set = 0, binding = BINDING_RT_COUNTERS, std430) buffer Counters { uint counters[]; };  // by RAY_* kind, then samples
layout(set = 0, binding = BINDING_RT_CORNERS, scalar) buffer Corners { vec4 corners[]; };

Surface unused_surface;
Hit unused_hit;

void flush_counters(uint samples) {
    for (uint k = 0u; k < 4u; ++k) {
        COUNTER_ADD(counters[ray_counter_slot(k)], rays_by_kind[k]);
    }
    COUNTER_ADD(counters[ray_counter_slot(COUNTER_SAMPLES)], samples);
#ifdef SHADING_DISTRIBUTED
    COUNTER_ADD(counters[ray_counter_slot(RAY_DIFFUSE)], diffuse_rays);
#endif
}

// Where camera sample `job` of pixel `pix` lies on the film, and its filter weight.
vec2 film_sample(uvec2 pix, uint job, out float w) {
    w = 1.0;
    uint index = (frame.flags & FLAG_SEQUENCE_JITTER) != 0u ? frame.sample_base + job : job;
    vec2 u = sample_2d(frame.sampler_kind, pix, index, frame.spp, frame.seed);
    if (frame.filter_kind == FILTER_TENT) {
        // Tent of radius one pixel around the centre: positions span [-1, 1), weighted.
        vec2 o = u * 2.0 - 1.0;
        w = (1.0 - abs(o.x)) * (1.0 - abs(o.y));
        return vec2(pix) + 0.5 + o;
    }
    return vec2(pix) + u;
}

#ifndef SHADING_DISTRIBUTED
vec3 radiance_at(vec2 film, inout PrimaryInfo info) {
    return whitted(camera_ray(film), PRIMARY_TRACE, unused_surface, unused_hit, info);
}

// The seed's adaptive quincunx supersampling. The pixel's corners come from the corner pass
// (shared with neighbours); its centre is traced here. Each quadrant (corner, centre) whose two
// colours differ by more than the threshold is subdivided: 3 new rays give the quadrant's other
// corners and centre, recursively up to adaptive_depth levels; every leaf quadrant contributes
// its area times the mean of its two samples.
//
// Written as a state machine around ONE radiance_at() call site: lavapipe's LLVM JIT time grows
// with every inlined copy of the Whitted loop, so the shader traces from a single place.
struct Quad { vec2 a; vec3 ca; vec2 m; vec3 cm; float area; uint depth; };
#define QUAD_STACK 24

float differ(vec3 x, vec3 y) {
    vec3 d = abs(min(x, vec3(1.0)) - min(y, vec3(1.0)));
    return max(d.x, max(d.y, d.z));
}

void main() {
    uvec2 pix = gl_GlobalInvocationID.xy;
    bool corner_pass = (pc.flags & FLAG_ADAPTIVE_CORNERS) != 0u;
    uvec2 extent = corner_pass ? uvec2(frame.width + 1u, frame.height + 1u) : uvec2(frame.width, frame.height);
    if (pix.x >= extent.x || pix.y >= extent.y) return;
    bool adaptive = !corner_pass && frame.sampler_kind == SAMPLER_ADAPTIVE;
    uint stride = frame.width + 1u;

    PrimaryInfo info = primary_miss();
    vec3 sum = vec3(0.0);
    float weight_sum = 0.0;
    uint samples = 0u;

    // Adaptive state.
    Quad stack[QUAD_STACK];
    int sp = 0;
    bool subdividing = false;
    Quad current;
    vec2 pending_pos[3];
    vec3 pending_col[3];
    uint pending = 0u;

    for (uint job = 0u; ; ++job) {
        vec2 film;
        float w = 1.0;
        if (corner_pass) {
            if (job > 0u) break;
            film = vec2(pix);
        } else if (adaptive) {
            if (job == 0u) {
                film = vec2(pix) + 0.5;
            } else if (subdividing) {
                film = pending_pos[pending];
            } else {
                // Retire leaf quadrants until one needs subdividing.
                bool found = false;
                while (sp > 0 && !found) {
                    Quad q = stack[--sp];
                    if (q.depth >= frame.adaptive_depth || differ(q.ca, q.cm) <= frame.adaptive_threshold || sp + 4 > QUAD_STACK) {
                        sum += q.area * 0.5 * (q.ca + q.cm);
                    } else {
                        current = q;
                        found = true;
                    }
                }
                if (!found) break;
                subdividing = true;
                pending = 0u;
                pending_pos[0] = vec2(current.a.x, current.m.y);
                pending_pos[1] = vec2(current.m.x, current.a.y);
                pending_pos[2] = 0.5 * (current.a + current.m);
                film = pending_pos[0];
            }
        } else {
            if (job >= frame.spp) break;
            film = film_sample(pix, job, w);
        }

        PrimaryInfo sample_info = primary_miss();
        vec3 c = radiance_at(film, sample_info);
        samples += 1u;
        if (job == 0u) info = sample_info;

        if (corner_pass) {
            corners[pix.y * stride + pix.x] = vec4(c, 1.0);
        } else if (adaptive) {
            if (job == 0u) {
                for (uint k = 0u; k < 4u; ++k) {
                    uvec2 corner = pix + uvec2(k & 1u, k >> 1u);
                    stack[sp++] = Quad(vec2(corner), corners[corner.y * stride + corner.x].rgb, film, c, 0.25, 0u);
                }
            } else {
                pending_col[pending++] = c;
                if (pending == 3u) {
                    vec2 mid = pending_pos[2];
                    vec3 cmid = pending_col[2];
                    float a = current.area * 0.25;
                    uint d = current.depth + 1u;
                    stack[sp++] = Quad(current.a, current.ca, mid, cmid, a, d);
                    stack[sp++] = Quad(pending_pos[0], pending_col[0], mid, cmid, a, d);
                    stack[sp++] = Quad(pending_pos[1], pending_col[1], mid, cmid, a, d);
                    stack[sp++] = Quad(current.m, current.cm, mid, cmid, a, d);
                    subdividing = false;
                }
            }
        } else {
            sum += w * c;
            weight_sum += w;
        }
    }

    if (!corner_pass) {
        uint index = pix.y * frame.width + pix.x;
        ColorOut(pc.color).v[index] = vec4(adaptive ? sum : (weight_sum > 0.0 ? sum / weight_sum : vec3(0.0)), 1.0);
        if ((pc.flags & FLAG_WRITE_AOV) != 0u) {
            aov_out[index] = primary_aov(info, samples);
        }
    }
    flush_counters(samples);
}
#endif
