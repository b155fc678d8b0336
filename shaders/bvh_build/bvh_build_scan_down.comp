#version 460
// Scan, step 3 of 3: exclusive prefix within each 1024-element block plus the block's offset,
// in place.
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
    U32s data = U32s(pc.data);
    uint base = gl_WorkGroupID.x * SCAN_BLOCK + gl_LocalInvocationID.x * SCAN_PER_THREAD;
    uint v[SCAN_PER_THREAD];
    uint s = 0u;
    for (uint k = 0u; k < SCAN_PER_THREAD; ++k) {
        v[k] = base + k < count ? data.v[base + k] : 0u;
        s += v[k];
    }
    uint total;
    uint prefix = workgroup_exclusive_scan(s, total) + U32s(pc.sums).v[gl_WorkGroupID.x];
    for (uint k = 0u; k < SCAN_PER_THREAD; ++k) {
        if (base + k < count) {
            data.v[base + k] = prefix;
        }
        prefix += v[k];
    }
}
