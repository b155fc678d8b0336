#version 460
// Layout check of the BVH records: reads BvhRefs, one BvhNode, BvhTriangle, BvhInstance and
// primitive through bvh_layout.glsl and writes every field in declaration order as 32-bit
// words; then whether fma() is fused on this device (the watertight fallback needs it).
#include "bvh_layout.glsl"

layout(local_size_x = 1) in;
layout(set = 0, binding = 3, std430) writeonly buffer Out { uint words[]; };
layout(push_constant) uniform Push { float fma_a; } pc;

uint n = 0u;
void put(uint v) { words[n++] = v; }
void putf(float v) { put(floatBitsToUint(v)); }
void put3(vec3 v) { putf(v.x); putf(v.y); putf(v.z); }
void put4(vec4 v) { putf(v.x); putf(v.y); putf(v.z); putf(v.w); }
void put64(uint64_t v) { uvec2 p = unpackUint2x32(v); put(p.x); put(p.y); }
void put_child(BvhChild c) { put3(c.bmin); put(c.link); put3(c.bmax); put(c.prim_count); }

void main() {
    put64(bvh.nodes); put64(bvh.triangles); put64(bvh.primitives); put64(bvh.instances);
    put(bvh.node_count); put(bvh.triangle_count); put(bvh.instance_count); put(bvh.tlas_root);
    BvhNode node = BvhNodeBuf(bvh.nodes).v[1];
    put_child(node.c0); put_child(node.c1);
    BvhTriangle tri = BvhTriangleBuf(bvh.triangles).v[1];
    put3(tri.v0); put3(tri.v1); put3(tri.v2);
    BvhInstance inst = BvhInstanceBuf(bvh.instances).v[1];
    put4(inst.world_to_object[0]); put4(inst.world_to_object[1]); put4(inst.world_to_object[2]);
    put(inst.blas_root); put(inst.flags); put(inst.geometry); put(inst.pad);
    put(BvhPrimitiveBuf(bvh.primitives).v[1]);
    // a * a rounds; a fused fma returns the rounding error, an unfused one returns 0.
    float a = pc.fma_a;
    precise float p = a * a;
    putf(fma(a, a, -p));
}
