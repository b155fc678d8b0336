// variants: hw bvh
#version 460
// Ray throughput benchmark (benches/bvh.rs). mode 0: primary rays of a pinhole camera at
// `eye` looking at the origin (pixel centres), closest hit written per pixel. mode 1: one
// cosine-weighted bounce from each primary hit (incoherent rays), closest hit.
#include "scene.glsl"
#include "trace.glsl"
#include "interface_passes.glsl"

// Workgroup shape (experiments compile other shapes with glslc -D, see benches/bvh.rs --wg).
#ifndef BENCH_WG_X
#define BENCH_WG_X 8
#define BENCH_WG_Y 8
#endif
layout(local_size_x = BENCH_WG_X, local_size_y = BENCH_WG_Y) in;

layout(set = 0, binding = BINDING_BENCH_PRIMARY, scalar) buffer Primary { BenchHit hits[]; };
layout(set = 0, binding = BINDING_BENCH_BOUNCE, scalar) writeonly buffer Bounce { BenchHit bounce[]; };
layout(push_constant, scalar) uniform Push { BenchPush pc; };

uint pcg(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

float rnd(inout uint s) {
    s = pcg(s);
    return float(s >> 8) * (1.0 / 16777216.0);
}

void main() {
    uvec2 px = gl_GlobalInvocationID.xy;
    if (px.x >= pc.width || px.y >= pc.height) {
        return;
    }
    uint index = px.y * pc.width + px.x;
    if (pc.mode == 0u) {
        vec3 forward = normalize(-pc.eye);
        vec3 right = normalize(cross(forward, vec3(0.0, 1.0, 0.0)));
        vec3 up = cross(right, forward);
        float aspect = float(pc.width) / float(pc.height);
        float u = (2.0 * (float(px.x) + 0.5) / float(pc.width) - 1.0) * pc.tan_half_fov * aspect;
        float v = (1.0 - 2.0 * (float(px.y) + 0.5) / float(pc.height)) * pc.tan_half_fov;
        vec3 dir = normalize(forward + u * right + v * up);
        Hit h = trace_closest(pc.eye, dir, 0.0, 1e30);
        hits[index].t = h.t;
        hits[index].instance = h.instance;
        hits[index].primitive = h.primitive;
        hits[index].origin = pc.eye;
        hits[index].dir = dir;
#ifdef BVH_STATS
        hits[index].pad = float(bvh_stat_nodes);
        hits[index].pad2 = float(bvh_stat_tris);
        hits[index].pad3 = float(bvh_stat_iters);
#endif
    } else {
        BenchHit prev = hits[index];
        if (prev.instance < 0) {
            return;
        }
        Hit ph;
        ph.t = prev.t;
        ph.instance = prev.instance;
        ph.primitive = prev.primitive;
        ph.barycentrics = vec2(0.0);
        vec3 n = hit_geometric_normal(ph);
        if (dot(n, prev.dir) > 0.0) {
            n = -n;
        }
        vec3 p = prev.origin + prev.t * prev.dir + n * (1e-4 * scene.scene_scale);
        uint s = index ^ (pc.seed * 0x9E3779B9u);
        float r1 = rnd(s), r2 = rnd(s);
        float phi = 6.28318530718 * r1;
        float sr = sqrt(r2);
        vec3 t = normalize(abs(n.x) > 0.5 ? cross(n, vec3(0.0, 1.0, 0.0)) : cross(n, vec3(1.0, 0.0, 0.0)));
        vec3 b = cross(n, t);
        vec3 dir = normalize(sr * cos(phi) * t + sr * sin(phi) * b + sqrt(max(0.0, 1.0 - r2)) * n);
        Hit h = trace_closest(p, dir, 0.0, 1e30);
        bounce[index].t = h.t;
        bounce[index].instance = h.instance;
        bounce[index].primitive = h.primitive;
        bounce[index].origin = p;
        bounce[index].dir = dir;
#ifdef BVH_STATS
        bounce[index].pad = float(bvh_stat_nodes);
        bounce[index].pad2 = float(bvh_stat_tris);
        bounce[index].pad3 = float(bvh_stat_iters);
#endif
    }
}
