#version 460
// Scan, step 2 of 3 (one workgroup): exclusive prefix over the block sums; the grand total
// goes to `total` when that address is not 0.
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "bvh_build/scan_common.glsl"
layout(local_size_x = 256) in;
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer U32s { uint v[]; };
#include "interface_bvh.glsl"
layout(push_constant) uniform Push { BvhScanPush pc; };

void main() {
    uint count = U32s(pc.count).v[0];
    uint blocks = (count + SCAN_BLOCK - 1u) / SCAN_BLOCK;
    uint chunk = (blocks + SCAN_GROUP - 1u) / SCAN_GROUP;
    uint first = gl_LocalInvocationID.x * chunk;
    uint last = min(blocks, first + chunk);
    U32s sums = U32s(pc.sums);
    uint s = 0u;
    for (uint k = first; k < last; ++k) {
        s += sums.v[k];
    }
    uint total;
    uint prefix = workgroup_exclusive_scan(s, total);
    for (uint k = first; k < last; ++k) {
        uint v = sums.v[k];
        sums.v[k] = prefix;
        prefix += v;
    }
    if (gl_LocalInvocationID.x == 0u && pc.total != 0ul) {
        U32s(pc.total).v[0] = total;
    }
}
