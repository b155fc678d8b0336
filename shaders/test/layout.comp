#version 460
// Layout check: reads one of each scene record through scene.glsl and writes every field,
// in declaration order, as 32-bit words. The Rust test compares with the repr(C) bytes.
#include "scene.glsl"

layout(local_size_x = 1) in;
layout(set = 0, binding = 2, std430) writeonly buffer Out { uint words[]; };

uint n = 0u;
void put(uint v) { words[n++] = v; }
void putf(float v) { put(floatBitsToUint(v)); }
void put2(vec2 v) { putf(v.x); putf(v.y); }
void put3(vec3 v) { putf(v.x); putf(v.y); putf(v.z); }
void put4(vec4 v) { putf(v.x); putf(v.y); putf(v.z); putf(v.w); }
void putm(mat4 m) { for (int c = 0; c < 4; ++c) put4(m[c]); }
void put64(uint64_t v) { uvec2 p = unpackUint2x32(v); put(p.x); put(p.y); }
void put_slot(GpuTextureSlot s) { put(uint(s.texture)); put(s.tex_coord); put3(s.row0); put3(s.row1); }

void main() {
    put64(scene.positions); put64(scene.attributes); put64(scene.indices); put64(scene.geometries);
    put64(scene.instances); put64(scene.materials); put64(scene.lights);
    put(scene.instance_count); put(scene.geometry_count); put(scene.light_count); put(scene.texture_count);
    put3(scene.bounds_min); putf(scene.scene_scale); put3(scene.bounds_max); put(uint(scene.environment));
    put64(scene.prev_positions); put64(scene.prev_instances);

    GpuVertex v = scene_vertex(0u);
    put3(v.normal); put4(v.tangent); put2(v.uv0); put2(v.uv1); put4(v.color);

    GpuGeometry g = scene_geometry(0u);
    put(g.first_index); put(g.triangle_count); put(g.first_vertex); put(g.vertex_count); put(g.material); put(g.flags);

    GpuInstance i = scene_instance(0u);
    putm(i.object_to_world); putm(i.world_to_object); putm(i.normal_to_world);
    put(i.geometry); put(i.flags); put(i.pad0); put(i.pad1);

    GpuMaterial m = scene_material(0u);
    put4(m.base_color); put3(m.emissive); putf(m.metallic); putf(m.roughness); putf(m.normal_scale);
    putf(m.occlusion_strength); putf(m.alpha_cutoff); put(m.alpha_mode); put(m.double_sided);
    putf(m.transmission); putf(m.ior); putf(m.thickness); put3(m.attenuation_color); putf(m.attenuation_distance);
    for (int k = 0; k < 6; ++k) put_slot(m.textures[k]);
    putf(m.specular); put3(m.specular_color); putf(m.clearcoat); putf(m.clearcoat_roughness);
    putf(m.clearcoat_normal_scale); put3(m.sheen_color); putf(m.sheen_roughness); put(m.flags);
    for (int k = 0; k < 8; ++k) put_slot(m.ext_textures[k]);

    GpuLight l = scene_light(0u);
    put3(l.position); put(l.kind); put3(l.direction); putf(l.range); put3(l.radiance);
    putf(l.inner_cos); putf(l.outer_cos); putf(l.size); putf(l.pad1); putf(l.pad2);
}
