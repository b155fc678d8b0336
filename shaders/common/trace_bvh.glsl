// trace_closest/trace_any on rqr's two-level BVH (src/accel/bvh.rs). Included by trace.glsl
// under RAY_BACKEND_BVH, after scene.glsl. Semantics equal trace_rayquery.glsl: hits count
// when tmin <= t <= tmax, t in units of dir, alpha MASK through alpha_accepts(),
// barycentrics (b1, b2) of vertices 1 and 2 in the original index order.
//
// Traversal: one explicit stack for both levels. A top-level leaf (an instance) switches the
// ray to object space and remembers the stack height; popping back to that height switches
// it back. Each 4-wide node holds its children's quantized boxes: all are slab-tested, the
// nearest hit child is visited next and the others are pushed with their entry distances
// (popped entries beyond the closest hit so far are dropped without a node load).
#include "bvh_layout.glsl"

// Direction components smaller than this are clamped (keeping their sign) before 1/d so that
// inv_dir and o_times_inv stay finite; equals cpu::MIN_DIR_COMPONENT.
#define BVH_MIN_DIR 1e-20

struct BvhRay {
    vec3 origin;
    vec3 inv_dir;     // 1 / dir
    vec3 o_times_inv; // -origin * inv_dir: a plane p is at t = fma(p, inv_dir, o_times_inv)
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

// a * b - c * d, re-evaluated where the watertight test's plain difference rounds to zero.
// With a fused fma (GPUs) Kahan's algorithm gives the correctly signed value. Where fma() is a
// multiply and an add (lavapipe; tests/bvh_gpu.rs reports which) it degenerates to the plain
// difference, which keeps the test watertight all the same: a non-zero plain difference always
// has the right sign and zero counts as inside; only the tie-break on the edge itself is lost.
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

#define BVH_MISS 3.0e38

// Entry distance of child `shift / 8` of node `n`, or BVH_MISS. Near and far planes are picked
// by the sign of the direction, so an unused slot (inverted box) never hits.
float bvh_child_entry(BvhRay r, BvhNode n, uint shift, vec3 a, vec3 b, float tmin, float tmax) {
    vec3 qlo = vec3((uvec3(n.planes[0], n.planes[2], n.planes[4]) >> shift) & 255u);
    vec3 qhi = vec3((uvec3(n.planes[1], n.planes[3], n.planes[5]) >> shift) & 255u);
    vec3 tnear = fma(mix(qlo, qhi, r.neg), a, b);
    vec3 tfar = fma(mix(qhi, qlo, r.neg), a, b);
    float entry = max(max(tnear.x, tnear.y), max(tnear.z, tmin));
    float exit_ = min(min(tfar.x, tfar.y), min(tfar.z, tmax));
    return entry <= exit_ ? entry : BVH_MISS;
}

#define BVH_CSWAP(ka, la, kb, lb) \
    { bool s_ = kb < ka; float tk_ = ka; uint tl_ = la; \
      ka = s_ ? kb : ka; la = s_ ? lb : la; kb = s_ ? tk_ : kb; lb = s_ ? tl_ : lb; }

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
            // Ray in the node's quantization frame: each plane is one fma(q, a, b).
            vec3 scale = uintBitsToFloat((uvec3(n.exponents, n.exponents >> 8, n.exponents >> 16) & 255u) << 23);
            vec3 a = scale * ray.inv_dir;
            vec3 b = fma(n.origin, ray.inv_dir, ray.o_times_inv);
            float k0 = bvh_child_entry(ray, n, 0u, a, b, tmin, best.t);
            float k1 = bvh_child_entry(ray, n, 8u, a, b, tmin, best.t);
            float k2 = bvh_child_entry(ray, n, 16u, a, b, tmin, best.t);
            float k3 = bvh_child_entry(ray, n, 24u, a, b, tmin, best.t);
            uint l0 = n.links[0], l1 = n.links[1], l2 = n.links[2], l3 = n.links[3];
            // Sorting network: nearest hit first, misses (BVH_MISS) last.
            BVH_CSWAP(k0, l0, k1, l1);
            BVH_CSWAP(k2, l2, k3, l3);
            BVH_CSWAP(k0, l0, k2, l2);
            BVH_CSWAP(k1, l1, k3, l3);
            BVH_CSWAP(k1, l1, k2, l2);
            // Farther hits are pushed farthest first, so the stack pops them in order. The
            // stack bound is checked on the host (BvhError::TooDeep); the guard only keeps a
            // corrupt BVH from writing out of bounds.
            if (k3 < BVH_MISS && sp < BVH_STACK_SIZE) {
                tstack[sp] = k3;
                stack[sp++] = l3;
            }
            if (k2 < BVH_MISS && sp < BVH_STACK_SIZE) {
                tstack[sp] = k2;
                stack[sp++] = l2;
            }
            if (k1 < BVH_MISS && sp < BVH_STACK_SIZE) {
                tstack[sp] = k1;
                stack[sp++] = l1;
            }
            link = k0 < BVH_MISS ? l0 : BVH_LINK_POP;
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
