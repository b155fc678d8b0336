// Statistics counters (rays by kind, samples) summed per subgroup, then one atomic per
// subgroup: a CPU Vulkan (lavapipe) runs the invocations of a workgroup on different cores, and
// one atomic per invocation on the same cache line costs as much as shading a pixel.
#ifndef RQR_COUNTERS_GLSL
#define RQR_COUNTERS_GLSL
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "interface_shared.glsl"

// Striped counters: runs of consecutive workgroups share a copy (a stripe), so on a CPU device,
// whose threads each run a contiguous range of workgroups, the threads count on different cache
// lines. Runs are a power of two long (shifts, not divisions: a CPU device divides lane by
// lane), so that at most `stripes` (a power of two) of them cover the dispatch.
uint workgroup_count() { return gl_NumWorkGroups.x * gl_NumWorkGroups.y * gl_NumWorkGroups.z; }
uint workgroup_index() { return (gl_WorkGroupID.z * gl_NumWorkGroups.y + gl_WorkGroupID.y) * gl_NumWorkGroups.x + gl_WorkGroupID.x; }
// The invocation's number in a one-dimensional dispatch laid out in rows of workgroups
// (GROUPS_PER_ROW; `rqr::vk::rows_of_groups`), for one-dimensional workgroups of
// `group_size` invocations.
uint linear_invocation(uint group_size) { return workgroup_index() * group_size + gl_LocalInvocationIndex; }
uint stripe_shift_for(uint stripes) {
    uint groups = workgroup_count();
    // ceil(log2(groups)) - log2(stripes), at least 0.
    return groups <= stripes ? 0u : uint(findMSB(groups - 1u)) + 1u - uint(findMSB(stripes));
}
uint stripe_of(uint stripes) { return workgroup_index() >> stripe_shift_for(stripes); }

// The slot of ray counter `k` (RAY_*, COUNTER_SAMPLES) of the ray-traced and hybrid passes in
// this workgroup's stripe.
uint ray_counter_slot(uint k) { return stripe_of(RAY_COUNTER_STRIPES) * RAY_COUNTER_STRIDE + k; }

// Adds `value` of every active invocation to `counter`. Call from all invocations that count
// (an invocation that has nothing to add passes 0).
#define COUNTER_ADD(counter, value)                          \
    {                                                        \
        uint sum_ = subgroupAdd(value);                      \
        if (subgroupElect() && sum_ != 0u) {                 \
            atomicAdd(counter, sum_);                        \
        }                                                    \
    }
#endif
