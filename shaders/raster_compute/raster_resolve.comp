// variants: atomic64 atomic32
#version 460
// Compute rasterizer, resolve stage (see raster.glsl): turns each pixel's winning global
// triangle id into the visibility image's (instance, primitive), 0xFFFFFFFF where empty.
#extension GL_GOOGLE_include_directive : require
#include "raster.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = BINDING_RASTER_VISIBILITY, rg32ui) uniform writeonly uimage2D visibility;

void main() {
    uvec2 pix = gl_GlobalInvocationID.xy;
    if (pix.x >= frame.width || pix.y >= frame.height) {
        return;
    }
    uint index = pix.y * frame.width + pix.x;
#ifdef RAY_BACKEND_ATOMIC64
    uint64_t value = depth_id[index];
    uint gid = value == ~0ul ? ~0u : uint(value & 0xFFFFFFFFul);
#else
    uint gid = depth_id[frame.width * frame.height + index];
#endif
    uvec2 ids = uvec2(~0u);
    if (gid != ~0u) {
        uint d = draw_of(gid);
        ids = uvec2(draws[d].instance, gid - draws[d].first_triangle);
    }
    imageStore(visibility, ivec2(pix), uvec4(ids, 0u, 0u));
}
