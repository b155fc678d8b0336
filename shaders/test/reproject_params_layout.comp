#version 460
// Layout check of temporal reuse's Params uniform as its passes see it
// (shaders/temporal/buffers.glsl): writes every field, in declaration order, as 32-bit words.
// tests/layout.rs compares with the bytes of src/interface/reproject.rs's GpuParams.
#extension GL_GOOGLE_include_directive : require
#include "scene.glsl"
#include "frame.glsl"
#include "temporal/temporal.glsl"

layout(local_size_x = 1) in;
layout(set = 0, binding = 31, std430) writeonly buffer Out { uint words[]; };
uint n = 0u;
void put(uint v) { words[n++] = v; }
void putf(float v) { put(floatBitsToUint(v)); }
void put64(uint64_t v) { put(uint(v)); put(uint(v >> 32)); }

void main() {
    put(params.flags); put(params.max_age); putf(params.frameless_fraction);
    putf(params.subsample_threshold); put(params.tonemap_op); putf(params.plane_threshold);
    putf(params.normal_threshold); putf(params.edge_threshold); putf(params.specular_metallic);
    putf(params.specular_roughness); putf(params.fill_radius); put(params.max_hops);
    putf(params.tonemap_scale); put(params.pad0);
    put64(params.cache_prev); put64(params.cache_next); put64(params.key_winner); put64(params.states);
    put64(params.colors); put64(params.display); put64(params.shown); put64(params.jobs);
    put64(params.anchors_prev); put64(params.anchors_next);
}
