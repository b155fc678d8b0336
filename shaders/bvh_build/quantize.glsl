// Padding and quantization of child boxes, shared by the collapse (build) and refit passes
// so that both write nodes exactly as `BvhNode::new` in src/accel/bvh/layout.rs does.
#ifndef RQR_BVH_QUANTIZE_GLSL
#define RQR_BVH_QUANTIZE_GLSL

#include "bvh_build/build_common.glsl"

// Same padding as pad_box in builder.rs.
const float PAD_RELATIVE = 1.0 / 1048576.0;

void pad_box(inout vec3 lo, inout vec3 hi, float pad_scale) {
    precise vec3 m = max(abs(lo), abs(hi));
    precise vec3 pad = (m + vec3(pad_scale)) * PAD_RELATIVE;
    precise vec3 plo = lo - pad;
    precise vec3 phi = hi + pad;
    lo = plo;
    hi = phi;
}

// Quantization as BvhNode::new: per axis the smallest power-of-two step with 255 steps
// covering the union, planes rounded outward and verified in the traversal's arithmetic.
// Fills origin, exponents and planes of `node` for children 0..count; false when an axis
// cannot be quantized (bounds beyond ~1e38).
bool quantize_children(vec3 bmin[4], vec3 bmax[4], uint count, inout BuildNode node) {
    node.exponents = 0u;
    for (uint p = 0u; p < 6u; ++p) {
        node.planes[p] = (p & 1u) == 0u ? 0xFFFFFFFFu : 0u;
    }
    bool failed = false;
    for (uint a = 0u; a < 3u; ++a) {
        float lo = bmin[0][a];
        float hi = bmax[0][a];
        for (uint k = 1u; k < count; ++k) {
            lo = min(lo, bmin[k][a]);
            hi = max(hi, bmax[k][a]);
        }
        node.origin[a] = lo;
        precise float extent = hi - lo;
        int e = extent > 0.0 ? int(ceil(log2(extent / 255.0))) : -126;
        e = clamp(e, -126, 127);
        uint qlo[4];
        uint qhi[4];
        bool ok = false;
        for (int attempt = 0; attempt < 8 && !ok && e <= 127; ++attempt) {
            float scale = uintBitsToFloat(uint(e + 127) << 23);
            ok = true;
            for (uint k = 0u; k < count; ++k) {
                float cmin = bmin[k][a];
                float cmax = bmax[k][a];
                int q0 = clamp(int(floor((cmin - lo) / scale)), 0, 255);
                while (q0 > 0) {
                    precise float d = lo + float(q0) * scale;
                    if (d <= cmin) {
                        break;
                    }
                    q0 -= 1;
                }
                int q1 = clamp(int(ceil((cmax - lo) / scale)), 0, 256);
                while (q1 <= 255) {
                    precise float d = lo + float(q1) * scale;
                    if (d >= cmax) {
                        break;
                    }
                    q1 += 1;
                }
                precise float d0 = lo + float(q0) * scale;
                if (q1 > 255 || d0 > cmin) {
                    ok = false;
                    break;
                }
                qlo[k] = uint(q0);
                qhi[k] = uint(q1);
            }
            if (!ok) {
                e += 1;
            }
        }
        if (!ok) {
            failed = true;
            continue;
        }
        node.exponents |= uint(e + 127) << (8u * a);
        for (uint k = 0u; k < count; ++k) {
            uint shift = 8u * k;
            node.planes[2u * a] = (node.planes[2u * a] & ~(255u << shift)) | (qlo[k] << shift);
            node.planes[2u * a + 1u] = (node.planes[2u * a + 1u] & ~(255u << shift)) | (qhi[k] << shift);
        }
    }
    return !failed;
}

#endif
