#version 460
// Copies one deformed geometry's skinned/morphed vertices (the output of skin.comp) into the
// scene's vertex buffers, one thread per vertex: positions into the tightly packed `vec3`
// position buffer (also the hw BLAS input), normals and tangents into the interleaved
// `GpuVertex` attributes (normal vec3, tangent vec4, uv0 vec2, uv1 vec2, color vec4 =
// 15 floats), leaving texture coordinates and colours untouched.
#extension GL_EXT_scalar_block_layout : require
layout(local_size_x = 64) in;
layout(set = 0, binding = 0, scalar) readonly buffer SkinnedPositions { vec3 skinned_positions[]; };
layout(set = 0, binding = 1, scalar) readonly buffer SkinnedNormals { vec3 skinned_normals[]; };
layout(set = 0, binding = 2, scalar) readonly buffer SkinnedTangents { vec4 skinned_tangents[]; };
layout(set = 0, binding = 3, scalar) writeonly buffer ScenePositions { float scene_positions[]; };
layout(set = 0, binding = 4, scalar) buffer SceneAttributes { float scene_attributes[]; };

const uint VERTEX_FLOATS = 15u;

layout(push_constant) uniform Push {
    uint first_vertex;
    uint count;
    uint has_tangents;
    uint pad;
} pc;

void main() {
    uint v = gl_GlobalInvocationID.x;
    if (v >= pc.count) return;
    uint s = pc.first_vertex + v;
    vec3 p = skinned_positions[v];
    scene_positions[s * 3u + 0u] = p.x;
    scene_positions[s * 3u + 1u] = p.y;
    scene_positions[s * 3u + 2u] = p.z;
    vec3 n = skinned_normals[v];
    uint a = s * VERTEX_FLOATS;
    scene_attributes[a + 0u] = n.x;
    scene_attributes[a + 1u] = n.y;
    scene_attributes[a + 2u] = n.z;
    if (pc.has_tangents != 0u) {
        vec4 t = skinned_tangents[v];
        scene_attributes[a + 3u] = t.x;
        scene_attributes[a + 4u] = t.y;
        scene_attributes[a + 5u] = t.z;
        scene_attributes[a + 6u] = t.w;
    }
}
