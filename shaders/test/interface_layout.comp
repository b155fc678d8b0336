#version 460
// Layout check of the generated interface structs (src/interface): reads the Frame uniform,
// every push-constant struct from a std430 block (the push-constant layout) and every buffer
// record from a scalar block, and writes each field in declaration order as 32-bit words
// (put_<Struct>, generated under RQR_LAYOUT_PUT). tests/layout.rs compares with the repr(C)
// bytes Rust wrote.
#extension GL_EXT_scalar_block_layout : require

layout(local_size_x = 1) in;
layout(set = 0, binding = 6, std430) writeonly buffer Out { uint words[]; };
uint n = 0u;
void put(uint v) { words[n++] = v; }
void puti(int v) { put(uint(v)); }
void putf(float v) { put(floatBitsToUint(v)); }
void put2(vec2 v) { putf(v.x); putf(v.y); }
void put3(vec3 v) { putf(v.x); putf(v.y); putf(v.z); }
void put4(vec4 v) { putf(v.x); putf(v.y); putf(v.z); putf(v.w); }
void putm(mat4 m) { for (int c = 0; c < 4; ++c) put4(m[c]); }
void putu2(uvec2 v) { put(v.x); put(v.y); }
void putu3(uvec3 v) { put(v.x); put(v.y); put(v.z); }
void putu4(uvec4 v) { put(v.x); put(v.y); put(v.z); put(v.w); }
void puti2(ivec2 v) { puti(v.x); puti(v.y); }
void puti3(ivec3 v) { puti(v.x); puti(v.y); puti(v.z); }
void puti4(ivec4 v) { puti(v.x); puti(v.y); puti(v.z); puti(v.w); }

#define RQR_LAYOUT_PUT
#include "frame.glsl"
#include "interface_passes.glsl"
#include "interface_reproject.glsl"

layout(set = 0, binding = 4, std430) readonly buffer Pushes {
    RaytracePush raytrace;
    HybridPush hybrid;
    DrawPush draw;
    RasterPush raster;
    TonemapPush tonemap;
    RaybenchPush raybench;
    ReprojectPush reproject;
    VisibilityPush visibility;
    TracePush trace;
} pushes;

layout(set = 0, binding = 5, scalar) readonly buffer Records {
    Aov aov;
    RasterDraw raster_draw;
    CacheEntry cache_entry;
    Shown shown;
    GpuParams params;
} records;

void main() {
    put_GpuFrame(frame);
    put_RaytracePush(pushes.raytrace);
    put_HybridPush(pushes.hybrid);
    put_DrawPush(pushes.draw);
    put_RasterPush(pushes.raster);
    put_TonemapPush(pushes.tonemap);
    put_RaybenchPush(pushes.raybench);
    put_ReprojectPush(pushes.reproject);
    put_VisibilityPush(pushes.visibility);
    put_TracePush(pushes.trace);
    put_Aov(records.aov);
    put_RasterDraw(records.raster_draw);
    put_CacheEntry(records.cache_entry);
    put_Shown(records.shown);
    put_GpuParams(records.params);
}
