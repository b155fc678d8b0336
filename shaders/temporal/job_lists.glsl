// Temporal reuse: the job lists the tracing passes work through, and the striped statistics
// counters the passes settle pixels into.
// Included by temporal.glsl (in its order: each part uses the ones before it).
// Job lists. The stage that settles the pixels lists those the verify pass looks at (list
// 0, rt path) and the first pixels to trace (list 1); the verify pass adds the candidates
// it rejects to list 1; each adaptive interpolation lists the next level's pixels in list 0,
// whose verify jobs are done by then. Tracing passes run one job per invocation, 64 per
// workgroup.
uint job_count(uint list) { return dispatch_args[4u * list + 3u]; }
uint job_at(uint list, uint i) { return JOBS(list * pixel_count() + i); }

// The counter slot that holds list `list`'s length while stages append to it.
uint list_counter(uint list) {
    return list == LIST_VERIFY ? C_JOBS : (list == LIST_TRACE ? C_TRACE_JOBS : C_PENDING_JOBS);
}

// The counter slot of statistic `slot` (ray kinds, C_SAMPLES, the pixel counts) for this
// workgroup: its stripe's copy (COUNTER_STRIPES in src/interface/reproject.rs; counters.glsl).
uint stripe_shift() { return stripe_shift_for(COUNTER_STRIPES); }
uint stripe() { return stripe_of(COUNTER_STRIPES); }
uint stat_slot(uint slot) { return (stripe() + 1u) * COUNTER_STRIPE_WORDS + slot; }

// After every append of the dispatch (`leader`: one elected lane of each subgroup): the last
// subgroup to finish turns the lengths of the lists in the bit set `lists` into their indirect
// dispatches, so no separate pass and barrier is needed. Subgroups count themselves done per stripe, and the last of each stripe once more
// in a shared counter (one shared atomic per stripe, not per subgroup). List 0 restarts at zero
// for the next stage that lists into it; the others keep their lengths for the later passes
// that append to them.
void lists_done(uint lists, bool leader) {
    if (leader) {
        // This subgroup's appends are counted before it counts itself done.
        memoryBarrierBuffer();
        uint groups = workgroup_count();
        uint shift = stripe_shift();
        uint members = min(1u << shift, groups - (stripe() << shift));
        uint slot = stat_slot(C_STRIPE_DONE);
        if (atomicAdd(counters[slot], 1u) + 1u == members * gl_NumSubgroups) {
            counters[slot] = 0u;
            memoryBarrierBuffer();
            uint stripes = (groups + (1u << shift) - 1u) >> shift;
            if (atomicAdd(counters[C_TILES_DONE], 1u) + 1u == stripes) {
                for (uint list = 0u; list < JOB_LISTS; ++list) {
                    if ((lists & (1u << list)) != 0u) {
                        uint n = list == LIST_VERIFY ? atomicExchange(counters[C_JOBS], 0u) : atomicAdd(counters[list_counter(list)], 0u);
                        // Rows of workgroups (GROUPS_PER_ROW; rqr::vk::rows_of_groups).
                        uint groups = (n + 63u) / 64u;
                        uint row = min(groups, GROUPS_PER_ROW);
                        dispatch_args[4u * list] = row;
                        dispatch_args[4u * list + 1u] = row == 0u ? 1u : (groups + row - 1u) / row;
                        dispatch_args[4u * list + 2u] = 1u;
                        dispatch_args[4u * list + 3u] = n;
                    }
                }
                counters[C_TILES_DONE] = 0u;
            }
        }
    }
}

// Counts settled state `settled` (0: nothing to count; a pixel is counted once, by the pass
// that settles it, and the tracing and interpolation passes count the kinds they turn pixels
// into) and appends q to the job lists `list[i]` whose `take[i]` holds (the first `lists` of
// them are used). Stream compaction in tile order: every subgroup writes its jobs contiguously
// in invocation order after one atomic per list (a subgroup covers one or more rows of an 8x8
// tile), so neighbouring lanes of a tracing pass trace neighbouring pixels; ballots, not scans,
// and no workgroup barrier (a CPU device runs shaders with barrier() as coroutines, which cost
// more than the atomics they would save). One lane, `leader` (subgroupElect(), elected once by the caller), does every
// atomic, and one broadcast hands the lists' offsets back: a CPU device (lavapipe) runs each
// subgroup operation (election, ballot, reduction, broadcast) as a loop over the lanes. The
// seven 0/1 counts travel as 8-bit fields of two words, one reduction for all (a subgroup has
// at most 128 lanes). Call from every invocation of the dispatch.
const uint SETTLED_COUNTERS[7] = uint[7](C_REUSED, C_HOLES, C_REJECTED, C_VIEW_DEPENDENT, C_EXPIRED, C_FRAMELESS, C_FILLED);

void settle_and_list(uint settled, uvec3 list, bvec3 take, uint lists, uint q, bool leader) {
    uint kind = settled & PX_KIND_MASK;
    uvec2 packed = uvec2((kind == PX_REUSE ? 1u : 0u) | ((settled & PX_HOLE) != 0u ? 1u << 8 : 0u)
                             | ((settled & PX_REJECTED) != 0u ? 1u << 16 : 0u) | ((settled & PX_VIEW_DEPENDENT) != 0u ? 1u << 24 : 0u),
                         ((settled & PX_EXPIRED) != 0u ? 1u : 0u) | ((settled & PX_FRAMELESS) != 0u ? 1u << 8 : 0u)
                             | ((settled & PX_FILLED) != 0u && kind == PX_REUSE ? 1u << 16 : 0u));
    uvec2 sums = subgroupAdd(packed);
    uvec4 b0 = subgroupBallot(take.x);
    uvec4 b1 = subgroupBallot(take.y);
    uvec4 b2 = lists > 2u ? subgroupBallot(take.z) : uvec4(0u);
    uvec3 total = uvec3(subgroupBallotBitCount(b0), subgroupBallotBitCount(b1), subgroupBallotBitCount(b2));
    uvec3 base = uvec3(0u);
    if (leader) {
        [[unroll]] for (uint k = 0u; k < 7u; ++k) {
            uint n = ((k < 4u ? sums.x : sums.y) >> (8u * (k & 3u))) & 255u;
            if (n != 0u) {
                atomicAdd(counters[stat_slot(SETTLED_COUNTERS[k])], n);
            }
        }
        if (total.x != 0u) base.x = atomicAdd(counters[list_counter(list.x)], total.x);
        if (total.y != 0u) base.y = atomicAdd(counters[list_counter(list.y)], total.y);
        if (total.z != 0u) base.z = atomicAdd(counters[list_counter(list.z)], total.z);
    }
    if ((total.x | total.y | total.z) == 0u) {
        return;
    }
    base = subgroupBroadcastFirst(base);
    uint n = pixel_count();
    if (take.x) JOBS(list.x * n + base.x + subgroupBallotExclusiveBitCount(b0)) = q;
    if (take.y) JOBS(list.y * n + base.y + subgroupBallotExclusiveBitCount(b1)) = q;
    if (take.z) JOBS(list.z * n + base.z + subgroupBallotExclusiveBitCount(b2)) = q;
}
