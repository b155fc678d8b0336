// variants: hw bvh
#version 460
// Hybrid shading pass reading the full G-buffer (`--gbuffer full`); see hybrid_main.glsl.
#extension GL_GOOGLE_include_directive : require
#include "hybrid_main.glsl"
