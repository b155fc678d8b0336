#version 460
// Copies `count` wide nodes built with local indices into the shared node array at `offset`,
// shifting their inner-node links by `offset`.
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
layout(local_size_x = 256) in;
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer Words { uint v[]; };
#include "interface_bvh.glsl"
layout(push_constant) uniform Push { BvhRelocatePush pc; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) {
        return;
    }
    Words src = Words(pc.src);
    Words dst = Words(pc.dst);
    uint from = 16u * i;
    uint to = 16u * (pc.offset + i);
    for (uint k = 0u; k < 16u; ++k) {
        uint w = src.v[from + k];
        // Words 10..13 are the links; bit 31 clear means an inner node.
        if (k >= 10u && k < 14u && (w & 0x80000000u) == 0u) {
            w += pc.offset;
        }
        dst.v[to + k] = w;
    }
}
