// variants: hw bvh
#version 460
// Pure ray-traced path in the distributed model (the pass itself: raytrace_main.glsl).
#extension GL_GOOGLE_include_directive : require
#define SHADING_DISTRIBUTED 1
#include "raytrace_main.glsl"
