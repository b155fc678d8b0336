// variants: hw bvh
#version 460
// Temporal reuse, trace, in the distributed model (the stage itself: trace_main.glsl).
#extension GL_GOOGLE_include_directive : require
#define SHADING_DISTRIBUTED 1
#include "trace_main.glsl"
