#version 460
// G-buffer raster pass, vertex stage: vertex pulling through buffer addresses. Draw
// 3 x triangle_count vertices per instance; each corner carries a one-hot barycentric so the
// fragment stage gets exact, perspective-correct barycentrics of the original triangle.
#include "scene.glsl"
#include "frame.glsl"

#include "interface_passes.glsl"
layout(push_constant) uniform Push { DrawPush pc; };

layout(location = 0) out vec3 out_bary;
layout(location = 1) flat out uint out_prim;

void main() {
    GpuInstance inst = scene_instance(pc.instance);
    GpuGeometry g = scene_geometry(inst.geometry);
    uint prim = uint(gl_VertexIndex) / 3u;
    uint corner = uint(gl_VertexIndex) % 3u;
    uvec3 tri = scene_triangle(g, prim);
    uint v = corner == 0u ? tri.x : (corner == 1u ? tri.y : tri.z);
    vec4 world = inst.object_to_world * vec4(scene_position(v), 1.0);
    vec4 clip = frame.view_proj * world;
    // Sub-pixel jitter: the film point at pixel centre + jitter lands on the pixel centre
    // (NDC spans 2 over width/height and, like film y, points down).
    clip.xy -= vec2(2.0 * frame.jitter.x / float(frame.width), 2.0 * frame.jitter.y / float(frame.height)) * clip.w;
    gl_Position = clip;
    out_bary = vec3(corner == 0u ? 1.0 : 0.0, corner == 1u ? 1.0 : 0.0, corner == 2u ? 1.0 : 0.0);
    out_prim = prim;
}
