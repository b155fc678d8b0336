// variants: hw bvh
#version 460
// `rqr bench`: pure ray throughput through trace_closest(), no shading.
// Mode 0: one primary ray per pixel centre, storing the hit point and geometric normal.
// Mode 1: one cosine-weighted bounce ray from every stored primary hit (incoherent rays).
#extension GL_GOOGLE_include_directive : require
#include "scene.glsl"
#include "trace.glsl"
#include "frame.glsl"
#include "sampling.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(push_constant) uniform Push { uint mode; } pc;
layout(set = 0, binding = 4, scalar) buffer Hits { vec4 hits[]; };   // xyz position, w = 1 on a hit; then normal
layout(set = 0, binding = 5, std430) buffer Counters { uint counters[]; }; // rays traced, rays that hit

shared uint group_rays;
shared uint group_hits;

void main() {
    if (gl_LocalInvocationIndex == 0u) { group_rays = 0u; group_hits = 0u; }
    barrier();
    uvec2 pix = gl_GlobalInvocationID.xy;
    if (pix.x < frame.width && pix.y < frame.height) {
        uint i = pix.y * frame.width + pix.x;
        if (pc.mode == 0u) {
            Ray r = camera_ray(vec2(pix) + 0.5);
            Hit h = trace_closest(r.origin, r.dir, 0.0, 3.0e38);
            atomicAdd(group_rays, 1u);
            if (hit_found(h)) {
                atomicAdd(group_hits, 1u);
                vec3 n = hit_geometric_normal(h);
                if (dot(n, r.dir) > 0.0) n = -n;
                hits[2u * i] = vec4(r.origin + h.t * r.dir, 1.0);
                hits[2u * i + 1u] = vec4(n, 0.0);
            } else {
                hits[2u * i] = vec4(0.0);
            }
        } else if (hits[2u * i].w > 0.0) {
            vec3 p = hits[2u * i].xyz;
            vec3 n = hits[2u * i + 1u].xyz;
            uint seed = hash_u32(i * 0x9E3779B9u + frame.seed);
            vec2 u = vec2(u32_to_unit(hash_u32(seed)), u32_to_unit(hash_u32(seed ^ 0x85ebca6bu)));
            // Cosine-weighted hemisphere about n (Malley's method).
            float radius = sqrt(u.x), phi = 6.2831853 * u.y;
            vec3 t = normalize(abs(n.x) > 0.5 ? cross(n, vec3(0, 1, 0)) : cross(n, vec3(1, 0, 0)));
            vec3 b = cross(n, t);
            vec3 d = normalize(radius * cos(phi) * t + radius * sin(phi) * b + sqrt(max(0.0, 1.0 - u.x)) * n);
            Hit h = trace_closest(p + n * frame.epsilon, d, 0.0, 3.0e38);
            atomicAdd(group_rays, 1u);
            if (hit_found(h)) atomicAdd(group_hits, 1u);
        }
    }
    barrier();
    if (gl_LocalInvocationIndex == 0u) {
        atomicAdd(counters[0], group_rays);
        atomicAdd(counters[1], group_hits);
    }
}
