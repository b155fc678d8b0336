#version 460
// Layout check of the generated interface structs (src/interface): reads the Frame uniform,
// every push-constant struct from a std430 block (the push-constant layout) and every buffer
// record from a scalar block, and writes each field in declaration order as 32-bit words
// (put_<Struct>, generated under RQR_LAYOUT_PUT). tests/layout.rs compares with the repr(C)
// bytes Rust wrote.
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

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
void put64(uint64_t v) { put(uint(v)); put(uint(v >> 32)); }

#define RQR_LAYOUT_PUT
#include "frame.glsl"
#include "interface_passes.glsl"
#include "interface_reproject.glsl"
#include "interface_bvh.glsl"

// The 64-bit structs first, so that every struct starts 8-byte aligned as in Rust.
layout(set = 0, binding = 4, std430) readonly buffer Pushes {
    BvhBuildPush bvh_build;
    BvhScanPush bvh_scan;
    BvhRelocatePush bvh_relocate;
    BvhTlasLinksPush bvh_tlas_links;
    RaytracePush raytrace;
    TonemapPush tonemap;
    HybridPush hybrid;
    DrawPush draw;
    RasterPush raster;
    RaybenchPush raybench;
    ReprojectPush reproject;
    VerifyPush verify;
    TracePush trace;
    SkinPush skin;
    TextureSamplingPush texture_sampling;
} pushes;

layout(set = 0, binding = 5, scalar) readonly buffer Records {
    GpuBvhRefs bvh_refs;
    BvhBuildRefs bvh_build_refs;
    BvhRefitRefs bvh_refit_refs;
    GpuParams params;
    Aov aov;
    RasterDraw raster_draw;
    CacheEntry cache_entry;
    Shown shown;
} records;

void main() {
    put_GpuFrame(frame);
    put_BvhBuildPush(pushes.bvh_build);
    put_BvhScanPush(pushes.bvh_scan);
    put_BvhRelocatePush(pushes.bvh_relocate);
    put_BvhTlasLinksPush(pushes.bvh_tlas_links);
    put_RaytracePush(pushes.raytrace);
    put_TonemapPush(pushes.tonemap);
    put_HybridPush(pushes.hybrid);
    put_DrawPush(pushes.draw);
    put_RasterPush(pushes.raster);
    put_RaybenchPush(pushes.raybench);
    put_ReprojectPush(pushes.reproject);
    put_VerifyPush(pushes.verify);
    put_TracePush(pushes.trace);
    put_SkinPush(pushes.skin);
    put_TextureSamplingPush(pushes.texture_sampling);
    put_GpuBvhRefs(records.bvh_refs);
    put_BvhBuildRefs(records.bvh_build_refs);
    put_BvhRefitRefs(records.bvh_refit_refs);
    put_GpuParams(records.params);
    put_Aov(records.aov);
    put_RasterDraw(records.raster_draw);
    put_CacheEntry(records.cache_entry);
    put_Shown(records.shown);
}
