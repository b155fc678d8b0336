// trace_closest/trace_any on rqr's two-level BVH (src/accel/bvh.rs). Included by trace.glsl
// under RAY_BACKEND_BVH, after scene.glsl. Semantics equal trace_rayquery.glsl: hits count
// when tmin <= t <= tmax, t in units of dir, alpha MASK through alpha_accepts(),
// barycentrics (b1, b2) of vertices 1 and 2 in the original index order.
//
// Traversal: one explicit stack for both levels. A top-level leaf (an instance) switches the
// ray to object space and remembers the stack height; popping back to that height switches
// it back. Each inner node holds both children's boxes: both are slab-tested, the nearer hit
// child is visited next and the farther one pushed.
#include "bvh_layout.glsl"

// Direction components smaller than this are clamped (keeping their sign) before 1/d so that
// inv_dir and o_times_inv stay finite; equals cpu::MIN_DIR_COMPONENT.
#define BVH_MIN_DIR 1e-20

struct BvhRay {
    vec3 origin;
    vec3 inv_dir;     // 1 / dir
    vec3 o_times_inv; // -origin * inv_dir: each slab plane is one fma(p, inv_dir, o_times_inv)
    bvec3 neg;        // dir < 0: the near plane is the box max on that axis
    ivec3 k;          // watertight test axes (kx, ky, kz), kz = dominant axis of dir
    vec3 shear;       // (dir[kx] / dir[kz], dir[ky] / dir[kz], 1 / dir[kz])
};

float bvh_safe_component(float x) {
    return abs(x) < BVH_MIN_DIR ? ((floatBitsToUint(x) & 0x80000000u) != 0u ? -BVH_MIN_DIR : BVH_MIN_DIR) : x;
}

BvhRay bvh_make_ray(vec3 origin, vec3 dir) {
    BvhRay r;
    r.origin = origin;
    r.inv_dir = 1.0 / vec3(bvh_safe_component(dir.x), bvh_safe_component(dir.y), bvh_safe_component(dir.z));
    r.o_times_inv = -origin * r.inv_dir;
    r.neg = lessThan(r.inv_dir, vec3(0.0));
    vec3 a = abs(dir);
    int kz = (a.x >= a.y && a.x >= a.z) ? 0 : (a.y >= a.z ? 1 : 2);
    int kx = kz == 2 ? 0 : kz + 1;
    int ky = kx == 2 ? 0 : kx + 1;
    // Keeps the projected winding independent of the sign of the dominant component.
    if (dir[kz] < 0.0) {
        int tmp = kx;
        kx = ky;
        ky = tmp;
    }
    r.k = ivec3(kx, ky, kz);
    r.shear = vec3(dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]);
    return r;
}

// Slab test of one box against [tmin, tmax]: near/far planes are picked by the sign of the
// direction, so an inverted (empty) box never hits. `entry` orders the children.
bool bvh_slab(BvhRay r, vec3 bmin, vec3 bmax, float tmin, float tmax, out float entry) {
    vec3 tnear = fma(mix(bmin, bmax, r.neg), r.inv_dir, r.o_times_inv);
    vec3 tfar = fma(mix(bmax, bmin, r.neg), r.inv_dir, r.o_times_inv);
    entry = max(max(tnear.x, tnear.y), max(tnear.z, tmin));
    float exit_ = min(min(tfar.x, tfar.y), min(tfar.z, tmax));
    return entry <= exit_;
}

// a * b - c * d with a correctly signed result (Kahan's algorithm; needs a fused fma): the
// fallback of the watertight test where the plain product difference rounds to zero.
float bvh_diff_of_products(float a, float b, float c, float d) {
    precise float cd = c * d;
    precise float err = fma(-c, d, cd);
    precise float dop = fma(a, b, -cd);
    return dop + err;
}

vec3 bvh_permute(vec3 v, ivec3 k) { return vec3(v[k.x], v[k.y], v[k.z]); }

// Watertight ray/triangle test (Woop, Benthin, Wald 2013). The vertices are translated to the
// ray origin, permuted so the ray runs along +z, and sheared so it becomes the z axis; the 2D
// edge functions U, V, W then decide the hit. Two triangles sharing an edge evaluate that
// edge's function on bit-identical inputs (exact vertex copies, same ray constants) and
// `precise` forbids fma contraction, so their values are exact negatives and a ray through
// the edge is inside at least one of them; zeros are re-evaluated with a correct sign.
bool bvh_intersect_triangle(BvhRay r, BvhTriangle tri, float tmin, float tmax, out float t, out vec2 bary) {
    precise vec3 a = bvh_permute(tri.v0 - r.origin, r.k);
    precise vec3 b = bvh_permute(tri.v1 - r.origin, r.k);
    precise vec3 c = bvh_permute(tri.v2 - r.origin, r.k);
    precise float ax = a.x - r.shear.x * a.z;
    precise float ay = a.y - r.shear.y * a.z;
    precise float bx = b.x - r.shear.x * b.z;
    precise float by = b.y - r.shear.y * b.z;
    precise float cx = c.x - r.shear.x * c.z;
    precise float cy = c.y - r.shear.y * c.z;
    precise float u = cx * by - cy * bx;
    precise float v = ax * cy - ay * cx;
    precise float w = bx * ay - by * ax;
    if (u == 0.0 || v == 0.0 || w == 0.0) {
        u = bvh_diff_of_products(cx, by, cy, bx);
        v = bvh_diff_of_products(ax, cy, ay, cx);
        w = bvh_diff_of_products(bx, ay, by, ax);
    }
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) {
        return false;
    }
    float det = u + v + w;
    if (det == 0.0) {
        return false;
    }
    float sz = r.shear.z;
    float scaled_t = u * (sz * a.z) + v * (sz * b.z) + w * (sz * c.z);
    float rcp = 1.0 / det;
    t = scaled_t * rcp;
    bary = vec2(v, w) * rcp;
    // Written so that NaN (a degenerate ray) fails.
    return t >= tmin && t <= tmax;
}

vec3 bvh_transform(BvhInstance inst, vec3 p, float w) {
    vec4 q = vec4(p, w);
    return vec3(dot(inst.world_to_object[0], q), dot(inst.world_to_object[1], q), dot(inst.world_to_object[2], q));
}

#ifdef BVH_STATS
// Per-invocation traversal counters for benchmarks (compile with -DBVH_STATS).
uint bvh_stat_nodes = 0u;
uint bvh_stat_tris = 0u;
uint bvh_stat_iters = 0u;
#define BVH_COUNT(x) x++
#else
#define BVH_COUNT(x)
#endif

#define BVH_LINK_POP 0xFFFFFFFFu
#define BVH_NO_BLAS 0xFFFFFFFFu

// Both queries: any_hit returns at the first accepted hit.
//
// The loop is a two-stage pipeline so that SIMD lanes (a CPU Vulkan's vector lanes, a GPU's
// subgroup) keep doing the same kind of work: every iteration, each lane tests at most one
// pending triangle (the triangle unit) and advances its node walk by one step (the node unit).
// A bottom-level leaf hands its triangle range to the triangle unit and the walk goes on; the
// walk only waits when it reaches another leaf, an instance change or the end while triangles
// are still pending (those belong to the current object-space ray).
Hit bvh_traverse(vec3 origin, vec3 dir, float tmin, float tmax, const bool any_hit) {
    Hit best = miss_hit(tmax);
    BvhRay world = bvh_make_ray(origin, dir);
    BvhRay ray = world;
    uint stack[BVH_STACK_SIZE];
    float tstack[BVH_STACK_SIZE]; // entry distance of each pushed child
    uint sp = 0u;
    // Stack height when the current bottom level was entered; BVH_NO_BLAS in the top level.
    uint blas_sp = BVH_NO_BLAS;
    uint inst = 0u;
    uint inst_flags = 0u;
    uint link = bvh.tlas_root; // next node or leaf to visit; BVH_LINK_POP: take the stack top
    uint tri = 0u;             // pending triangles [tri, tri_end) of the current leaf
    uint tri_end = 0u;

    while (true) {
        BVH_COUNT(bvh_stat_iters);
        // Triangle unit.
        if (tri < tri_end) {
            BVH_COUNT(bvh_stat_tris);
            BvhTriangle tv = bvh_load_triangle(tri);
            float t;
            vec2 bary;
            if (bvh_intersect_triangle(ray, tv, tmin, best.t, t, bary)) {
                if ((inst_flags & BVH_INSTANCE_ALPHA_TEST) == 0u || alpha_accepts(inst, tv.primitive, bary)) {
                    best.t = t;
                    best.instance = int(inst);
                    best.primitive = int(tv.primitive);
                    best.barycentrics = bary;
                    if (any_hit) {
                        return best;
                    }
                }
            }
            tri++;
        }
        // Node unit.
        if ((link & BVH_LINK_LEAF) == 0u) {
            BVH_COUNT(bvh_stat_nodes);
            BvhNode n = bvh_load_node(link);
            float t0, t1;
            bool h0 = bvh_slab(ray, n.min0, n.max0, tmin, best.t, t0);
            bool h1 = bvh_slab(ray, n.min1, n.max1, tmin, best.t, t1);
            if (h0 && h1) {
                bool first0 = t0 <= t1;
                // The stack bound is checked on the host (BvhError::TooDeep); the guard only
                // keeps a corrupt BVH from writing out of bounds.
                if (sp < BVH_STACK_SIZE) {
                    tstack[sp] = first0 ? t1 : t0;
                    stack[sp++] = first0 ? n.link1 : n.link0;
                }
                link = first0 ? n.link0 : n.link1;
            } else {
                link = h0 ? n.link0 : (h1 ? n.link1 : BVH_LINK_POP);
            }
        } else if (link != BVH_LINK_POP) {
            if (blas_sp == BVH_NO_BLAS) {
                // Top-level leaf: enter the instance's bottom level in object space. t keeps
                // its meaning because dir is transformed without renormalising.
                inst = link & BVH_LINK_FIRST_MASK;
                BvhInstance bi = bvh_load_instance(inst);
                ray = bvh_make_ray(bvh_transform(bi, origin, 1.0), bvh_transform(bi, dir, 0.0));
                inst_flags = bi.flags;
                blas_sp = sp;
                link = bi.blas_root;
            } else if (tri >= tri_end) {
                tri = link & BVH_LINK_FIRST_MASK;
                tri_end = tri + ((link >> BVH_LINK_COUNT_SHIFT) & 15u) + 1u;
                link = BVH_LINK_POP;
            }
        }
        if (link == BVH_LINK_POP) {
            bool drained = tri >= tri_end;
            if (sp == blas_sp && drained) {
                // The bottom level is exhausted: back to the world-space ray.
                ray = world;
                blas_sp = BVH_NO_BLAS;
            }
            if (sp != blas_sp) {
                if (sp > 0u) {
                    // Entries farther than the closest hit so far are dropped without a load.
                    --sp;
                    if (tstack[sp] <= best.t) {
                        link = stack[sp];
                    }
                } else if (drained) {
                    break;
                }
            }
        }
    }
    return best;
}

Hit trace_closest(vec3 origin, vec3 dir, float tmin, float tmax) {
    return bvh_traverse(origin, dir, tmin, tmax, false);
}

bool trace_any(vec3 origin, vec3 dir, float tmin, float tmax) {
    return hit_found(bvh_traverse(origin, dir, tmin, tmax, true));
}
