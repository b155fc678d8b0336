// Denoising: the edge-stopping weights of the spatial passes (SVGF's, with a plane test for
// depth): a neighbour counts by how well its normal agrees (dot^phi_normal) and by how far it
// lies off the pixel's tangent plane relative to its distance from the pixel (so a flat
// surface seen at a grazing angle keeps its weight and a step in depth loses it).
#ifndef RQR_DENOISE_EDGES_GLSL
#define RQR_DENOISE_EDGES_GLSL

struct EdgeCentre {
    bool hit;
    vec3 position;
    vec3 normal;
};

// The pixel's edge texel (written by the temporal pass: 16 bytes, where the AOV is 80).
EdgeCentre edge_centre(uint i) {
    vec4 e = Vec4s(params.edges).v[i];
    EdgeCentre c;
    uint bits = floatBitsToUint(e.w);
    c.hit = bits != EDGE_MISS;
    c.position = e.xyz;
    c.normal = c.hit ? decode_normal(bits) : vec3(0.0);
    return c;
}

// x^128 by squaring (128: Falcor's φ_normal, the normal edge-stopping exponent; a CPU device's
// pow is far slower).
float pow128(float x) {
    x *= x; x *= x; x *= x; x *= x; x *= x; x *= x; x *= x;
    return x;
}

// The geometry weight of neighbour j apart: the normal's factor (returned; 0 for a miss on
// either side) and the plane test's exponent (its factor is exp(-plane)), so that a caller
// with an exponent of its own pays one exp for both.
float geometry_terms(EdgeCentre c, uint j, out float plane) {
    plane = 0.0;
    EdgeCentre q = edge_centre(j);
    if (!c.hit || !q.hit) {
        return 0.0;
    }
    vec3 offset = q.position - c.position;
    plane = abs(dot(offset, c.normal)) * inversesqrt(max(dot(offset, offset), 1e-24)) / params.phi_plane;
    return pow128(max(dot(c.normal, q.normal), 0.0));
}

// Weight of neighbour j from the centre's geometry (0 for a miss on either side).
float geometry_weight(EdgeCentre c, uint j) {
    float plane;
    float w_normal = geometry_terms(c, j, plane);
    return w_normal > 0.0 ? w_normal * exp(-plane) : 0.0;
}

#endif
