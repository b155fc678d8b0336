// The test of whether a surface point remembered from an earlier frame is the surface a pixel
// sees now (ReBLUR / SVGF style), shared by temporal reuse (its cached samples) and the
// denoiser (its history): the remembered point lies on the pixel's tangent plane, within
// `plane_threshold` of the view depth `z`, and the normals agree to `normal_threshold`.
#ifndef RQR_DISOCCLUSION_GLSL
#define RQR_DISOCCLUSION_GLSL

bool surfaces_match(vec3 remembered, vec3 remembered_normal, vec3 p, vec3 n, float z,
                    float plane_threshold, float normal_threshold) {
    float plane = abs(dot(remembered - p, n)) / z;
    return plane <= plane_threshold && dot(remembered_normal, n) >= normal_threshold;
}

#endif
