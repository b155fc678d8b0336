#version 460
// Self-test: out[i] = in[i] * 3 + i. Checks upload -> dispatch -> readback end to end.
layout(local_size_x = 64) in;
layout(set = 0, binding = 0, std430) readonly buffer Input { uint values_in[]; };
layout(set = 0, binding = 1, std430) writeonly buffer Output { uint values_out[]; };
layout(push_constant) uniform Push { uint count; } pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i < pc.count) {
        values_out[i] = values_in[i] * 3u + i;
    }
}
