// The workgroup scan shared by env_sampling_rows.comp and env_sampling_marginal.comp: n
// non-negative values (env_cdf_value, defined by the includer) into the normalised CDF of
// n + 1 floats the sampler reads (env_sampling.glsl). src/environment/sampling.rs builds the
// same table on the host in f64, as the reference: entry 0 is 0, entry n exactly 1, entry i the
// sum of the first i values over the sum of all; a sum of 0 gives the uniform CDF i / n.
//
// Accuracy in f32: each invocation sums a contiguous chunk of n / 64 values in order, and the
// chunks' sums are scanned by subgroup operations and then over the subgroups' totals, so an
// entry's rounding error is some tens of ulp of the total at most, not n ulp as one sequential
// scan's (measured on the shipped maps: within 3e-7, 5 ulp of 1, of the host's f64 table). The
// scan rounds differently at chunk and subgroup borders, where an entry could come out an ulp
// below its predecessor; a max-scan (exact in floating point) keeps the CDF non-decreasing,
// which the sampler's binary search and bin widths (probabilities) rely on.
//
// 64 invocations a workgroup: on lavapipe, which runs a workgroup's invocations as coroutines
// switched at every barrier, 256 took three times as long (17 against 6 ms for 1024×512).
#ifndef RQR_ENV_CDF_GLSL
#define RQR_ENV_CDF_GLSL

#define ENV_CDF_GROUP 64u

layout(buffer_reference, scalar, buffer_reference_align = 4) buffer EnvTable { float v[]; };

shared float env_cdf_shared[ENV_CDF_GROUP];

// Value i of the sequence, i < n (non-negative); read once per i, before any entry is written
// but this invocation's own.
float env_cdf_value(uint i);

// Scan of `v` over the workgroup by sum (max_op false) or max (true): `exclusive` gets the
// scan of the invocations before this one, `last` the scan of all. Within a subgroup by
// subgroup operations, then over the subgroups' totals in order, which costs two barriers (a
// barrier per step of a shared-memory tree is what a CPU device pays most for). Every
// invocation must call it.
void env_cdf_scan(float v, bool max_op, out float exclusive, out float last) {
    // Lane 0's exclusive max is -inf: the max with `before` (>= 0) below replaces it.
    float own = max_op ? subgroupExclusiveMax(v) : subgroupExclusiveAdd(v);
    float subgroup_total = max_op ? subgroupMax(v) : subgroupAdd(v);
    if (subgroupElect()) env_cdf_shared[gl_SubgroupID] = subgroup_total;
    barrier();
    float before = 0.0, all = 0.0;
    for (uint s = 0u; s < gl_NumSubgroups; ++s) {
        if (s == gl_SubgroupID) before = all;
        float t = env_cdf_shared[s];
        all = max_op ? max(all, t) : all + t;
    }
    barrier();
    exclusive = max_op ? max(before, own) : before + own;
    last = all;
}

// Writes the CDF of the n values to table.v[base .. base + n] and returns their sum.
float env_cdf_build(EnvTable table, uint base, uint n) {
    uint lid = gl_LocalInvocationID.x;
    uint chunk = (n + ENV_CDF_GROUP - 1u) / ENV_CDF_GROUP;
    uint begin = min(lid * chunk, n);
    uint end = min(begin + chunk, n);
    // The values are kept in the entries they become (entry i + 1 for value i; this
    // invocation's own), so that the second loop reads them back from there: a texel is
    // fetched once.
    float partial = 0.0;
    for (uint i = begin; i < end; ++i) {
        float v = env_cdf_value(i);
        table.v[base + i + 1u] = v;
        partial += v;
    }
    float offset, total;
    env_cdf_scan(partial, false, offset, total);
    bool uniform_cdf = !(total > 0.0);
    // This chunk's last entry (entries grow within a chunk); the max of those before it.
    float chunk_last = uniform_cdf ? 0.0 : min((offset + partial) / total, 1.0);
    float before, unused;
    env_cdf_scan(chunk_last, true, before, unused);
    if (lid == 0u) table.v[base] = 0.0;
    float prefix = 0.0;
    for (uint i = begin; i < end; ++i) {
        float c;
        if (i + 1u == n) {
            c = 1.0;
        } else if (uniform_cdf) {
            c = float(i + 1u) / float(n);
        } else {
            prefix += table.v[base + i + 1u];
            c = max(min((offset + prefix) / total, 1.0), before);
        }
        table.v[base + i + 1u] = c;
    }
    return total;
}

#endif
