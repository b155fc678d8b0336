// variants: hw bvh
#version 460
// Traces a list of rays with trace_closest() and trace_any() and writes the results, for
// comparison with the CPU reference (tests/bvh_gpu.rs).
#include "scene.glsl"
#include "trace.glsl"

layout(local_size_x = 64) in;

struct TestRay {
    vec3 origin;
    float tmin;
    vec3 dir;
    float tmax;
};

struct TestHit {
    float t;
    int instance;
    int primitive;
    vec2 barycentrics;
    uint any_hit;
};

layout(set = 0, binding = 3, scalar) readonly buffer Rays { TestRay rays[]; };
layout(set = 0, binding = 4, scalar) writeonly buffer Hits { TestHit hits[]; };
layout(push_constant) uniform Push { uint count; } pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) {
        return;
    }
    TestRay r = rays[i];
    Hit h = trace_closest(r.origin, r.dir, r.tmin, r.tmax);
    TestHit o;
    o.t = h.t;
    o.instance = h.instance;
    o.primitive = h.primitive;
    o.barycentrics = h.barycentrics;
    o.any_hit = trace_any(r.origin, r.dir, r.tmin, r.tmax) ? 1u : 0u;
    hits[i] = o;
}
