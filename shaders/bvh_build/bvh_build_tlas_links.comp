#version 460
// Copies the top level, built by the bottom-level passes over one "triangle" per instance
// (its world box as (min, max, min), primitive = instance index), to the front of the node
// array and turns every leaf link into the instance it holds: a top-level leaf link addresses
// its instance directly (count 1).
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
layout(local_size_x = 256) in;
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer Words { uint v[]; };
#include "interface_bvh.glsl"
layout(push_constant) uniform Push { BvhTlasLinksPush pc; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) {
        return;
    }
    Words src = Words(pc.src);
    Words dst = Words(pc.dst);
    Words leaves = Words(pc.leaves);
    for (uint k = 0u; k < 16u; ++k) {
        uint w = src.v[16u * i + k];
        // Words 10..13 are the links; bit 31 set (and not the empty link) marks a leaf.
        if (k >= 10u && k < 14u && w != 0xFFFFFFFFu && (w & 0x80000000u) != 0u) {
            uint first = w & 0x07FFFFFFu;
            w = 0x80000000u | leaves.v[10u * first + 9u];
        }
        dst.v[16u * i + k] = w;
    }
}
