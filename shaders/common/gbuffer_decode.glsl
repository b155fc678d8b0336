// The full G-buffer (gbuffer.frag's attachments, GBUFFER_* in src/interface/passes.rs) back into
// the Surface that surface_at() would have produced for the primary hit, for the passes that
// shade from it (hybrid shading, reprojection's tracing). Include after shade.glsl.
#ifndef RQR_GBUFFER_DECODE_GLSL
#define RQR_GBUFFER_DECODE_GLSL
#include "interface_passes.glsl"

// One pixel's G-buffer texels, in GBUFFER_* order (bary is not part of the Surface).
struct GbufferTexel {
    vec4 position;   // world position, t
    vec4 normal;     // shading normal, roughness
    vec4 geometric;  // geometric normal of the glTF front face, metallic
    vec4 base;       // base colour, alpha
    vec4 emissive;   // emissive, occlusion
    uvec4 ids;       // instance, primitive, material | front face << 31, transmission bits
};

// Whether the texel holds a hit (instance 0xFFFFFFFF: the background).
bool gbuffer_hit(uvec4 ids) { return ids.x != 0xFFFFFFFFu; }

// Fills `s` with the Surface of a G-buffer hit, its material's volume parameters and its layers
// (clearcoat, sheen, specular: surface_layers). The full G-buffer keeps no layer textures, so
// the layers get their material's factors.
void gbuffer_decode(GbufferTexel g, inout Surface s) {
    s.position = g.position.xyz;
    s.n = g.normal.xyz;
    s.roughness = g.normal.w;
    s.ng_front = g.geometric.xyz;
    s.metallic = g.geometric.w;
    s.base_color = g.base.rgb;
    s.alpha = g.base.a;
    s.emissive = g.emissive.rgb;
    s.occlusion = g.emissive.a;
    s.material = g.ids.z & 0x7FFFFFFFu;
    s.front_face = (g.ids.z >> 31) != 0u;
    s.ng = s.front_face ? s.ng_front : -s.ng_front;
    s.transmission = uintBitsToFloat(g.ids.w);
    GpuMaterial m = scene_material(s.material);
    s.ior = m.ior;
    s.atten_color = m.attenuation_color;
    s.atten_dist = m.thickness > 0.0 ? m.attenuation_distance : BIG_FLOAT;
    s.alpha_mode = m.alpha_mode;
    surface_layers(s, m);
}
#endif
