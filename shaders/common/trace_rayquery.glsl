// trace_closest/trace_any on VK_KHR_ray_query. Geometry of OPAQUE materials is flagged opaque
// in the BLAS; MASK/BLEND geometry produces candidates that alpha_accepts() confirms.
#extension GL_EXT_ray_query : require

layout(set = 0, binding = BINDING_RAY_BACKEND) uniform accelerationStructureEXT tlas;

Hit trace_closest(vec3 origin, vec3 dir, float tmin, float tmax) {
    rayQueryEXT q;
    rayQueryInitializeEXT(q, tlas, gl_RayFlagsNoneEXT, 0xFF, origin, tmin, dir, tmax);
    while (rayQueryProceedEXT(q)) {
        if (rayQueryGetIntersectionTypeEXT(q, false) == gl_RayQueryCandidateIntersectionTriangleEXT) {
            uint inst = uint(rayQueryGetIntersectionInstanceCustomIndexEXT(q, false));
            uint prim = uint(rayQueryGetIntersectionPrimitiveIndexEXT(q, false));
            if (alpha_accepts(inst, prim, rayQueryGetIntersectionBarycentricsEXT(q, false))) {
                rayQueryConfirmIntersectionEXT(q);
            }
        }
    }
    if (rayQueryGetIntersectionTypeEXT(q, true) == gl_RayQueryCommittedIntersectionNoneEXT) {
        return miss_hit(tmax);
    }
    Hit h;
    h.t = rayQueryGetIntersectionTEXT(q, true);
    h.instance = rayQueryGetIntersectionInstanceCustomIndexEXT(q, true);
    h.primitive = rayQueryGetIntersectionPrimitiveIndexEXT(q, true);
    h.barycentrics = rayQueryGetIntersectionBarycentricsEXT(q, true);
    return h;
}

bool trace_any(vec3 origin, vec3 dir, float tmin, float tmax) {
    rayQueryEXT q;
    rayQueryInitializeEXT(q, tlas, gl_RayFlagsTerminateOnFirstHitEXT, 0xFF, origin, tmin, dir, tmax);
    while (rayQueryProceedEXT(q)) {
        if (rayQueryGetIntersectionTypeEXT(q, false) == gl_RayQueryCandidateIntersectionTriangleEXT) {
            uint inst = uint(rayQueryGetIntersectionInstanceCustomIndexEXT(q, false));
            uint prim = uint(rayQueryGetIntersectionPrimitiveIndexEXT(q, false));
            if (alpha_accepts(inst, prim, rayQueryGetIntersectionBarycentricsEXT(q, false))) {
                rayQueryConfirmIntersectionEXT(q);
            }
        }
    }
    return rayQueryGetIntersectionTypeEXT(q, true) != gl_RayQueryCommittedIntersectionNoneEXT;
}
