// variants: hw bvh
#version 460
// Temporal reuse, trace, in the Whitted model (the stage itself: trace_main.glsl).
#extension GL_GOOGLE_include_directive : require
#include "trace_main.glsl"
