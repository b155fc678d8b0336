#version 460
// Layout check of the BVH records: reads BvhRefs, then node 1, triangle 1 and instance 1 twice:
// through the GLSL structs of bvh_layout.glsl and through the 64-bit loaders traversal uses,
// writing every field in declaration order as 32-bit words; last, whether fma() is fused.
#include "bvh_layout.glsl"

layout(local_size_x = 1) in;
layout(set = 0, binding = 3, std430) writeonly buffer Out { uint words[]; };
layout(push_constant) uniform Push { float fma_a; } pc;

layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer NodeBuf { BvhNode v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer TriangleBuf { BvhTriangle v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer InstanceBuf { BvhInstance v[]; };

uint n = 0u;
void put(uint v) { words[n++] = v; }
void putf(float v) { put(floatBitsToUint(v)); }
void put3(vec3 v) { putf(v.x); putf(v.y); putf(v.z); }
void put4(vec4 v) { putf(v.x); putf(v.y); putf(v.z); putf(v.w); }
void put64(uint64_t v) { uvec2 p = unpackUint2x32(v); put(p.x); put(p.y); }
void put_node(BvhNode v) {
    put3(v.origin); put(v.exponents);
    for (int k = 0; k < 6; ++k) put(v.planes[k]);
    for (int k = 0; k < 4; ++k) put(v.links[k]);
    put(v.reserved0); put(v.reserved1);
}
void put_tri(BvhTriangle t) { put3(t.v0); put3(t.v1); put3(t.v2); put(t.primitive); }
void put_inst(BvhInstance i) {
    put4(i.world_to_object[0]); put4(i.world_to_object[1]); put4(i.world_to_object[2]);
    put(i.blas_root); put(i.flags); put(i.geometry); put(i.pad);
}

void main() {
    put64(bvh.nodes); put64(bvh.triangles); put64(bvh.instances);
    put(bvh.node_count); put(bvh.triangle_count); put(bvh.instance_count); put(bvh.tlas_root);
    put_node(NodeBuf(bvh.nodes).v[1]);
    put_tri(TriangleBuf(bvh.triangles).v[1]);
    put_inst(InstanceBuf(bvh.instances).v[1]);
    put_node(bvh_load_node(1u));
    put_tri(bvh_load_triangle(1u));
    put_inst(bvh_load_instance(1u));
    // a * a rounds; a fused fma returns the rounding error, an unfused one returns 0.
    float a = pc.fma_a;
    precise float p = a * a;
    putf(fma(a, a, -p));
}
