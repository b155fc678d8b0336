#version 460
// Self-test: burns `iterations` loop steps per invocation, for fence-timeout tests.
layout(local_size_x = 64) in;
layout(set = 0, binding = 0, std430) buffer Sink { uint sink[]; };
layout(push_constant) uniform Push { uint iterations; } pc;

void main() {
    uint x = gl_GlobalInvocationID.x;
    for (uint k = 0u; k < pc.iterations; ++k) {
        x = x * 1664525u + 1013904223u;
    }
    sink[gl_GlobalInvocationID.x & 1023u] = x;
}
