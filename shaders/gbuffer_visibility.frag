#version 460
// Visibility-buffer raster pass (`--gbuffer visibility`, the default), fragment stage: writes
// only which triangle covers the sample. The hybrid shading pass recovers the hit from it with
// ray_triangle_hit() and shades it exactly like a traced hit, so the raster pass stays as cheap
// as rasterization gets (no material evaluation per overdrawn fragment, 8 bytes per pixel).
#include "scene.glsl"
#include "frame.glsl"
#include "surface.glsl"

#include "interface_passes.glsl"
layout(push_constant) uniform Push { DrawPush pc; };
// Only alpha-MASK draws use the pipeline with the test: a shader that can discard disables
// early depth testing.
layout(constant_id = 0) const bool ALPHA_TEST = true;

layout(location = 0) in vec3 in_bary;
layout(location = 1) flat in uint in_prim;

layout(location = 0) out uvec2 v_ids; // instance, primitive (0xFFFFFFFF: nothing)

void main() {
    if (ALPHA_TEST && !alpha_accepts(pc.instance, in_prim, in_bary.yz)) {
        discard;
    }
    v_ids = uvec2(pc.instance, in_prim);
}
