// Workgroup-wide exclusive prefix sum over 256 invocations (Hillis-Steele in shared memory).
#ifndef RQR_BVH_SCAN_COMMON_GLSL
#define RQR_BVH_SCAN_COMMON_GLSL

#define SCAN_GROUP 256u
#define SCAN_PER_THREAD 4u
#define SCAN_BLOCK 1024u

shared uint scan_shared[SCAN_GROUP];

// Exclusive prefix of `v` over the workgroup; `total` gets the sum of all. Every invocation
// must call it (it has barriers).
uint workgroup_exclusive_scan(uint v, out uint total) {
    uint lid = gl_LocalInvocationID.x;
    scan_shared[lid] = v;
    uint inclusive = v;
    for (uint offset = 1u; offset < SCAN_GROUP; offset <<= 1) {
        barrier();
        uint add = lid >= offset ? scan_shared[lid - offset] : 0u;
        barrier();
        inclusive += add;
        scan_shared[lid] = inclusive;
    }
    barrier();
    total = scan_shared[SCAN_GROUP - 1u];
    barrier();
    return inclusive - v;
}

#endif
