// variants: hw bvh
#version 460
// `rqr bench`: pure ray throughput through trace_closest(), no shading.
// Mode 0: one primary ray per pixel centre, storing the hit (position, instance, primitive).
// Mode 1: one cosine-weighted bounce ray from every stored primary hit (incoherent rays).
#extension GL_GOOGLE_include_directive : require
#include "scene.glsl"
#include "trace.glsl"
#include "frame.glsl"
#include "sampling.glsl"
#include "counters.glsl"
#include "interface_passes.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(push_constant) uniform Push { RaybenchPush pc; };
// Per pixel: (hit position, instance bits), (primary direction, primitive bits); instance -1 on
// a miss.
layout(set = 0, binding = BINDING_RAYBENCH_HITS, scalar) buffer Hits { vec4 hits[]; };
layout(set = 0, binding = BINDING_RAYBENCH_COUNTERS, std430) buffer Counters { uint counters[]; }; // rays traced, rays that hit

// No barriers or shared memory: on a CPU Vulkan (lavapipe) a barrier turns every invocation
// into a coroutine; counters are summed per subgroup (counters.glsl). The geometric normal of the primary hit
// is fetched by the bounce pass, which needs it, so the primary pass times tracing only.
void main() {
    uvec2 pix = gl_GlobalInvocationID.xy;
    if (pix.x >= frame.width || pix.y >= frame.height) {
        return;
    }
    uint i = pix.y * frame.width + pix.x;
    if (pc.mode == RAYBENCH_PRIMARY) {
        Ray r = camera_ray(vec2(pix) + 0.5);
        Hit h = trace_closest(r.origin, r.dir, 0.0, 3.0e38);
        COUNTER_ADD(counters[0], 1u);
        COUNTER_ADD(counters[1], hit_found(h) ? 1u : 0u);
        hits[2u * i] = vec4(r.origin + h.t * r.dir, intBitsToFloat(h.instance));
        hits[2u * i + 1u] = vec4(r.dir, intBitsToFloat(h.primitive));
    } else {
        vec4 a = hits[2u * i];
        vec4 b = hits[2u * i + 1u];
        Hit ph = miss_hit(0.0);
        ph.instance = floatBitsToInt(a.w);
        ph.primitive = floatBitsToInt(b.w);
        if (!hit_found(ph)) {
            return;
        }
        vec3 n = hit_geometric_normal(ph);
        if (dot(n, b.xyz) > 0.0) n = -n;
        vec3 p = a.xyz + n * frame.epsilon;
        uint seed = hash_u32(i * 0x9E3779B9u + frame.seed);
        vec2 u = vec2(u32_to_unit(hash_u32(seed)), u32_to_unit(hash_u32(seed ^ 0x85ebca6bu)));
        // Cosine-weighted hemisphere about n (Malley's method).
        float radius = sqrt(u.x), phi = 6.2831853 * u.y;
        vec3 t = normalize(abs(n.x) > 0.5 ? cross(n, vec3(0, 1, 0)) : cross(n, vec3(1, 0, 0)));
        vec3 bt = cross(n, t);
        vec3 d = normalize(radius * cos(phi) * t + radius * sin(phi) * bt + sqrt(max(0.0, 1.0 - u.x)) * n);
        Hit h = trace_closest(p, d, 0.0, 3.0e38);
        COUNTER_ADD(counters[0], 1u);
        COUNTER_ADD(counters[1], hit_found(h) ? 1u : 0u);
    }
}
