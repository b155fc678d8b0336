// Statistics counters (rays by kind, samples) summed per subgroup, then one atomic per
// subgroup: a CPU Vulkan (lavapipe) runs the invocations of a workgroup on different cores, and
// one atomic per invocation on the same cache line costs as much as shading a pixel.
#ifndef RQR_COUNTERS_GLSL
#define RQR_COUNTERS_GLSL
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require

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
