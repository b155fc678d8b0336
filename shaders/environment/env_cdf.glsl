// The workgroup scan shared by env_sampling_rows.comp and env_sampling_marginal.comp: n
// non-negative values (env_cdf_value, defined by the includer) into the normalised CDF of
// n + 1 floats the sampler reads (env_sampling.glsl). src/environment/sampling.rs builds the
// same table on the host in f64, as the reference: entry 0 is 0, entry n exactly 1, entry i the
// sum of the first i values over the sum of all; a sum of 0 gives the uniform CDF i / n.
//
// Accuracy in f32: each invocation sums a contiguous chunk of n / 256 values in order, and the
// chunks' sums are scanned as a tree (8 levels), so an entry's rounding error is about
// (n / 256 + 8) ulp of the total, not n ulp as a sequential scan's. The tree rounds differently
// at chunk borders, where an entry could come out one ulp below its predecessor; a max-scan
// (exact in floating point) keeps the CDF non-decreasing, which the sampler's binary search and
// bin widths (probabilities) rely on.
#ifndef RQR_ENV_CDF_GLSL
#define RQR_ENV_CDF_GLSL

#define ENV_CDF_GROUP 256u

layout(buffer_reference, scalar, buffer_reference_align = 4) buffer EnvTable { float v[]; };

shared float env_cdf_shared[ENV_CDF_GROUP];

// Value i of the sequence, i < n (non-negative).
float env_cdf_value(uint i);

// Inclusive scan of `v` over the workgroup by sum (max_op false) or max (true), Hillis–Steele;
// `exclusive` gets the scan of the invocations before this one, `last` the scan of all. Every
// invocation must call it (it has barriers).
void env_cdf_scan(float v, bool max_op, out float exclusive, out float last) {
    uint lid = gl_LocalInvocationID.x;
    env_cdf_shared[lid] = v;
    float inclusive = v;
    for (uint offset = 1u; offset < ENV_CDF_GROUP; offset <<= 1) {
        barrier();
        float other = lid >= offset ? env_cdf_shared[lid - offset] : 0.0;
        barrier();
        inclusive = max_op ? max(inclusive, other) : inclusive + other;
        env_cdf_shared[lid] = inclusive;
    }
    barrier();
    exclusive = lid > 0u ? env_cdf_shared[lid - 1u] : 0.0;
    last = env_cdf_shared[ENV_CDF_GROUP - 1u];
    barrier();
}

// Writes the CDF of the n values to table.v[base .. base + n] and returns their sum.
float env_cdf_build(EnvTable table, uint base, uint n) {
    uint lid = gl_LocalInvocationID.x;
    uint chunk = (n + ENV_CDF_GROUP - 1u) / ENV_CDF_GROUP;
    uint begin = min(lid * chunk, n);
    uint end = min(begin + chunk, n);
    float partial = 0.0;
    for (uint i = begin; i < end; ++i) {
        partial += env_cdf_value(i);
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
            // Read before the write below: the marginal pass scans its values in place.
            prefix += env_cdf_value(i);
            c = max(min((offset + prefix) / total, 1.0), before);
        }
        table.v[base + i + 1u] = c;
    }
    return total;
}

#endif
