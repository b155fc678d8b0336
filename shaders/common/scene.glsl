// Scene records on the GPU; byte layout equals src/scene/layout.rs (scalar block layout).
// Set 0 (src/interface/shared.rs): BINDING_SCENE = SceneRefs uniform, BINDING_TEXTURES =
// bindless textures, BINDING_RAY_BACKEND = ray backend (TLAS for hw, BvhRefs for bvh).
// Pass-specific bindings follow BINDING_FRAME.
#ifndef RQR_SCENE_GLSL
#define RQR_SCENE_GLSL

#extension GL_EXT_buffer_reference : require
#extension GL_EXT_buffer_reference2 : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_nonuniform_qualifier : require
#include "interface_shared.glsl"

struct GpuVertex {
    vec3 normal;
    vec4 tangent;
    vec2 uv0;
    vec2 uv1;
    vec4 color;
};

struct GpuGeometry {
    uint first_index;
    uint triangle_count;
    uint first_vertex;
    uint vertex_count;
    uint material;
    uint flags;
};
#define GEOMETRY_HAS_TANGENTS 1u
#define GEOMETRY_HAS_COLORS 2u

struct GpuInstance {
    mat4 object_to_world;
    mat4 world_to_object;
    mat4 normal_to_world;
    uint geometry;
    uint flags;
    uint pad0;
    uint pad1;
};
#define INSTANCE_MIRRORED 1u

struct GpuTextureSlot {
    int texture;
    uint tex_coord;
    vec3 row0;
    vec3 row1;
};

#define ALPHA_OPAQUE 0u
#define ALPHA_MASK 1u
#define ALPHA_BLEND 2u

struct GpuMaterial {
    vec4 base_color;
    vec3 emissive;
    float metallic;
    float roughness;
    float normal_scale;
    float occlusion_strength;
    float alpha_cutoff;
    uint alpha_mode;
    uint double_sided;
    float transmission;
    float ior;
    float thickness;
    vec3 attenuation_color;
    float attenuation_distance;
    // base colour, metallic-roughness, normal, occlusion, emissive, transmission (TEX_*); the
    // same bytes as the six named slots of src/scene/layout.rs. An array so that a loop can
    // load one slot at a time from memory (see surface_at).
    GpuTextureSlot textures[6];
    // KHR_materials_specular / clearcoat / sheen (defaults without them) and the extension
    // textures (EXT_TEX_*), read only when flags has MATERIAL_EXT_TEXTURES.
    float specular;
    vec3 specular_color;
    float clearcoat;
    float clearcoat_roughness;
    float clearcoat_normal_scale;
    vec3 sheen_color;
    float sheen_roughness;
    uint flags;
    GpuTextureSlot ext_textures[8];
};
#define MATERIAL_LAYERED 1u
#define MATERIAL_EXT_TEXTURES 2u
#define EXT_TEX_SPECULAR 0
#define EXT_TEX_SPECULAR_COLOR 1
#define EXT_TEX_CLEARCOAT 2
#define EXT_TEX_CLEARCOAT_ROUGHNESS 3
#define EXT_TEX_CLEARCOAT_NORMAL 4
#define EXT_TEX_SHEEN_COLOR 5
#define EXT_TEX_SHEEN_ROUGHNESS 6
#define EXT_TEX_THICKNESS 7
#define TEX_BASE_COLOR 0
#define TEX_METALLIC_ROUGHNESS 1
#define TEX_NORMAL 2
#define TEX_OCCLUSION 3
#define TEX_EMISSIVE 4
#define TEX_TRANSMISSION 5

#define LIGHT_DIRECTIONAL 0u
#define LIGHT_POINT 1u
#define LIGHT_SPOT 2u

struct GpuLight {
    vec3 position;
    uint kind;
    vec3 direction;
    float range;
    vec3 radiance;
    float inner_cos;
    float outer_cos;
    float size;  // sphere radius, or a directional light's angular radius; 0: punctual
    float pad1;
    float pad2;
};

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer PositionBuf { vec3 v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer VertexBuf { GpuVertex v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer IndexBuf { uint v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer GeometryBuf { GpuGeometry v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer InstanceBuf { GpuInstance v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer MaterialBuf { GpuMaterial v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer LightBuf { GpuLight v[]; };

layout(set = 0, binding = BINDING_SCENE, scalar) uniform SceneRefs {
    uint64_t positions;
    uint64_t attributes;
    uint64_t indices;
    uint64_t geometries;
    uint64_t instances;
    uint64_t materials;
    uint64_t lights;
    uint instance_count;
    uint geometry_count;
    uint light_count;
    uint texture_count;
    vec3 bounds_min;
    float scene_scale;
    vec3 bounds_max;
    int environment;  // first of the environment's ENV_TEX_* textures, or -1
    // The previous frame of an animation (motion vectors): positions and instances, or the
    // same addresses as `positions` and `instances` when nothing moved.
    uint64_t prev_positions;
    uint64_t prev_instances;
} scene;

layout(set = 0, binding = BINDING_TEXTURES) uniform sampler2D textures[];

GpuInstance scene_instance(uint i) { return InstanceBuf(scene.instances).v[i]; }
GpuGeometry scene_geometry(uint i) { return GeometryBuf(scene.geometries).v[i]; }
GpuMaterial scene_material(uint i) { return MaterialBuf(scene.materials).v[i]; }
GpuLight scene_light(uint i) { return LightBuf(scene.lights).v[i]; }
vec3 scene_position(uint vertex) { return PositionBuf(scene.positions).v[vertex]; }
GpuInstance scene_prev_instance(uint i) { return InstanceBuf(scene.prev_instances).v[i]; }
vec3 scene_prev_position(uint vertex) { return PositionBuf(scene.prev_positions).v[vertex]; }
GpuVertex scene_vertex(uint vertex) { return VertexBuf(scene.attributes).v[vertex]; }

// Absolute vertex indices of triangle `prim` of geometry `g`.
uvec3 scene_triangle(GpuGeometry g, uint prim) {
    IndexBuf ib = IndexBuf(scene.indices);
    uint base = g.first_index + 3u * prim;
    return uvec3(ib.v[base], ib.v[base + 1u], ib.v[base + 2u]) + g.first_vertex;
}

// Texture coordinate set `set` interpolated at barycentrics (b1, b2).
vec2 texture_uv(GpuTextureSlot slot, vec2 uv0, vec2 uv1) {
    vec3 uv = vec3(slot.tex_coord == 1u ? uv1 : uv0, 1.0);
    return vec2(dot(slot.row0, uv), dot(slot.row1, uv));
}

// Alpha of a material at a surface point (base colour factor x texture x vertex colour),
// sampled at mip 0 so traversal-time alpha tests agree between backends and passes.
float surface_alpha(GpuMaterial m, uint instance, uint prim, vec2 bary) {
    float alpha = m.base_color.a;
    GpuGeometry g = scene_geometry(scene_instance(instance).geometry);
    uvec3 tri = scene_triangle(g, prim);
    vec3 w = vec3(1.0 - bary.x - bary.y, bary.x, bary.y);
    if ((g.flags & GEOMETRY_HAS_COLORS) != 0u) {
        alpha *= w.x * scene_vertex(tri.x).color.a + w.y * scene_vertex(tri.y).color.a + w.z * scene_vertex(tri.z).color.a;
    }
    if (m.textures[TEX_BASE_COLOR].texture >= 0 && uint(m.textures[TEX_BASE_COLOR].texture) < scene.texture_count) {
        GpuVertex a = scene_vertex(tri.x), b = scene_vertex(tri.y), c = scene_vertex(tri.z);
        vec2 uv0 = w.x * a.uv0 + w.y * b.uv0 + w.z * c.uv0;
        vec2 uv1 = w.x * a.uv1 + w.y * b.uv1 + w.z * c.uv1;
        alpha *= textureLod(textures[nonuniformEXT(m.textures[TEX_BASE_COLOR].texture)], texture_uv(m.textures[TEX_BASE_COLOR], uv0, uv1), 0.0).a;
    }
    return alpha;
}

// Whether a candidate hit on `instance`/`prim` blocks the ray: opaque and blended surfaces
// always do, alpha-masked ones where alpha >= cutoff (the same test in both backends).
bool alpha_accepts(uint instance, uint prim, vec2 bary) {
    GpuMaterial m = scene_material(scene_geometry(scene_instance(instance).geometry).material);
    if (m.alpha_mode != ALPHA_MASK) {
        return true;
    }
    return surface_alpha(m, instance, prim, bary) >= m.alpha_cutoff;
}

#endif
