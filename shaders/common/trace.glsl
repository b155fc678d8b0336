// The one ray interface of every pass. Include after scene.glsl. Compiled per backend:
//   RAY_BACKEND_HW  -> trace_rayquery.glsl (VK_KHR_ray_query on a TLAS at set 0 binding 2)
//   RAY_BACKEND_BVH -> trace_bvh.glsl      (rqr's BVH, BvhRefs uniform at set 0 binding 2)
//
//   Hit  trace_closest(vec3 origin, vec3 dir, float tmin, float tmax);
//   bool trace_any(vec3 origin, vec3 dir, float tmin, float tmax);   // shadow rays
//
// Both honour alpha MASK through alpha_accepts() and report barycentrics (b1, b2) of
// vertices 1 and 2 like VK_KHR_ray_query. `dir` need not be unit length; t is in its units.
#ifndef RQR_TRACE_GLSL
#define RQR_TRACE_GLSL

struct Hit {
    float t;           // hit distance along dir; tmax+ on a miss
    int instance;      // -1 on a miss
    int primitive;     // triangle index within the geometry; -1 on a miss
    vec2 barycentrics; // weights of vertices 1 and 2
};

Hit miss_hit(float tmax) {
    Hit h;
    h.t = tmax;
    h.instance = -1;
    h.primitive = -1;
    h.barycentrics = vec2(0.0);
    return h;
}

bool hit_found(Hit h) { return h.instance >= 0; }

#if defined(RAY_BACKEND_HW)
#include "trace_rayquery.glsl"
#elif defined(RAY_BACKEND_BVH)
#include "trace_bvh.glsl"
#else
#error "compile with RAY_BACKEND_HW or RAY_BACKEND_BVH (// variants: hw bvh)"
#endif

// World-space geometric normal of a hit (front side = glTF front face; mirrored instances
// handled because normals go through the inverse transpose).
vec3 hit_geometric_normal(Hit h) {
    GpuInstance inst = scene_instance(uint(h.instance));
    GpuGeometry g = scene_geometry(inst.geometry);
    uvec3 tri = scene_triangle(g, uint(h.primitive));
    vec3 p0 = scene_position(tri.x), p1 = scene_position(tri.y), p2 = scene_position(tri.z);
    vec3 n = cross(p1 - p0, p2 - p0);
    return normalize(mat3(inst.normal_to_world) * n);
}

#endif
