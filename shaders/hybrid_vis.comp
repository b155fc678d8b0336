// variants: hw bvh
#version 460
// Hybrid shading pass reading the visibility buffer (`--gbuffer visibility`); see
// hybrid_main.glsl.
#extension GL_GOOGLE_include_directive : require
#define HYBRID_VISIBILITY 1
#include "hybrid_main.glsl"
