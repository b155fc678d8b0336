// variants: hw
#version 460
// Pure ray-traced path: one thread per pixel, all of its samples; Whitted trace/shade.
// Bindings: 0-2 scene/textures/ray backend, 3 frame, 4 colour out, 5 AOVs, 6 ray counters,
// 7 adaptive corner samples ((w+1) x (h+1)).
#extension GL_GOOGLE_include_directive : require
#include "scene.glsl"
#include "trace.glsl"
#include "frame.glsl"
#include "sampling.glsl"
#include "brdf.glsl"
#include "shade.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
// FLAG_ADAPTIVE_CORNERS selects the corner pass; FLAG_WRITE_AOV enables AOV output.
layout(push_constant) uniform Push { uint flags; } pc;

layout(set = 0, binding = 4, scalar) writeonly buffer ColorOut { vec4 color_out[]; };
struct Aov {
    vec4 normal_depth;   // xyz geometric normal (glTF front face), w = t (0 on a miss)
    vec4 position_inst;  // xyz world position, w = instance (-1 on a miss)
    vec4 bary_prim;      // xy barycentrics, z = primitive (-1 on a miss), w = samples used
};
layout(set = 0, binding = 5, scalar) writeonly buffer AovOut { Aov aov_out[]; };
layout(set = 0, binding = 6, std430) buffer Counters { uint counters[]; };  // by RAY_* kind, then samples
layout(set = 0, binding = 7, scalar) buffer Corners { vec4 corners[]; };

PrimaryInfo no_info() {
    PrimaryInfo i;
    i.hit = false; i.t = 0.0; i.instance = -1; i.primitive = -1; i.bary = vec2(0.0); i.normal = vec3(0.0); i.position = vec3(0.0);
    return i;
}

Surface unused_surface;

vec3 radiance_at(vec2 film, inout PrimaryInfo info) {
    return whitted(camera_ray(film), false, unused_surface, 0.0, info);
}

// The seed's adaptive quincunx supersampling. The pixel's corners come from the corner pass
// (shared with neighbours); its centre is traced here. Each quadrant (corner, centre) whose two
// colours differ by more than the threshold is subdivided: 3 new rays give the quadrant's other
// corners and centre, recursively up to adaptive_depth levels; every leaf quadrant contributes
// its area times the mean of its two samples.
struct Quad { vec2 a; vec3 ca; vec2 m; vec3 cm; float area; uint depth; };
#define QUAD_STACK 24

float differ(vec3 x, vec3 y) {
    vec3 d = abs(min(x, vec3(1.0)) - min(y, vec3(1.0)));
    return max(d.x, max(d.y, d.z));
}

vec3 adaptive_pixel(uvec2 pix, inout PrimaryInfo info, inout uint samples) {
    uint stride = frame.width + 1u;
    vec2 base = vec2(pix);
    vec2 centre = base + 0.5;
    vec3 cc = radiance_at(centre, info);
    samples += 1u;
    Quad stack[QUAD_STACK];
    int sp = 0;
    for (uint k = 0u; k < 4u; ++k) {
        uvec2 corner = pix + uvec2(k & 1u, k >> 1u);
        stack[sp++] = Quad(vec2(corner), corners[corner.y * stride + corner.x].rgb, centre, cc, 0.25, 0u);
    }
    vec3 sum = vec3(0.0);
    PrimaryInfo scratch = no_info();
    while (sp > 0) {
        Quad q = stack[--sp];
        if (q.depth >= frame.adaptive_depth || differ(q.ca, q.cm) <= frame.adaptive_threshold || sp + 4 > QUAD_STACK) {
            sum += q.area * 0.5 * (q.ca + q.cm);
            continue;
        }
        vec2 b1 = vec2(q.a.x, q.m.y), b2 = vec2(q.m.x, q.a.y), mid = 0.5 * (q.a + q.m);
        vec3 c1 = radiance_at(b1, scratch), c2 = radiance_at(b2, scratch), cmid = radiance_at(mid, scratch);
        samples += 3u;
        float a = q.area * 0.25;
        stack[sp++] = Quad(q.a, q.ca, mid, cmid, a, q.depth + 1u);
        stack[sp++] = Quad(b1, c1, mid, cmid, a, q.depth + 1u);
        stack[sp++] = Quad(b2, c2, mid, cmid, a, q.depth + 1u);
        stack[sp++] = Quad(q.m, q.cm, mid, cmid, a, q.depth + 1u);
    }
    return sum;
}

void flush_counters(uint samples) {
    for (uint k = 0u; k < 4u; ++k) {
        if (rays_by_kind[k] != 0u) atomicAdd(counters[k], rays_by_kind[k]);
    }
    if (samples != 0u) atomicAdd(counters[4], samples);
}

void main() {
    uvec2 pix = gl_GlobalInvocationID.xy;
    if ((pc.flags & FLAG_ADAPTIVE_CORNERS) != 0u) {
        if (pix.x > frame.width || pix.y > frame.height) return;
        PrimaryInfo info = no_info();
        corners[pix.y * (frame.width + 1u) + pix.x] = vec4(radiance_at(vec2(pix), info), 1.0);
        flush_counters(1u);
        return;
    }
    if (pix.x >= frame.width || pix.y >= frame.height) return;
    uint index = pix.y * frame.width + pix.x;
    PrimaryInfo info = no_info();
    vec3 sum = vec3(0.0);
    float weight_sum = 0.0;
    uint samples = 0u;
    if (frame.sampler_kind == SAMPLER_ADAPTIVE) {
        sum = adaptive_pixel(pix, info, samples);
        weight_sum = 1.0;
    } else {
        for (uint s = 0u; s < frame.spp; ++s) {
            vec2 u = sample_2d(frame.sampler_kind, pix, s, frame.spp, frame.seed);
            vec2 film;
            float w = 1.0;
            if (frame.filter_kind == FILTER_TENT) {
                // Tent of radius one pixel around the centre: positions span [-1, 1), weighted.
                vec2 o = u * 2.0 - 1.0;
                film = vec2(pix) + 0.5 + o;
                w = (1.0 - abs(o.x)) * (1.0 - abs(o.y));
            } else {
                film = vec2(pix) + u;
            }
            PrimaryInfo sample_info = no_info();
            vec3 c = radiance_at(film, sample_info);
            if (s == 0u) info = sample_info;
            sum += w * c;
            weight_sum += w;
            samples += 1u;
        }
    }
    color_out[index] = vec4(weight_sum > 0.0 ? sum / weight_sum : vec3(0.0), 1.0);
    if ((pc.flags & FLAG_WRITE_AOV) != 0u) {
        Aov a;
        a.normal_depth = vec4(info.normal, info.hit ? info.t : 0.0);
        a.position_inst = vec4(info.position, float(info.hit ? info.instance : -1));
        a.bary_prim = vec4(info.bary, float(info.hit ? info.primitive : -1), float(samples));
        aov_out[index] = a;
    }
    flush_counters(samples);
}
