// Per-render parameters (GpuFrame, declared in src/interface/shared.rs) and camera rays.
// Pixel convention: row 0 is the top row; pixel (x, y) covers [x, x+1) x [y, y+1) and its
// centre is (x + 0.5, y + 0.5).
#ifndef RQR_FRAME_GLSL
#define RQR_FRAME_GLSL

#extension GL_EXT_scalar_block_layout : require
#include "interface_shared.glsl"

layout(set = 0, binding = BINDING_FRAME, scalar) uniform Frame { GpuFrame frame; };

struct Ray {
    vec3 origin;
    vec3 dir;
};

// Camera ray through film position `p` in pixels (x right, y down from the top-left corner).
Ray camera_ray(vec2 p) {
    vec2 ndc = vec2(p.x / float(frame.width) * 2.0 - 1.0, 1.0 - p.y / float(frame.height) * 2.0);
    Ray r;
    if (frame.ortho != 0u) {
        vec3 local = vec3(ndc * frame.ortho_half, 0.0);
        r.origin = (frame.camera_to_world * vec4(local, 1.0)).xyz;
        r.dir = normalize(mat3(frame.camera_to_world) * vec3(0.0, 0.0, -1.0));
    } else {
        vec3 local = vec3(ndc.x * frame.tan_half_fov_y * frame.aspect, ndc.y * frame.tan_half_fov_y, -1.0);
        r.origin = frame.camera_pos;
        r.dir = normalize(mat3(frame.camera_to_world) * local);
    }
    return r;
}

vec3 background_radiance(vec3 dir) {
    if ((frame.flags & FLAG_SKY) != 0u) {
        float t = clamp(0.5 * (dir.y + 1.0), 0.0, 1.0);
        return mix(vec3(0.9, 0.9, 0.95) * frame.background, vec3(0.35, 0.55, 0.95) * frame.background, t);
    }
    return frame.background;
}

#endif
