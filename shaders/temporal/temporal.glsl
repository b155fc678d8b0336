// Temporal reuse (src/render/temporal/): the per-pixel sample cache, pixel states, parameters
// and the tests shared by the technique's passes (temporal_*.comp). Include after scene.glsl
// and frame.glsl. The parts, each a concern of its own, follow in the order they build on
// each other.
//
// Every binding, flag, stage, counter slot and shared struct (CacheEntry, Shown, GpuParams,
// the push constants) is declared once, in src/interface/reproject.rs, from which build.rs
// generates interface_reproject.glsl.
#ifndef RQR_TEMPORAL_GLSL
#define RQR_TEMPORAL_GLSL
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
// [[unroll]] on the short loops over neighbours and counters: a CPU device (lavapipe) keeps a
// local array indexed by a loop variable on the stack and gathers from it lane by lane.
#extension GL_EXT_control_flow_attributes : require
#include "counters.glsl"
#include "interface_passes.glsl"
#include "tonemap.glsl"
#include "interface_reproject.glsl"
#include "environment.glsl"

#include "cache_entry.glsl"
#include "buffers.glsl"
#include "job_lists.glsl"
#include "pixels.glsl"
#include "projection.glsl"
#include "judge.glsl"
#include "anchor.glsl"
#include "commit.glsl"

#endif
