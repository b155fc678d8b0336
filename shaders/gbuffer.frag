#version 460
// Full G-buffer raster pass (`--gbuffer full`), fragment stage: takes the hit from intersecting
// the sample's camera ray with the rasterized triangle (ray_triangle_hit), evaluates the
// material with the SAME surface_at() as the ray-traced path (ray-cone texture LOD from the
// camera distance), alpha-tests MASK materials with the same alpha_accepts(), and writes the
// G-buffer.
#include "scene.glsl"
#include "frame.glsl"
#include "surface.glsl"

#include "interface_passes.glsl"
layout(push_constant) uniform Push { DrawPush pc; };
// Only alpha-MASK draws use the pipeline with the test: a shader that can discard disables
// early depth testing (on lavapipe it then shades every overdrawn fragment).
layout(constant_id = 0) const bool ALPHA_TEST = true;

layout(location = 0) in vec3 in_bary;
layout(location = 1) flat in uint in_prim;

layout(location = GBUFFER_POSITION) out vec4 g_position;   // world position, t along the camera ray
layout(location = GBUFFER_NORMAL) out vec4 g_normal;     // shading normal (facing the camera), roughness
layout(location = GBUFFER_GEOMETRIC) out vec4 g_geometric;  // geometric normal of the glTF front face, metallic
layout(location = GBUFFER_BASE) out vec4 g_base;       // base colour, alpha
layout(location = GBUFFER_EMISSIVE) out vec4 g_emissive;   // emissive, occlusion
layout(location = GBUFFER_IDS) out uvec4 g_ids;       // instance, primitive, material | front << 31, transmission bits
layout(location = GBUFFER_BARY) out vec4 g_bary;       // barycentrics (b1, b2), motion vector in pixels

void main() {
    vec2 bary = in_bary.yz;
    if (ALPHA_TEST && !alpha_accepts(pc.instance, in_prim, bary)) {
        discard;
    }
    // The primary ray through this fragment's sample position (pixel centre + jitter).
    vec2 film = gl_FragCoord.xy + frame.jitter;
    Ray cam = camera_ray(film);
    vec3 hit = ray_triangle_hit(pc.instance, in_prim, cam.origin, cam.dir, bary);
    bary = hit.xy;
    float t = hit.z;
    Surface s = surface_at(pc.instance, in_prim, bary, cam.dir, frame.pixel_spread * t);
    g_position = vec4(s.position, t);
    g_normal = vec4(s.n, s.roughness);
    g_geometric = vec4(s.ng_front, s.metallic);
    g_base = vec4(s.base_color, s.alpha);
    g_emissive = vec4(s.emissive, s.occlusion);
    g_ids = uvec4(pc.instance, in_prim, s.material | (s.front_face ? 0x80000000u : 0u), floatBitsToUint(s.transmission));
    // Motion: where this object-space point was in the previous frame, through the previous
    // instance transform and (skinned, morphed) vertices; the same arithmetic as
    // surface_at's position, so a point that did not move gives exactly s.position.
    vec3 prev_world = s.position;
    if (scene.prev_positions != scene.positions || scene.prev_instances != scene.instances) {
        GpuInstance pinst = scene_prev_instance(pc.instance);
        uvec3 tri = scene_triangle(scene_geometry(pinst.geometry), in_prim);
        vec3 w = vec3(1.0 - bary.x - bary.y, bary.x, bary.y);
        vec3 p = w.x * scene_prev_position(tri.x) + w.y * scene_prev_position(tri.y) +
                 w.z * scene_prev_position(tri.z);
        prev_world = (pinst.object_to_world * vec4(p, 1.0)).xyz;
    }
    vec4 prev = frame.prev_view_proj * vec4(prev_world, 1.0);
    vec2 prev_px = (prev.xy / prev.w * 0.5 + 0.5) * vec2(frame.width, frame.height);
    g_bary = vec4(bary, prev_px - (gl_FragCoord.xy + frame.jitter));
}
