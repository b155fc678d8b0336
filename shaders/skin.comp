#version 460
// Skinning and morphing of one geometry, one thread per vertex, writing this frame's vertex
// buffer. Morph targets first (rest + sum of weight x displacement), then linear blend
// skinning with up to 8 influences (JOINTS_0/WEIGHTS_0, JOINTS_1/WEIGHTS_1). Normals go
// through the blended matrix's cofactor matrix (the inverse transpose up to a positive
// scale, signed by the determinant so mirroring keeps them outward), tangents through the
// matrix itself; both renormalized. The CPU reference is `scene::pose::deform`.
#extension GL_EXT_scalar_block_layout : require
layout(local_size_x = 64) in;
#include "interface_passes.glsl"
layout(set = 0, binding = BINDING_SKIN_REST_POSITIONS, scalar) readonly buffer RestPositions { vec3 rest_positions[]; };
layout(set = 0, binding = BINDING_SKIN_REST_NORMALS, scalar) readonly buffer RestNormals { vec3 rest_normals[]; };
layout(set = 0, binding = BINDING_SKIN_REST_TANGENTS, scalar) readonly buffer RestTangents { vec4 rest_tangents[]; };
// 8 joint indices and 8 weights per vertex.
layout(set = 0, binding = BINDING_SKIN_JOINTS, scalar) readonly buffer Joints { uint joints[]; };
layout(set = 0, binding = BINDING_SKIN_WEIGHTS, scalar) readonly buffer Weights { float weights[]; };
// Displacements [attribute (position, normal, tangent)][target][vertex]; zeros where a
// target does not move an attribute.
layout(set = 0, binding = BINDING_SKIN_DELTAS, scalar) readonly buffer Deltas { vec3 deltas[]; };
layout(set = 0, binding = BINDING_SKIN_JOINT_MATRICES, scalar) readonly buffer JointMatrices { mat4 joint_matrices[]; };
layout(set = 0, binding = BINDING_SKIN_MORPH_WEIGHTS, scalar) readonly buffer MorphWeights { float morph_weights[]; };
layout(set = 0, binding = BINDING_SKIN_OUT_POSITIONS, scalar) writeonly buffer OutPositions { vec3 out_positions[]; };
layout(set = 0, binding = BINDING_SKIN_OUT_NORMALS, scalar) writeonly buffer OutNormals { vec3 out_normals[]; };
layout(set = 0, binding = BINDING_SKIN_OUT_TANGENTS, scalar) writeonly buffer OutTangents { vec4 out_tangents[]; };

layout(push_constant) uniform Push { SkinPush pc; };

vec3 normalize_or(vec3 v, vec3 fallback) {
    float l2 = dot(v, v);
    return l2 > 0.0 ? v * inversesqrt(l2) : fallback;
}

void main() {
    uint v = gl_GlobalInvocationID.x;
    if (v >= pc.count) return;
    bool tangents = (pc.flags & SKIN_TANGENTS) != 0u;
    vec3 p = rest_positions[v];
    vec3 n = rest_normals[v];
    vec4 t = tangents ? rest_tangents[v] : vec4(0.0);
    for (uint k = 0u; k < pc.targets; ++k) {
        float w = morph_weights[k];
        if (w == 0.0) continue;
        p += w * deltas[(0u * pc.targets + k) * pc.count + v];
        n += w * deltas[(1u * pc.targets + k) * pc.count + v];
        t.xyz += w * deltas[(2u * pc.targets + k) * pc.count + v];
    }
    mat4 m = mat4(1.0);
    if ((pc.flags & SKIN_SKINNED) != 0u) {
        m = mat4(0.0);
        for (uint i = 0u; i < 8u; ++i) {
            float w = weights[v * 8u + i];
            uint j = joints[v * 8u + i];
            // Zero-weight influences may carry any index.
            if (w > 0.0 && j < pc.joint_count) m += w * joint_matrices[j];
        }
    }
    mat3 m3 = mat3(m);
    mat3 cofactor = mat3(cross(m3[1], m3[2]), cross(m3[2], m3[0]), cross(m3[0], m3[1]));
    if (determinant(m3) < 0.0) cofactor = -cofactor;
    out_positions[v] = (m * vec4(p, 1.0)).xyz;
    out_normals[v] = normalize_or(cofactor * n, vec3(0.0, 0.0, 1.0));
    if (tangents) out_tangents[v] = vec4(normalize_or(m3 * t.xyz, vec3(1.0, 0.0, 0.0)), t.w);
}
