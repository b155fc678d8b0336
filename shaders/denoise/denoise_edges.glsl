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

EdgeCentre edge_centre(uint i) {
    Aov a = Aovs(params.aov).v[i];
    EdgeCentre c;
    c.hit = a.instance != AOV_NO_ID;
    c.position = a.position.xyz;
    c.normal = a.normal_depth.xyz;
    return c;
}

// Weight of neighbour j from the centre's geometry (0 for a miss on either side).
float geometry_weight(EdgeCentre c, uint j) {
    Aov a = Aovs(params.aov).v[j];
    if (!c.hit || a.instance == AOV_NO_ID) {
        return 0.0;
    }
    float w_normal = pow(max(dot(c.normal, a.normal_depth.xyz), 0.0), params.phi_normal);
    vec3 offset = a.position.xyz - c.position;
    float off_plane = abs(dot(offset, c.normal)) / max(length(offset), 1e-12);
    float w_plane = exp(-off_plane / params.phi_plane);
    return w_normal * w_plane;
}

#endif
