// variants: hw bvh
#version 460
// Pure ray-traced path in the Whitted model (the pass itself: raytrace_main.glsl).
#extension GL_GOOGLE_include_directive : require
#include "raytrace_main.glsl"
